"""Criticality metrics per variation and actor pair, from the trace alone (any backend).

For every unordered pair of actors (a, b) of every variation:

- `min_ttc` [s]: minimum time to collision. At each step both footprints
  (oriented rectangles) are moved at their current velocity, headings held, and
  the first time they would overlap is found exactly with the separating-axis
  test on the four axes of the two rectangles (continuous SAT). 0 from the
  first contact on; NaN when the pair is never on a collision course.
- `pet` [s]: post-encroachment time at the conflict point, the first point
  where the two centre paths cross at an angle between 20 and 160 deg: the time
  from the first actor's rear leaving the point to the second actor's front
  reaching it (entry and exit interpolated between steps); 0 when both
  footprints cover it at once; NaN when the paths do not cross or one actor
  never reaches the point.
- `min_thw` [s]: minimum time headway, the bumper-to-bumper gap to an actor
  ahead in the follower's path (heading difference under 30 deg, lateral
  offset under the two half widths) divided by the follower's speed.
- `min_gap` [m]: the smallest gap between the two footprints (the
  separating-axis gap of `crashscene.geometry.footprint_separation`, a lower
  bound of their distance), 0 from the first contact on: how close a pair
  came that never got onto a collision course.
- `max_drac` [m/s2]: maximum deceleration rate to avoid the crash: the
  relative speed |v_b - v_a| that must be cancelled over the distance it closes
  before contact, |v_rel| / (2 TTC) (for a car closing on a stopped one:
  v^2 / (2 gap)).
- `impact_speed` [m/s], `delta_v_a`, `delta_v_b` [m/s] at the first contact:
  the relative speed of the two velocity vectors at contact and each vehicle's
  velocity change. Delta-v is what the simulator recorded (`delta_v_a/b` in
  the collisions table) when it did; otherwise the perfectly plastic
  (common-velocity) estimate of crash reconstruction, momentum conserved:
  delta_v_a = m_b / (m_a + m_b) * impact_speed, with masses by actor type.

Everything is vectorised over (variation, step); the only Python loops are
over actor pairs and chunks of variations.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from crashscene.geometry import footprint_separation, heading_difference, relative_position
from crashscene.monitor.arrays import TraceArrays
from crashscene.monitor.collisions import pair_overlaps
from crashscene.monitor.timeseries import first_index, last_index

MASS = {"car": 1500.0, "truck": 9000.0, "motorcycle": 250.0}  # [kg] by DSL actor type, for delta-v
DEFAULT_MASS = 1500.0  # [kg]
CROSSING_MIN_ANGLE = np.radians(20.0)  # [rad] paths meeting flatter than this follow or oppose, not cross
FOLLOW_MAX_ANGLE = np.radians(30.0)  # [rad] heading difference of a car-following pair
MIN_FOLLOWER_SPEED = 0.1  # [m/s] slower followers have no meaningful headway
PATH_STRIDE = 4  # steps between path samples when looking for the crossing point
CHUNK = 512  # variations per vectorised block (bounds memory)

METRICS = ("min_ttc", "min_gap", "pet", "min_thw", "max_drac", "impact_speed", "delta_v_a", "delta_v_b")

CRITICALITY_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("actor_a", pa.string()),         # role order, ego first
    ("actor_b", pa.string()),
    ("involves_ads", pa.bool_()),     # one of the two is under test (is_ads)
    ("min_ttc", pa.float64()),        # [s] NaN: never on a collision course
    ("min_ttc_t", pa.float64()),      # [s] when the minimum occurred
    ("min_gap", pa.float64()),        # [m] 0 at contact; NaN: never both present
    ("pet", pa.float64()),            # [s] NaN: no crossing conflict
    ("min_thw", pa.float64()),        # [s] NaN: never following
    ("max_drac", pa.float64()),       # [m/s2] NaN: never closing
    ("collided", pa.bool_()),
    ("impact_speed", pa.float64()),   # [m/s] NaN without contact
    ("delta_v_a", pa.float64()),      # [m/s]
    ("delta_v_b", pa.float64()),      # [m/s]
    ("delta_v_source", pa.string()),  # simulator | momentum | null
])


def time_to_collision(pa_: np.ndarray, pb_: np.ndarray, yaw_a: np.ndarray, yaw_b: np.ndarray,
                      half_a: np.ndarray, half_b: np.ndarray, va: np.ndarray, vb: np.ndarray) -> np.ndarray:
    """First time [s] >= 0 at which two translating oriented rectangles overlap; inf if never.

    `pa_`, `pb_` (..., 2) centres [m]; `yaw_*` (...) [rad]; `half_*` (..., 2) half length and half width [m];
    `va`, `vb` (..., 2) velocities [m/s]. Separating-axis test swept in time: on each of the four axes the
    projections overlap during an interval; the rectangles overlap while all four intervals do.
    """
    dx, dy = pb_[..., 0] - pa_[..., 0], pb_[..., 1] - pa_[..., 1]
    wx, wy = vb[..., 0] - va[..., 0], vb[..., 1] - va[..., 1]
    ca, sa, cb, sb = np.cos(yaw_a), np.sin(yaw_a), np.cos(yaw_b), np.sin(yaw_b)
    t_in = np.zeros(dx.shape)
    t_out = np.full(dx.shape, np.inf)
    # component arithmetic, in the order a dot product over a last axis of 2 sums (the same bits, no stacking)
    for ax, ay in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):
        radius = (half_a[..., 0] * np.abs(ca * ax + sa * ay) + half_a[..., 1] * np.abs(-sa * ax + ca * ay)
                  + half_b[..., 0] * np.abs(cb * ax + sb * ay) + half_b[..., 1] * np.abs(-sb * ax + cb * ay))
        gap, s = dx * ax + dy * ay, wx * ax + wy * ay   # overlap on this axis while |gap + s t| <= radius
        with np.errstate(divide="ignore", invalid="ignore"):
            lo, hi = (-radius - gap) / s, (radius - gap) / s
        still = s == 0
        inside = np.abs(gap) <= radius
        enter = np.where(still, np.where(inside, -np.inf, np.inf), np.minimum(lo, hi))
        leave = np.where(still, np.where(inside, np.inf, -np.inf), np.maximum(lo, hi))
        t_in = np.maximum(t_in, enter)
        t_out = np.minimum(t_out, leave)
    hit = (t_in <= t_out) & np.isfinite(t_in)
    return np.where(hit, t_in, np.inf)


def _velocity(speed: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    return np.stack([speed * np.cos(yaw), speed * np.sin(yaw)], axis=-1)


class _Columns:
    """Per actor, over one slice of variations: the trace columns with NaN as 0 and the velocity, computed once
    for all the pairs the actor is in; and the (V, A, T) time of the whole batch."""

    def __init__(self, arrays: TraceArrays, sl: slice, time: np.ndarray):
        self.arrays, self.sl, self.time = arrays, sl, time
        self._cache: dict[tuple[str, int], np.ndarray] = {}

    def get(self, name: str, i: int) -> np.ndarray:
        key = (name, i)
        if key not in self._cache:
            self._cache[key] = np.nan_to_num(self.arrays.floats[name][self.sl, i])
        return self._cache[key]

    def velocity(self, i: int) -> np.ndarray:
        key = ("velocity", i)
        if key not in self._cache:
            self._cache[key] = _velocity(self.get("speed", i), self.get("yaw", i))
        return self._cache[key]


def _pair_ttc(arrays: TraceArrays, cols: _Columns, a: int, b: int, contact: np.ndarray):
    """(min TTC, its time, max DRAC, min gap) for pair (a, b) over the variations of `cols`; `contact` first
    contact step."""
    sl = cols.sl
    n_steps = arrays.shape[2]
    both = arrays.alive[sl, a] & arrays.alive[sl, b]
    before = np.arange(n_steps)[None, :] < np.where(contact >= 0, contact, n_steps)[:, None]
    use = both & before
    get = cols.get
    half = lambda i: np.broadcast_to(np.stack([arrays.length[sl, i], arrays.width[sl, i]], axis=-1)[:, None] / 2,
                                     (sl.stop - sl.start, n_steps, 2))
    centre = lambda i: np.stack([get("x", i), get("y", i)], axis=-1)
    va = cols.velocity(a)
    vb = cols.velocity(b)
    ttc = time_to_collision(centre(a), centre(b), get("yaw", a), get("yaw", b), half(a), half(b), va, vb)
    ttc = np.where(use, ttc, np.inf)
    rel = np.linalg.norm(vb - va, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        drac = np.where(np.isfinite(ttc) & (ttc > 0), rel / (2 * ttc), np.nan)
    at = np.argmin(ttc, axis=1)
    min_ttc = ttc[np.arange(len(at)), at]
    t = cols.time[sl, a]
    min_t = np.where(np.isfinite(min_ttc), t[np.arange(len(at)), at], np.nan)
    collided = contact >= 0
    min_ttc = np.where(collided, 0.0, np.where(np.isfinite(min_ttc), min_ttc, np.nan))
    min_t = np.where(collided, t[np.arange(len(at)), np.clip(contact, 0, n_steps - 1)], min_t)
    with np.errstate(all="ignore"):
        max_drac = np.where(np.isfinite(drac).any(axis=1), np.nanmax(np.where(np.isfinite(drac), drac, -1), axis=1),
                            np.nan)
    gap = footprint_separation(get("x", a), get("y", a), get("yaw", a), arrays.length[sl, a][:, None],
                               arrays.width[sl, a][:, None], get("x", b), get("y", b), get("yaw", b),
                               arrays.length[sl, b][:, None], arrays.width[sl, b][:, None])
    gap = np.where(use, np.maximum(gap, 0.0), np.inf).min(axis=1)
    min_gap = np.where(collided, 0.0, np.where(np.isfinite(gap), gap, np.nan))
    return min_ttc, min_t, max_drac, min_gap


def _pair_thw(arrays: TraceArrays, sl: slice, a: int, b: int) -> np.ndarray:
    """Minimum time headway [s] of either actor following the other, over variations `sl`."""
    f = arrays.floats
    best = np.full(sl.stop - sl.start, np.inf)
    for me, other in ((a, b), (b, a)):
        lon, lat = relative_position(f["x"][sl, me], f["y"][sl, me], f["yaw"][sl, me], f["x"][sl, other],
                                     f["y"][sl, other])
        same_way = heading_difference(f["yaw"][sl, me], f["yaw"][sl, other]) < FOLLOW_MAX_ANGLE
        half_w = ((arrays.width[sl, me] + arrays.width[sl, other]) / 2)[:, None]
        gap = lon - ((arrays.length[sl, me] + arrays.length[sl, other]) / 2)[:, None]
        speed = f["speed"][sl, me]
        with np.errstate(invalid="ignore", divide="ignore"):
            following = same_way & (np.abs(lat) < half_w) & (gap > 0) & (speed > MIN_FOLLOWER_SPEED)
            thw = np.where(following, gap / speed, np.inf)
        best = np.minimum(best, thw.min(axis=1))
    return np.where(np.isfinite(best), best, np.nan)


def _crossing_point(px_a, py_a, px_b, py_b, yaw_a, yaw_b):
    """First crossing (along a's path) of two polylines (V, N) with a crossing angle; (x, y) or NaN."""
    ax0, ay0, ax1, ay1 = px_a[:, :-1, None], py_a[:, :-1, None], px_a[:, 1:, None], py_a[:, 1:, None]
    bx0, by0, bx1, by1 = px_b[:, None, :-1], py_b[:, None, :-1], px_b[:, None, 1:], py_b[:, None, 1:]
    rx, ry = ax1 - ax0, ay1 - ay0
    sx, sy = bx1 - bx0, by1 - by0
    denom = rx * sy - ry * sx
    qx, qy = bx0 - ax0, by0 - ay0
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (qx * sy - qy * sx) / denom
        v = (qx * ry - qy * rx) / denom
        hit = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1) & (denom != 0)
    vi, ii, jj = np.nonzero(hit)  # the crossing angle only where the segments cross (few of V x N x N)
    angle = heading_difference(yaw_a[vi, ii], yaw_b[vi, jj])
    hit[vi, ii, jj] = (angle >= CROSSING_MIN_ANGLE) & (angle <= np.pi - CROSSING_MIN_ANGLE)
    n_b = hit.shape[2]
    flat = hit.reshape(len(hit), -1)
    any_hit = flat.any(axis=1)
    k = np.argmax(flat, axis=1)
    i, j = k // n_b, k % n_b
    rows = np.arange(len(hit))
    with np.errstate(invalid="ignore"):
        x = ax0[rows, i, 0] + u[rows, i, j] * rx[rows, i, 0]
        y = ay0[rows, i, 0] + u[rows, i, j] * ry[rows, i, 0]
    return np.where(any_hit, x, np.nan), np.where(any_hit, y, np.nan)


def _occupancy(arrays: TraceArrays, cols: _Columns, me: int, px: np.ndarray, py: np.ndarray):
    """Times [s] the actor's front reaches and its rear leaves the point (px, py); NaN when never."""
    f, sl = arrays.floats, cols.sl
    lon, lat = relative_position(f["x"][sl, me], f["y"][sl, me], f["yaw"][sl, me], px[:, None], py[:, None])
    half_l = (arrays.length[sl, me] / 2)[:, None]
    half_w = (arrays.width[sl, me] / 2)[:, None]
    with np.errstate(invalid="ignore"):
        inside = (np.abs(lon) <= half_l) & (np.abs(lat) <= half_w)
    t = cols.time[sl, me]
    rows = np.arange(inside.shape[0])
    n = inside.shape[1]
    first, last = first_index(inside), last_index(inside)
    prev = np.clip(first - 1, 0, n - 1)
    nxt = np.clip(last + 1, 0, n - 1)
    h = half_l[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        frac_in = (lon[rows, prev] - h) / (lon[rows, prev] - lon[rows, first])
        frac_out = (lon[rows, last] + h) / (lon[rows, last] - lon[rows, nxt])
    frac_in = np.where(np.isfinite(frac_in) & (first > 0), np.clip(frac_in, 0, 1), 1.0)
    frac_out = np.where(np.isfinite(frac_out) & (last < n - 1), np.clip(frac_out, 0, 1), 0.0)
    t_in = np.where(first > 0, t[rows, prev] + frac_in * (t[rows, first] - t[rows, prev]), t[rows, 0])
    t_out = t[rows, last] + frac_out * (t[rows, nxt] - t[rows, last])
    never = first < 0
    return np.where(never, np.nan, t_in), np.where(never, np.nan, t_out)


def _pair_pet(arrays: TraceArrays, cols: _Columns, a: int, b: int) -> np.ndarray:
    """Post-encroachment time [s] at the pair's first path crossing, over the variations of `cols`."""
    f, sl = arrays.floats, cols.sl
    steps = np.arange(0, arrays.shape[2], PATH_STRIDE)
    if steps[-1] != arrays.shape[2] - 1:
        steps = np.append(steps, arrays.shape[2] - 1)
    if len(steps) < 2:
        return np.full(sl.stop - sl.start, np.nan)
    path = lambda name, i: np.where(arrays.alive[sl, i][:, steps], f[name][sl, i][:, steps], np.nan)
    px, py = _crossing_point(path("x", a), path("y", a), path("x", b), path("y", b), path("yaw", a),
                             path("yaw", b))
    a_in, a_out = _occupancy(arrays, cols, a, px, py)
    b_in, b_out = _occupancy(arrays, cols, b, px, py)
    a_first = a_in <= b_in
    with np.errstate(invalid="ignore"):
        pet = np.where(a_first, b_in - a_out, a_in - b_out)
    return np.where(np.isfinite(pet), np.maximum(pet, 0.0), np.nan)


def criticality_table(arrays: TraceArrays, collisions: pa.Table | None = None) -> pa.Table:
    """One CRITICALITY_SCHEMA row per (variation, unordered actor pair) where both actors are present.

    `collisions` (the monitor's classified collisions, or the simulator's) supplies recorded delta-v.
    """
    n_var, n_act, _ = arrays.shape
    if n_act < 2:
        return CRITICALITY_SCHEMA.empty_table()
    ia, ib, overlap = pair_overlaps(arrays)
    contact = first_index(overlap)   # (V, P) first overlapping step, -1 none
    recorded = _recorded_delta_v(arrays, collisions)
    time = arrays.time()
    per_pair: list[dict[str, list[np.ndarray]]] = [
        {m: [] for m in ("min_ttc", "min_ttc_t", "max_drac", "min_gap", "min_thw", "pet")} for _ in ia]
    for lo in range(0, n_var, CHUNK):  # chunks outside, pairs inside: each actor's columns once per chunk
        chunk = _Columns(arrays, slice(lo, min(n_var, lo + CHUNK)), time)
        sl = chunk.sl
        for p, (a, b) in enumerate(zip(ia, ib)):
            cols = per_pair[p]
            ttc, ttc_t, drac, gap = _pair_ttc(arrays, chunk, a, b, contact[sl, p])
            cols["min_ttc"].append(ttc)
            cols["min_ttc_t"].append(ttc_t)
            cols["max_drac"].append(drac)
            cols["min_gap"].append(gap)
            cols["min_thw"].append(_pair_thw(arrays, sl, a, b))
            cols["pet"].append(_pair_pet(arrays, chunk, a, b))
    parts = []
    for p, (a, b) in enumerate(zip(ia, ib)):
        merged = {k: np.concatenate(v) for k, v in per_pair[p].items()}
        impact, dva, dvb, source = _impact(arrays, a, b, contact[:, p], recorded.get((arrays.roles[a],
                                                                                       arrays.roles[b])))
        present = arrays.present[:, a] & arrays.present[:, b]
        rows = np.nonzero(present)[0]
        n = len(rows)
        parts.append(pa.table({
            "variation": pa.array(arrays.variations[rows].astype(np.int32)),
            "actor_a": pa.array([arrays.roles[a]] * n, type=pa.string()),
            "actor_b": pa.array([arrays.roles[b]] * n, type=pa.string()),
            "involves_ads": pa.array((arrays.is_ads[rows, a] | arrays.is_ads[rows, b])),
            "min_ttc": pa.array(merged["min_ttc"][rows]),
            "min_ttc_t": pa.array(merged["min_ttc_t"][rows]),
            "min_gap": pa.array(merged["min_gap"][rows]),
            "pet": pa.array(merged["pet"][rows]),
            "min_thw": pa.array(merged["min_thw"][rows]),
            "max_drac": pa.array(merged["max_drac"][rows]),
            "collided": pa.array(contact[rows, p] >= 0),
            "impact_speed": pa.array(impact[rows]),
            "delta_v_a": pa.array(dva[rows]),
            "delta_v_b": pa.array(dvb[rows]),
            "delta_v_source": pa.array(source[rows].tolist(), type=pa.string()),
        }, schema=CRITICALITY_SCHEMA))
    table = pa.concat_tables(parts)
    order = pc.sort_indices(table, sort_keys=[("variation", "ascending")])  # stable: pair order within
    return table.take(order)


def _recorded_delta_v(arrays: TraceArrays, collisions: pa.Table | None) -> dict:
    """(actor_a, actor_b) -> {variation: (delta_v_a, delta_v_b)} of the first recorded contact, when recorded."""
    if collisions is None or not collisions.num_rows or "delta_v_a" not in collisions.column_names:
        return {}
    out: dict = {}
    cols = collisions.select(["variation", "t", "actor_a", "actor_b", "delta_v_a", "delta_v_b"]).to_pylist()
    for row in sorted(cols, key=lambda r: (r["variation"], r["t"] if r["t"] is not None else np.inf)):
        if row["delta_v_a"] is None or row["delta_v_b"] is None:
            continue
        if not (np.isfinite(row["delta_v_a"]) and np.isfinite(row["delta_v_b"])):
            continue
        key, dv = (row["actor_a"], row["actor_b"]), (row["delta_v_a"], row["delta_v_b"])
        if key not in out and (row["actor_b"], row["actor_a"]) in out:
            key, dv = (row["actor_b"], row["actor_a"]), dv[::-1]
        out.setdefault(key, {}).setdefault(int(row["variation"]), dv)
    return out


def _mass(types: np.ndarray) -> np.ndarray:
    return np.array([MASS.get(str(t), DEFAULT_MASS) for t in types])


def _impact(arrays: TraceArrays, a: int, b: int, contact: np.ndarray, recorded: dict | None):
    """Impact speed and delta-v per variation at the pair's first contact step (NaN without contact)."""
    f = arrays.floats
    n_var = arrays.shape[0]
    rows = np.arange(n_var)
    step = np.clip(contact, 0, arrays.shape[2] - 1)
    va = _velocity(f["speed"][rows, a, step], f["yaw"][rows, a, step])
    vb = _velocity(f["speed"][rows, b, step], f["yaw"][rows, b, step])
    impact = np.linalg.norm(va - vb, axis=-1)
    ma, mb = _mass(arrays.actor_type[:, a]), _mass(arrays.actor_type[:, b])
    dva, dvb = mb / (ma + mb) * impact, ma / (ma + mb) * impact
    source = np.where(contact >= 0, "momentum", None).astype(object)
    for v, (ra, rb) in (recorded or {}).items():
        i = int(np.searchsorted(arrays.variations, v))
        if i < n_var and arrays.variations[i] == v and contact[i] >= 0:
            dva[i], dvb[i], source[i] = ra, rb, "simulator"
    hit = contact >= 0
    return (np.where(hit, impact, np.nan), np.where(hit, dva, np.nan), np.where(hit, dvb, np.nan), source)


def ads_objectives(table: pa.Table) -> dict[int, dict[str, float]]:
    """Per variation, over pairs involving an actor under test: min TTC (0 at contact), min gap, min PET,
    min THW, max DRAC, max impact speed (NaN where none)."""
    out: dict[int, dict[str, float]] = {}
    if not table.num_rows:
        return out
    rows = table.filter(table["involves_ads"]).to_pydict()
    picks = (("min_ttc", np.fmin), ("min_gap", np.fmin), ("pet", np.fmin), ("min_thw", np.fmin),
             ("max_drac", np.fmax), ("impact_speed", np.fmax))
    for i, v in enumerate(rows["variation"]):
        cur = out.setdefault(int(v), {key: np.nan for key, _ in picks})
        for key, pick in picks:
            value = rows[key][i]
            cur[key] = float(pick(cur[key], np.nan if value is None else value))
    return out


def summarize(table: pa.Table) -> dict[str, dict[str, float | int | None]]:
    """min, p5, median (and the number of finite values) per metric over the table's pair rows."""
    out: dict[str, dict[str, float | int | None]] = {}
    for metric in METRICS:
        values = table.column(metric).to_numpy(zero_copy_only=False).astype(float) if table.num_rows else np.zeros(0)
        values = values[np.isfinite(values)]
        if not len(values):
            out[metric] = {"n": 0, "min": None, "p5": None, "median": None}
            continue
        out[metric] = {"n": int(len(values)), "min": round(float(values.min()), 4),
                       "p5": round(float(np.percentile(values, 5)), 4),
                       "median": round(float(np.median(values)), 4)}
    return out
