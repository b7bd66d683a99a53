"""Collisions: detected from footprints, merged with the simulator's contact events, classified.

Footprint overlap (oriented rectangles from x, y, yaw, length, width) is
checked at every step, so traces from a backend without contact events still
yield collisions. One row per (variation, actor pair): the first contact.
Classes follow rules.md: `rear_end` (relative heading under 30 deg, struck from
behind), `head_on` (over 150 deg), `angle` (60-120 deg), `sideswipe` (otherwise,
and same- or opposite-direction contact that is side to side).
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

from crashscene.monitor.arrays import TraceArrays
from crashscene.geometry import (
    classify_contact,
    footprints_overlap,
    heading_difference,
    pair_indices,
    relative_position,
)
from crashscene.monitor.timeseries import first_index
from crashscene.traces import COLLISION_SCHEMA

COLLISION_CLASSES = ("rear_end", "head_on", "angle", "sideswipe")

# The contract's contact columns (traces.COLLISION_SCHEMA; actor_a/actor_b in role order, ego first), then
# what classification adds.
CLASSIFIED_SCHEMA = pa.schema(list(COLLISION_SCHEMA) + [
    ("relative_heading_deg", pa.float64()),  # [deg] in [0, 180]
    ("class", pa.string()),             # COLLISION_CLASSES
    ("striking_actor", pa.string()),    # the actor whose front made the contact (null for a sideswipe)
    ("source", pa.string()),            # simulator | footprint | both
    ("involves_ads", pa.bool_()),       # an actor under test (is_ads) is one of the two
])


def footprint_contacts(arrays: TraceArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First overlapping step per (variation, unordered pair): (pair_a, pair_b, step (V, P), -1 none)."""
    ia, ib = pair_indices(arrays.shape[1])
    n_var, _, n_steps = arrays.shape
    first = np.full((n_var, len(ia)), -1, dtype=np.int64)
    if not len(ia) or n_steps == 0:
        return ia, ib, first
    f = arrays.floats
    x = np.where(arrays.alive, f["x"], np.nan)
    y, yaw = f["y"], f["yaw"]
    diag = np.hypot(arrays.length, arrays.width) / 2
    for p, (a, b) in enumerate(zip(ia, ib)):
        # cheap distance gate, then the separating-axis test on the few candidate steps
        with np.errstate(invalid="ignore"):
            near = np.hypot(x[:, a] - x[:, b], y[:, a] - y[:, b]) <= (diag[:, a] + diag[:, b])[:, None]
        overlap = np.zeros((n_var, n_steps), dtype=bool)
        if near.any():
            vv, tt = np.nonzero(near)
            overlap[vv, tt] = footprints_overlap(x[vv, a, tt], y[vv, a, tt], yaw[vv, a, tt], arrays.length[vv, a],
                                                 arrays.width[vv, a], x[vv, b, tt], y[vv, b, tt], yaw[vv, b, tt],
                                                 arrays.length[vv, b], arrays.width[vv, b])
        first[:, p] = first_index(overlap)
    return ia, ib, first


def classify_collisions(arrays: TraceArrays, contacts: pa.Table | None, ads: np.ndarray) -> pa.Table:
    """Merge footprint and simulator contacts, one row per (variation, pair), and classify them.

    `ads` (V, A) marks the actors under test.
    """
    n_var, _, n_steps = arrays.shape
    ia, ib, first = footprint_contacts(arrays)
    pair_of = {(int(a), int(b)): p for p, (a, b) in enumerate(zip(ia, ib))}
    t_first = np.full(first.shape, np.inf)
    hit = first >= 0
    time = arrays.time()
    for p, (a, _) in enumerate(zip(ia, ib)):
        t_first[hit[:, p], p] = time[hit[:, p], a, first[hit[:, p], p]]
    source = np.where(hit, "footprint", "").astype(object)
    sim_xy = np.full(first.shape + (2,), np.nan)
    sim_t = np.full(first.shape, np.inf)
    role_index = {r: i for i, r in enumerate(arrays.roles)}
    if contacts is not None and contacts.num_rows:
        rows = contacts.to_pydict()
        for k in range(contacts.num_rows):
            v = int(np.searchsorted(arrays.variations, rows["variation"][k]))
            if v >= n_var or arrays.variations[v] != rows["variation"][k]:
                continue
            ra, rb = role_index.get(rows["actor_a"][k]), role_index.get(rows["actor_b"][k])
            if ra is None or rb is None or ra == rb:
                continue
            p = pair_of[(min(ra, rb), max(ra, rb))]
            t = rows["t"][k] if rows["t"][k] is not None else np.nan
            if np.isfinite(t) and t < sim_t[v, p]:
                sim_t[v, p] = t
                sim_xy[v, p] = [np.nan if rows["x"][k] is None else rows["x"][k],
                                np.nan if rows["y"][k] is None else rows["y"][k]]
    sim_hit = np.isfinite(sim_t)
    source = np.where(sim_hit & hit, "both", np.where(sim_hit, "simulator", source))
    t_event = np.fmin(t_first, sim_t)
    any_hit = hit | sim_hit
    vv, pp = np.nonzero(any_hit)
    if not len(vv):
        return CLASSIFIED_SCHEMA.empty_table()
    a_idx, b_idx = ia[pp], ib[pp]
    # state at the contact: the footprint step, or the step nearest the simulator's time
    sim_step = np.clip(np.round(np.where(np.isfinite(sim_t[vv, pp]), sim_t[vv, pp], 0) / arrays.dt), 0, n_steps - 1)
    step = np.where(hit[vv, pp] & (t_first[vv, pp] <= sim_t[vv, pp]), first[vv, pp], sim_step.astype(np.int64))
    f = arrays.floats
    xa, ya, yawa, va = (f[c][vv, a_idx, step] for c in ("x", "y", "yaw", "speed"))
    xb, yb, yawb, vb = (f[c][vv, b_idx, step] for c in ("x", "y", "yaw", "speed"))
    rel = heading_difference(yawa, yawb)
    lon_ab, lat_ab = relative_position(xa, ya, yawa, xb, yb)
    lon_ba, lat_ba = relative_position(xb, yb, yawb, xa, ya)
    half_len = (arrays.length[vv, a_idx] + arrays.length[vv, b_idx]) / 2
    half_wid = (arrays.width[vv, a_idx] + arrays.width[vv, b_idx]) / 2
    cls = classify_contact(rel, lon_ab, lat_ab, half_len, half_wid)
    # the striker has the other ahead of it: larger forward offset relative to its lateral offset
    a_strikes = (lon_ab - np.abs(lat_ab)) >= (lon_ba - np.abs(lat_ba))
    head_on = cls == "head_on"
    a_strikes = np.where(head_on, va >= vb, a_strikes)
    roles = np.asarray(arrays.roles, dtype=object)
    striking = np.where(a_strikes, roles[a_idx], roles[b_idx]).astype(object)
    striking[cls == "sideswipe"] = None
    cx = np.where(np.isfinite(sim_xy[vv, pp, 0]), sim_xy[vv, pp, 0], (xa + xb) / 2)
    cy = np.where(np.isfinite(sim_xy[vv, pp, 1]), sim_xy[vv, pp, 1], (ya + yb) / 2)
    order = np.lexsort((pp, t_event[vv, pp], vv))
    columns = {
        "variation": arrays.variations[vv].astype(np.int32),
        "t": t_event[vv, pp],
        "actor_a": roles[a_idx],
        "actor_b": roles[b_idx],
        "speed_a": va, "speed_b": vb, "yaw_a": yawa, "yaw_b": yawb, "x": cx, "y": cy,
        "relative_heading_deg": np.degrees(rel),
        "class": cls,
        "striking_actor": striking,
        "source": source[vv, pp],
        "involves_ads": ads[vv, a_idx] | ads[vv, b_idx],
    }
    return pa.table({k: pa.array(list(v[order]) if v.dtype == object else v[order], type=CLASSIFIED_SCHEMA.field(k).type)
                     for k, v in columns.items()}, schema=CLASSIFIED_SCHEMA)


def first_contact_steps(arrays: TraceArrays, collisions: pa.Table) -> np.ndarray:
    """(V, A) step of each actor's first collision, -1 when it never collides."""
    out = np.full(arrays.shape[:2], -1, dtype=np.int64)
    if not collisions.num_rows:
        return out
    role_index = {r: i for i, r in enumerate(arrays.roles)}
    v = np.searchsorted(arrays.variations, collisions.column("variation").to_numpy())
    step = np.round(collisions.column("t").to_numpy() / arrays.dt).astype(np.int64)
    big = np.iinfo(np.int64).max
    best = np.full(arrays.shape[:2], big, dtype=np.int64)
    for col in ("actor_a", "actor_b"):
        a = np.array([role_index[r] for r in collisions.column(col).to_pylist()], dtype=np.int64)
        np.minimum.at(best, (v, a), step)
    return np.where(best < big, best, -1)
