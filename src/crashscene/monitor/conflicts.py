"""Where two actors' paths cross: the conflict areas of the right-of-way rules.

For every ordered pair of actors (a, b) of every variation: does a's path
cross (or merge into) b's path, when does a enter b's path and when does it
leave it, and at which arc length [m] along a's path the crossing lies. The
right-of-way rules (CVC 21800, 21801, 21802, 21803) turn these into
post-encroachment times and times to reach the conflict area.

A path is the recorded trajectory, sampled every `stride` steps, extended
straight ahead of its last position by `extension` [m]: a vehicle that braked
to a stop short of the crossing (because another cut in front of it) still has
a conflict point, so its time to reach it can be measured.
A path ends at `last_step` when given (the step an impact took the vehicle out
of its driver's control: what it does afterwards is no path it chose).
A pair whose paths touch at a heading difference below `min_angle` or above
pi - `min_angle` (car-following, oncoming traffic in its own lane) has no
crossing conflict: those are the following and wrong-side rules' business.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from crashscene.geometry import heading_difference, pair_indices
from crashscene.monitor.arrays import TraceArrays
from crashscene.monitor.timeseries import first_index, last_index

NO_STEP = -1


@dataclass
class PathConflicts:
    """Ordered-pair conflict geometry, arrays (V, A, A) indexed [variation, a, b]."""

    crossing: np.ndarray   # bool: a's path crosses or merges into b's path
    angle: np.ndarray      # [rad] heading difference where a enters b's path
    enter: np.ndarray      # step at which a's front bumper enters b's path (NO_STEP if never in the trace)
    exit: np.ndarray       # last step before a's rear bumper has left it (NO_STEP if never entered)
    s_enter: np.ndarray    # [m] a's arc length where its front bumper enters (extension included; NaN if none)
    s: np.ndarray          # (V, A, T) a's arc length along its recorded path [m]


def arc_length(arrays: TraceArrays) -> np.ndarray:
    """(V, A, T) cumulative distance travelled [m]; steps without a position keep the last value."""
    x, y = arrays.floats["x"], arrays.floats["y"]
    seg = np.hypot(np.diff(x, axis=2), np.diff(y, axis=2))
    seg = np.where(np.isfinite(seg), seg, 0.0)
    s = np.concatenate([np.zeros(x.shape[:2] + (1,)), np.cumsum(seg, axis=2)], axis=2)
    return s


def relevant_steps(arrays: TraceArrays, stride: int, around: float) -> np.ndarray:
    """(V, A, K) steps (every `stride`-th, and the last) within `around` [s] of the actor being in a junction;
    -1 pads.

    Crossing conflicts only matter at junctions, so paths are compared there
    only: a few dozen samples per actor instead of the whole trace.
    """
    n_steps = arrays.shape[2]
    junction = arrays.flag("in_junction") & arrays.alive
    k = max(1, round(around / arrays.dt))
    csum = np.concatenate([np.zeros(junction.shape[:2] + (1,)), np.cumsum(junction, axis=2)], axis=2)
    steps = np.arange(n_steps)
    hi = np.minimum(steps + k + 1, n_steps)
    lo = np.maximum(steps - k, 0)
    near = (csum[..., hi] - csum[..., lo]) > 0
    alive = arrays.alive
    last = np.where(alive.any(axis=2), n_steps - 1 - np.argmax(alive[..., ::-1], axis=2), -1)
    # every `stride`-th step, and the last one: where a path ends (an impact upset the vehicle) is part of it
    keep = near & alive & ((steps % max(1, stride) == 0) | (steps == last[..., None]))
    n_keep = int(keep.sum(axis=2).max()) if keep.size else 0
    order = np.argsort(~keep, axis=2, kind="stable")[..., :n_keep]
    return np.where(np.take_along_axis(keep, order, axis=2), order, -1)


def path_conflicts(arrays: TraceArrays, stride: int = 2, extension: float = 20.0, extension_step: float = 2.0,
                   min_angle: float = np.radians(20.0), around: float = 3.0, chunk: int = 256,
                   last_step: np.ndarray | None = None) -> PathConflicts:
    """Conflict geometry of every ordered actor pair, vectorised in chunks of variations.

    Paths are compared over the samples within `around` [s] of each actor's
    time in a junction, plus the straight extension. `last_step` (V, A; -1 = none) ends each path there.
    """
    if last_step is not None and (last_step >= 0).any():
        steps = np.arange(arrays.shape[2])
        ended = (last_step[..., None] >= 0) & (steps > last_step[..., None])
        arrays = replace(arrays, alive=arrays.alive & ~ended)
    n_var, n_act, n_steps = arrays.shape
    s_full = arc_length(arrays)
    shape = (n_var, n_act, n_act)
    out = PathConflicts(crossing=np.zeros(shape, dtype=bool), angle=np.full(shape, np.nan),
                        enter=np.full(shape, NO_STEP, dtype=np.int64), exit=np.full(shape, NO_STEP, dtype=np.int64),
                        s_enter=np.full(shape, np.nan), s=s_full)
    if n_act < 2 or n_steps == 0:
        return out
    idx = relevant_steps(arrays, stride, around)
    if idx.shape[2] == 0:
        return out
    n_ext = max(0, round(extension / extension_step))
    px, py, pyaw, ps = _sampled_paths(arrays, s_full, idx, n_ext, extension_step)
    ia, ib = pair_indices(n_act)
    for lo in range(0, n_var, chunk):
        hi = min(n_var, lo + chunk)
        for a, b in zip(ia, ib):
            _pair(out, arrays, lo, hi, a, b, px, py, pyaw, ps, idx, min_angle)
    return out


def _sampled_paths(arrays: TraceArrays, s_full: np.ndarray, idx: np.ndarray, n_ext: int, ds: float):
    x = np.where(arrays.alive, arrays.floats["x"], np.nan)
    y = np.where(arrays.alive, arrays.floats["y"], np.nan)
    yaw = arrays.floats["yaw"]
    last = np.where(arrays.alive.any(axis=2), arrays.shape[2] - 1 - np.argmax(arrays.alive[..., ::-1], axis=2), 0)
    take = lambda arr: np.take_along_axis(arr, last[..., None], axis=2)
    lx, ly, lyaw, ls = take(x), take(y), take(yaw), take(s_full)
    steps = np.arange(1, n_ext + 1) * ds
    ex = lx + steps * np.cos(lyaw)
    ey = ly + steps * np.sin(lyaw)
    es = ls + steps
    safe = np.clip(idx, 0, None)
    pad = idx < 0
    gather = lambda arr: np.where(pad, np.nan, np.take_along_axis(arr, safe, axis=2))
    # float32 around a per-variation origin: half the memory traffic, centimetre precision
    origin_x = np.nanmean(np.where(np.isfinite(lx), lx, np.nan), axis=(1, 2), keepdims=True)
    origin_y = np.nanmean(np.where(np.isfinite(ly), ly, np.nan), axis=(1, 2), keepdims=True)
    origin_x, origin_y = np.nan_to_num(origin_x), np.nan_to_num(origin_y)
    px = (np.concatenate([gather(x), ex], axis=2) - origin_x).astype(np.float32)
    py = (np.concatenate([gather(y), ey], axis=2) - origin_y).astype(np.float32)
    pyaw = np.concatenate([gather(yaw), np.broadcast_to(lyaw, ex.shape)], axis=2)
    ps = np.concatenate([gather(s_full), es], axis=2)
    return px, py, pyaw, ps


def _pair(out: PathConflicts, arrays: TraceArrays, lo: int, hi: int, a: int, b: int, px, py, pyaw, ps,
          idx: np.ndarray, min_angle: float) -> None:
    """Fill both orders (a, b) and (b, a): each actor's front bumper against the other's centre path."""
    sl = slice(lo, hi)
    n_real = idx.shape[2]
    # lateral overlap of a bumper with the other's swept path: within both half widths of its centre line
    r = ((arrays.width[sl, a] + arrays.width[sl, b]) / 2).astype(np.float32)[:, None]
    for me, other in ((a, b), (b, a)):
        half = (arrays.length[sl, me] / 2).astype(np.float32)[:, None]
        qx = (px[sl, me] + half * np.cos(pyaw[sl, me]).astype(np.float32))[:, :, None]
        qy = (py[sl, me] + half * np.sin(pyaw[sl, me]).astype(np.float32))[:, :, None]
        d2 = (qx - px[sl, other][:, None, :]) ** 2 + (qy - py[sl, other][:, None, :]) ** 2
        d2[~np.isfinite(d2)] = np.inf
        front_in = d2.min(axis=2) < r * r
        first = first_index(front_in)
        rows = np.nonzero(first >= 0)[0]
        if not len(rows):
            continue
        v = rows + lo
        f = first[rows]
        other_pt = np.argmin(d2[rows, f, :], axis=1)
        angle = heading_difference(pyaw[v, me, f], pyaw[v, other, other_pt])
        out.crossing[v, me, other] = (angle >= min_angle) & (angle <= np.pi - min_angle)
        out.angle[v, me, other] = angle
        out.s_enter[v, me, other] = ps[v, me, f]   # centre arc length when the front bumper enters
        # the front's stay on the other's path; the rear leaves one vehicle length of travel later
        positions = np.arange(front_in.shape[1])
        gone = ~front_in[rows] & (positions[None, :] > f[:, None])
        leave = first_index(gone)
        last_in = np.where(leave >= 0, leave - 1, front_in.shape[1] - 1)
        s_clear = ps[v, me, last_in] + arrays.length[v, me]
        s_me = out.s[v, me]
        alive = arrays.alive[v, me]
        past = (s_me > s_clear[:, None]) & alive
        exit_step = np.where(past.any(axis=1), first_index(past) - 1, last_index(alive))
        real = f < n_real
        enter_step = np.where(real, np.take_along_axis(idx[v, me], np.minimum(f, n_real - 1)[:, None], 1)[:, 0],
                              NO_STEP)
        out.enter[v, me, other] = enter_step
        out.exit[v, me, other] = np.where(real, np.maximum(exit_step, enter_step), NO_STEP)
