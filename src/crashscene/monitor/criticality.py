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
  delta_v_a = m_b / (m_a + m_b) * impact_speed, with masses by actor type (`crashscene.vehicle_mass`, the simulator's).

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
from crashscene.vehicle_mass import mass_of

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
                      half_a: np.ndarray, half_b: np.ndarray, va: np.ndarray, vb: np.ndarray,
                      trig: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """First time [s] >= 0 at which two translating oriented rectangles overlap; inf if never.

    `pa_`, `pb_` (..., 2) centres [m]; `yaw_*` (...) [rad]; `half_*` (..., 2) half length and half width [m];
    `va`, `vb` (..., 2) velocities [m/s]; `trig`: (cos yaw_a, sin yaw_a, cos yaw_b, sin yaw_b) when the caller
    has them. Separating-axis test swept in time: on each of the four axes the projections overlap during an
    interval; the rectangles overlap while all four intervals do.
    """
    dx, dy = pb_[..., 0] - pa_[..., 0], pb_[..., 1] - pa_[..., 1]
    wx, wy = vb[..., 0] - va[..., 0], vb[..., 1] - va[..., 1]
    ca, sa, cb, sb = (np.cos(yaw_a), np.sin(yaw_a), np.cos(yaw_b), np.sin(yaw_b)) if trig is None else trig
    t_in = np.zeros(dx.shape)
    t_out = np.full(dx.shape, np.inf)
    # component arithmetic, in the order a dot product over a last axis of 2 sums (the same bits, no stacking)
    for ax, ay in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):
        radius = (half_a[..., 0] * np.abs(ca * ax + sa * ay) + half_a[..., 1] * np.abs(-sa * ax + ca * ay)
                  + half_b[..., 0] * np.abs(cb * ax + sb * ay) + half_b[..., 1] * np.abs(-sb * ax + cb * ay))
        gap, s = dx * ax + dy * ay, wx * ax + wy * ay   # overlap on this axis while |gap + s t| <= radius
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # s near 0: never enters, +-inf
            lo, hi = (-radius - gap) / s, (radius - gap) / s
        still = s == 0
        inside = np.abs(gap) <= radius
        enter = np.where(still, np.where(inside, -np.inf, np.inf), np.minimum(lo, hi))
        leave = np.where(still, np.where(inside, np.inf, -np.inf), np.maximum(lo, hi))
        t_in = np.maximum(t_in, enter)
        t_out = np.minimum(t_out, leave)
    hit = (t_in <= t_out) & np.isfinite(t_in)
    return np.where(hit, t_in, np.inf)


def _velocity(speed: np.ndarray, yaw: np.ndarray, cos_sin=None) -> np.ndarray:
    c, s = (np.cos(yaw), np.sin(yaw)) if cos_sin is None else cos_sin
    return np.stack([speed * c, speed * s], axis=-1)


class _Columns:
    """Per actor, over one slice of variations: the trace columns with NaN as 0, the velocity and the heading's
    cosine and sine, computed once for all the pairs the actor is in; and the (V, A, T) time of the whole batch."""

    def __init__(self, arrays: TraceArrays, sl: slice, time: np.ndarray):
        self.arrays, self.sl, self.time = arrays, sl, time
        self._cache: dict[tuple[str, int], np.ndarray] = {}

    def get(self, name: str, i: int) -> np.ndarray:
        key = (name, i)
        if key not in self._cache:
            self._cache[key] = np.nan_to_num(self.arrays.floats[name][self.sl, i])
        return self._cache[key]

    def raw(self, name: str, i: int) -> np.ndarray:
        """The column as recorded (NaN kept)."""
        return self.arrays.floats[name][self.sl, i]

    def cos_sin(self, i: int, raw: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(cos, sin) of actor i's heading: with NaN as 0, or as recorded (`raw`)."""
        key = ("cos_sin_raw" if raw else "cos_sin", i)
        if key not in self._cache:
            yaw = self.raw("yaw", i) if raw else self.get("yaw", i)
            self._cache[key] = (np.cos(yaw), np.sin(yaw))
        return self._cache[key]

    def velocity(self, i: int) -> np.ndarray:
        key = ("velocity", i)
        if key not in self._cache:
            self._cache[key] = _velocity(self.get("speed", i), self.get("yaw", i), self.cos_sin(i))
        return self._cache[key]


USED_SHARE = 0.75  # [-] above this share of (variation, step) samples used, _pair_ttc computes on all of them


def _pair_ttc(arrays: TraceArrays, cols: _Columns, a: int, b: int, contact: np.ndarray):
    """(min TTC, its time, max DRAC, min gap) for pair (a, b) over the variations of `cols`; `contact` first
    contact step.

    Only the samples used (both present, before the first contact) are measured: where few are (most pairs
    collide early), they are gathered first. Each sample's arithmetic is its own, so the values are the same."""
    sl = cols.sl
    n_steps = arrays.shape[2]
    both = arrays.alive[sl, a] & arrays.alive[sl, b]
    before = np.arange(n_steps)[None, :] < np.where(contact >= 0, contact, n_steps)[:, None]
    use = both & before
    every = np.count_nonzero(use) > USED_SHARE * use.size
    pick = (lambda arr: arr) if every else (lambda arr: arr[use])

    def spread(values: np.ndarray, fill: float) -> np.ndarray:  # the used samples' values back on (V, T)
        if every:
            return np.where(use, values, fill)
        out = np.full(use.shape, fill)
        out[use] = values
        return out

    get = lambda name, i: pick(cols.get(name, i))
    size = lambda i, column: pick(np.broadcast_to(column[sl, i][:, None], use.shape))

    def half(i: int) -> np.ndarray:  # (..., 2) half length and half width; all samples: one row broadcast, no copy
        if every:
            return np.broadcast_to(np.stack([arrays.length[sl, i], arrays.width[sl, i]], axis=-1)[:, None] / 2,
                                   use.shape + (2,))
        return np.stack([size(i, arrays.length), size(i, arrays.width)], axis=-1) / 2

    centre = lambda i: np.stack([get("x", i), get("y", i)], axis=-1)
    va = pick(cols.velocity(a))
    vb = pick(cols.velocity(b))
    trig = tuple(pick(q) for q in (*cols.cos_sin(a), *cols.cos_sin(b)))
    ttc = time_to_collision(centre(a), centre(b), get("yaw", a), get("yaw", b), half(a), half(b), va, vb, trig)
    rel = np.linalg.norm(vb - va, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        drac = spread(np.where(np.isfinite(ttc) & (ttc > 0), rel / (2 * ttc), np.nan), np.nan)
    ttc = spread(ttc, np.inf)
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
    gap = footprint_separation(get("x", a), get("y", a), get("yaw", a), size(a, arrays.length),
                               size(a, arrays.width), get("x", b), get("y", b), get("yaw", b),
                               size(b, arrays.length), size(b, arrays.width), trig)
    gap = spread(np.maximum(gap, 0.0), np.inf).min(axis=1)
    min_gap = np.where(collided, 0.0, np.where(np.isfinite(gap), gap, np.nan))
    return min_ttc, min_t, max_drac, min_gap


def _pair_thw(arrays: TraceArrays, cols: _Columns, a: int, b: int) -> np.ndarray:
    """Minimum time headway [s] of either actor following the other, over the variations of `cols`."""
    f, sl = arrays.floats, cols.sl
    best = np.full(sl.stop - sl.start, np.inf)
    for me, other in ((a, b), (b, a)):
        lon, lat = relative_position(f["x"][sl, me], f["y"][sl, me], f["yaw"][sl, me], f["x"][sl, other],
                                     f["y"][sl, other], cols.cos_sin(me, raw=True))
        same_way = heading_difference(f["yaw"][sl, me], f["yaw"][sl, other]) < FOLLOW_MAX_ANGLE
        half_w = ((arrays.width[sl, me] + arrays.width[sl, other]) / 2)[:, None]
        gap = lon - ((arrays.length[sl, me] + arrays.length[sl, other]) / 2)[:, None]
        speed = f["speed"][sl, me]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):  # masked where not following
            following = same_way & (np.abs(lat) < half_w) & (gap > 0) & (speed > MIN_FOLLOWER_SPEED)
            thw = np.where(following, gap / speed, np.inf)
        best = np.minimum(best, thw.min(axis=1))
    return np.where(np.isfinite(best), best, np.nan)


CROSSING_REACH = 1.0  # [m] segments whose bounding boxes are further apart than this are not tested for a crossing


def _crossing_point(px_a, py_a, px_b, py_b, yaw_a, yaw_b):
    """First crossing (along a's path) of two polylines (V, N) with a crossing angle; (x, y) or NaN.

    Only segment pairs whose bounding boxes come within CROSSING_REACH of each other are intersected (few of
    V x N x N): segments further apart cannot cross, their parameters could fall inside [0, 1] only by rounding
    on segments parallel to 1e-13 rad, which the crossing angle rejects."""
    ax0, ay0, ax1, ay1 = px_a[:, :-1], py_a[:, :-1], px_a[:, 1:], py_a[:, 1:]
    bx0, by0, bx1, by1 = px_b[:, :-1], py_b[:, :-1], px_b[:, 1:], py_b[:, 1:]
    box_a = [np.minimum(ax0, ax1), np.maximum(ax0, ax1), np.minimum(ay0, ay1), np.maximum(ay0, ay1)]
    box_b = [np.minimum(bx0, bx1), np.maximum(bx0, bx1), np.minimum(by0, by1), np.maximum(by0, by1)]
    with np.errstate(invalid="ignore"):  # NaN (not alive): never near
        near = (box_a[0][:, :, None] <= (box_b[1] + CROSSING_REACH)[:, None, :]) \
            & ((box_b[0] - CROSSING_REACH)[:, None, :] <= box_a[1][:, :, None]) \
            & (box_a[2][:, :, None] <= (box_b[3] + CROSSING_REACH)[:, None, :]) \
            & ((box_b[2] - CROSSING_REACH)[:, None, :] <= box_a[3][:, :, None])
    vi, ii, jj = np.nonzero(near)  # in (variation, i, j) order: a's path first
    rx, ry = ax1[vi, ii] - ax0[vi, ii], ay1[vi, ii] - ay0[vi, ii]
    sx, sy = bx1[vi, jj] - bx0[vi, jj], by1[vi, jj] - by0[vi, jj]
    denom = rx * sy - ry * sx
    qx, qy = bx0[vi, jj] - ax0[vi, ii], by0[vi, jj] - ay0[vi, ii]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (qx * sy - qy * sx) / denom
        v = (qx * ry - qy * rx) / denom
        hit = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1) & (denom != 0)
    angle = heading_difference(yaw_a[vi[hit], ii[hit]], yaw_b[vi[hit], jj[hit]])
    hit[hit] = (angle >= CROSSING_MIN_ANGLE) & (angle <= np.pi - CROSSING_MIN_ANGLE)
    rows, first = np.unique(vi[hit], return_index=True)  # each variation's first crossing along a's path
    k = np.flatnonzero(hit)[first]
    x, y = np.full(len(px_a), np.nan), np.full(len(px_a), np.nan)
    x[rows] = ax0[rows, ii[k]] + u[k] * rx[k]
    y[rows] = ay0[rows, ii[k]] + u[k] * ry[k]
    return x, y


def _occupancy(arrays: TraceArrays, cols: _Columns, me: int, px: np.ndarray, py: np.ndarray):
    """Times [s] the actor's front reaches and its rear leaves the point (px, py); NaN when never."""
    f, sl = arrays.floats, cols.sl
    lon, lat = relative_position(f["x"][sl, me], f["y"][sl, me], f["yaw"][sl, me], px[:, None], py[:, None],
                                 cols.cos_sin(me, raw=True))
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
            cols["min_thw"].append(_pair_thw(arrays, chunk, a, b))
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
    return np.array([mass_of(t) for t in types])


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
