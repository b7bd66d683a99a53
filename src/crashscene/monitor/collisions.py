"""Contacts: detected from footprints, merged with the simulator's contact events, classified.

Footprint overlap (oriented rectangles from x, y, yaw, length, width) is
checked at every step, so traces from a backend without contact events still
yield contacts. One row per *contact*: every onset of overlap of an actor pair.
rules.md defines a collision as two footprints overlapping, nothing more, so a
contact lasts while they overlap and ends at the first recorded step they are
apart; touching again later is a new contact (a car pushed back into the vehicle
that struck it, two bodies turned by a first impact whose sides slap together),
classed, like any contact, from the relative heading at its own onset. Rows are
in time order with their `contact_index` in the variation. A simulator event of
the same pair during a footprint contact (from SAME_CONTACT before its onset to
the step after it ends) is that contact.
Classes follow rules.md: `rear_end` (relative heading under 30 deg, struck from
behind), `head_on` (over 150 deg), `angle` (60-120 deg), `sideswipe` (otherwise,
and same- or opposite-direction contact that is side to side). The area of
each vehicle that touched (front, rear, left, right: the quarter of its
footprint, split by the diagonals, holding the centre of the overlap at the
first overlapping step) is what dsl.md's `collisions` areas are compared with.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

from crashscene.geometry import (
    contact_areas,
    footprints_overlap,
    overlap_centre,
    pair_indices,
    pose_class,
    relative_position,
)
from crashscene.monitor.arrays import TraceArrays
from crashscene.monitor.judging import contact_indices
from crashscene.traces import COLLISION_SCHEMA

COLLISION_CLASSES = ("rear_end", "head_on", "angle", "sideswipe")
SAME_CONTACT = 0.3   # [s] a simulator event this close to a footprint onset of the same pair is that contact

# The contract's contact columns (traces.COLLISION_SCHEMA; actor_a/actor_b in role order, ego first), then
# what classification adds.
CLASSIFIED_SCHEMA = pa.schema(list(COLLISION_SCHEMA) + [
    ("relative_heading_deg", pa.float64()),  # [deg] in [0, 180]
    ("class", pa.string()),             # COLLISION_CLASSES
    ("striking_actor", pa.string()),    # the actor whose front made the contact (null for a sideswipe)
    ("source", pa.string()),            # simulator | footprint | both
    ("involves_ads", pa.bool_()),       # an actor under test (is_ads) is one of the two
    ("contact_index", pa.int32()),      # order of the contact within its variation, from 0
    ("area_a", pa.string()),            # front | rear | left | right: the quarter of actor_a that touched
    ("area_b", pa.string()),
])


def pair_overlaps(arrays: TraceArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Footprint overlap of every unordered actor pair: (pair_a, pair_b, overlap (V, P, T) bool)."""
    ia, ib = pair_indices(arrays.shape[1])
    n_var, _, n_steps = arrays.shape
    overlap = np.zeros((n_var, len(ia), n_steps), dtype=bool)
    if not len(ia) or n_steps == 0:
        return ia, ib, overlap
    f = arrays.floats
    x = np.where(arrays.alive, f["x"], np.nan)
    y, yaw = f["y"], f["yaw"]
    diag = np.hypot(arrays.length, arrays.width) / 2
    for p, (a, b) in enumerate(zip(ia, ib)):
        # cheap distance gate, then the separating-axis test on the few candidate steps
        with np.errstate(invalid="ignore"):
            near = np.hypot(x[:, a] - x[:, b], y[:, a] - y[:, b]) <= (diag[:, a] + diag[:, b])[:, None]
        if near.any():
            vv, tt = np.nonzero(near)
            overlap[vv, p, tt] = footprints_overlap(x[vv, a, tt], y[vv, a, tt], yaw[vv, a, tt], arrays.length[vv, a],
                                                    arrays.width[vv, a], x[vv, b, tt], y[vv, b, tt], yaw[vv, b, tt],
                                                    arrays.length[vv, b], arrays.width[vv, b])
    return ia, ib, overlap


def contact_onsets(overlap: np.ndarray) -> np.ndarray:
    """(V, P, T) True where a contact begins: overlap where the footprints were apart at the step before."""
    before = np.zeros_like(overlap)
    before[..., 1:] = overlap[..., :-1]
    return overlap & ~before


def _simulator_events(arrays: TraceArrays, contacts: pa.Table | None,
                      pair_of: dict[tuple[int, int], int]) -> dict[tuple[int, int], list[dict]]:
    """The simulator's contact rows by (variation index, pair), each with t, x, y and the two delta-v."""
    events: dict[tuple[int, int], list[dict]] = {}
    if contacts is None or not contacts.num_rows:
        return events
    n_rows, n_var = contacts.num_rows, arrays.shape[0]
    role_index = {r: i for i, r in enumerate(arrays.roles)}
    variation = contacts.column("variation").to_numpy()
    v = np.searchsorted(arrays.variations, variation)
    known = v < n_var
    known[known] = arrays.variations[v[known]] == variation[known]

    def floats(name: str) -> np.ndarray:  # NaN where missing or null
        if name not in contacts.column_names:
            return np.full(n_rows, np.nan)
        return contacts.column(name).to_numpy(zero_copy_only=False).astype(float)

    t, x, y, dva, dvb = (floats(name) for name in ("t", "x", "y", "delta_v_a", "delta_v_b"))
    keep = known & np.isfinite(t)
    ra = [role_index.get(role) for role in contacts.column("actor_a").to_pylist()]
    rb = [role_index.get(role) for role in contacts.column("actor_b").to_pylist()]
    for k in np.flatnonzero(keep).tolist():
        a, b = ra[k], rb[k]
        if a is None or b is None or a == b:
            continue
        dv = (float(dvb[k]), float(dva[k])) if a > b else (float(dva[k]), float(dvb[k]))
        events.setdefault((int(v[k]), pair_of[(min(a, b), max(a, b))]), []).append(
            {"t": float(t[k]), "x": float(x[k]), "y": float(y[k]), "dv": dv})
    return events


def _merge_events(overlap: np.ndarray, onset_steps: np.ndarray, time: np.ndarray,
                  sim: list[dict]) -> list[tuple[float, int, str, dict]]:
    """Footprint contacts (from each onset to its last overlapping step) and simulator events of one pair in one
    variation, as contacts: (t, footprint onset step or -1, source, simulator event or {}). A simulator event
    that falls within a footprint contact (SAME_CONTACT before its onset to the step after its end) is it."""
    out: list[tuple[float, int, str, dict]] = []
    unused = sorted(sim, key=lambda e: e["t"])
    touching = np.nonzero(overlap)[0]
    for k, step in enumerate(onset_steps):
        nxt = onset_steps[k + 1] if k + 1 < len(onset_steps) else len(overlap)
        end = touching[np.searchsorted(touching, nxt) - 1]  # the last overlapping step before the next onset
        t0, t1 = float(time[step]) - SAME_CONTACT, float(time[min(end + 1, len(time) - 1)])
        inside = [e for e in unused if t0 <= e["t"] <= t1]
        for e in inside:
            unused.remove(e)
        if inside:
            out.append((min(float(time[step]), inside[0]["t"]), int(step), "both", inside[0]))
        else:
            out.append((float(time[step]), int(step), "footprint", {}))
    out += [(e["t"], -1, "simulator", e) for e in unused]
    return sorted(out, key=lambda item: item[0])


def classify_collisions(arrays: TraceArrays, contacts: pa.Table | None, ads: np.ndarray) -> pa.Table:
    """Merge footprint and simulator contacts, one row per contact, and classify them.

    `ads` (V, A) marks the actors under test.
    """
    n_var, _, n_steps = arrays.shape
    ia, ib, overlap = pair_overlaps(arrays)
    pair_of = {(int(a), int(b)): p for p, (a, b) in enumerate(zip(ia, ib))}
    onsets = contact_onsets(overlap) if overlap.size else overlap
    sim = _simulator_events(arrays, contacts, pair_of)
    time = arrays.time()
    keys = sorted({(int(v), int(p)) for v, p in zip(*np.nonzero(onsets.any(axis=2)))} | set(sim))
    rows: list[tuple] = []  # (v, pair, t, step, source, event)
    for v, p in keys:
        steps = np.nonzero(onsets[v, p])[0] if overlap.size else np.zeros(0, dtype=int)
        touching = overlap[v, p] if overlap.size else np.zeros(n_steps, dtype=bool)
        for t, step, source, event in _merge_events(touching, steps, time[v, ia[p]], sim.get((v, p), [])):
            if step < 0:  # state at the simulator's time
                step = int(np.clip(round(t / arrays.dt), 0, max(n_steps - 1, 0)))
            rows.append((v, p, t, step, source, event))
    if not rows:
        return CLASSIFIED_SCHEMA.empty_table()
    rows.sort(key=lambda r: (r[0], r[2], r[1]))
    vv = np.array([r[0] for r in rows], dtype=np.int64)
    pp = np.array([r[1] for r in rows], dtype=np.int64)
    step = np.array([r[3] for r in rows], dtype=np.int64)
    t_event = np.array([r[2] for r in rows])
    a_idx, b_idx = ia[pp], ib[pp]
    f = arrays.floats
    xa, ya, yawa, va = (f[c][vv, a_idx, step] for c in ("x", "y", "yaw", "speed"))
    xb, yb, yawb, vb = (f[c][vv, b_idx, step] for c in ("x", "y", "yaw", "speed"))
    la, wa = arrays.length[vv, a_idx], arrays.width[vv, a_idx]
    lb, wb = arrays.length[vv, b_idx], arrays.width[vv, b_idx]
    cls, rel, lon_ab, lat_ab = pose_class(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb)
    lon_ba, lat_ba = relative_position(xb, yb, yawb, xa, ya)
    # the striker has the other ahead of it: larger forward offset relative to its lateral offset
    a_strikes = (lon_ab - np.abs(lat_ab)) >= (lon_ba - np.abs(lat_ba))
    a_strikes = np.where(cls == "head_on", va >= vb, a_strikes)
    roles = np.asarray(arrays.roles, dtype=object)
    striking = np.where(a_strikes, roles[a_idx], roles[b_idx]).astype(object)
    striking[cls == "sideswipe"] = None
    sim_x = np.array([r[5].get("x", np.nan) for r in rows])
    sim_y = np.array([r[5].get("y", np.nan) for r in rows])
    cx, cy = overlap_centre(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb)
    cx = np.where(np.isfinite(cx), cx, np.where(np.isfinite(sim_x), sim_x, (xa + xb) / 2))
    cy = np.where(np.isfinite(cy), cy, np.where(np.isfinite(sim_y), sim_y, (ya + yb) / 2))
    area_a, area_b = contact_areas(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb, cx, cy)
    index = np.zeros(len(rows), dtype=np.int32)
    for k in range(1, len(rows)):
        index[k] = index[k - 1] + 1 if vv[k] == vv[k - 1] else 0
    dv = np.array([r[5].get("dv", (np.nan, np.nan)) for r in rows], dtype=float).reshape(-1, 2)
    columns = {
        "variation": arrays.variations[vv].astype(np.int32),
        "t": t_event,
        "actor_a": roles[a_idx],
        "actor_b": roles[b_idx],
        "speed_a": va, "speed_b": vb, "yaw_a": yawa, "yaw_b": yawb,
        "x": np.where(np.isfinite(sim_x), sim_x, cx), "y": np.where(np.isfinite(sim_y), sim_y, cy),
        "delta_v_a": dv[:, 0], "delta_v_b": dv[:, 1],
        "relative_heading_deg": np.degrees(rel),
        "class": cls,
        "striking_actor": striking,
        "source": np.array([r[4] for r in rows], dtype=object),
        "involves_ads": ads[vv, a_idx] | ads[vv, b_idx],
        "contact_index": index,
        "area_a": area_a,
        "area_b": area_b,
    }
    return pa.table({k: pa.array(list(v) if v.dtype == object else v,
                                 type=CLASSIFIED_SCHEMA.field(k).type, from_pandas=True)
                     for k, v in columns.items()}, schema=CLASSIFIED_SCHEMA)


def first_contact_steps(arrays: TraceArrays, collisions: pa.Table) -> np.ndarray:
    """(V, A) step of each actor's first collision, -1 when it never collides."""
    out = np.full(arrays.shape[:2], -1, dtype=np.int64)
    if not collisions.num_rows:
        return out
    v, *pair, step = contact_indices(arrays, collisions, rounded=True)
    big = np.iinfo(np.int64).max
    best = np.full(arrays.shape[:2], big, dtype=np.int64)
    for a in pair:
        np.minimum.at(best, (v, a), step)
    return np.where(best < big, best, -1)
