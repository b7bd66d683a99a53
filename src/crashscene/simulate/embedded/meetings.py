"""Where a third actor meets a car an impact sets moving (pushed, deflected, or sliding after a clip), measured
on the predicted paths of every candidate at once, and the third actor placed to meet it there: its start moved
along its route, or (no room behind) slowed and held at its start.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from crashscene.simulate.embedded import cascade, lockstep, timing
from crashscene.simulate.embedded.stations import START_MARGIN, shift_start
from crashscene.simulate.roads import ROUTE_DS

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

NEAR_ROUTE = 8.0  # [m] a pushed car further than this from a route's centre line cannot meet a car on it
CASCADE_WINDOW = 0.8  # [s] a later contact's striker arrives up to this long after the pushed car is in its path
CASCADE_CENTRAL = 2.0  # [deg] a later contact is timed where the predicted heading is this near its most central
SIDE_ALONG = 0.25  # [-] a sideswipe strikes a third car's side this part of its length ahead of its centre


def place_third(plan: VariationPlan, xi: int, meeting: tuple[int, float, str, str, float, float],
                later: tuple[str, str, str], arrive: float, passing: tuple[int, ...] = (),
                along: float = SIDE_ALONG) -> bool:
    """Actor xi placed to meet a moving actor at `arrive` [s] as `meeting` (`pushed_meetings`) has it, as its
    written area says (cascade.meeting_mode): its front at the moving one, or (a sideswipe on its side) its
    side beside it, `along` of its length ahead of its centre (`_meet_at`); False when it cannot be."""
    return _meet_at(plan, xi, third_reach(plan, xi, meeting, later, along), arrive, passing)


def third_reach(plan: VariationPlan, xi: int, meeting: tuple[int, float, str, str, float, float],
                later: tuple[str, str, str], along: float = SIDE_ALONG) -> float:
    """[m] how far along its route actor xi's centre moves from its start to meet as `place_third` places it."""
    _, gap_k, _, _, extent, _ = meeting
    if cascade.meeting_mode(later[0], later[2]) == "side":
        return gap_k - along * plan.length[xi]
    return gap_k - plan.length[xi] / 2 - extent


def _meet_at(plan: VariationPlan, a: int, reach: float, arrive: float, passing: tuple[int, ...] = ()) -> bool:
    """Actor a covers `reach` [m] along its route by `arrive` [s]: it starts where that takes its own speed, else
    (no room behind) it drives slower and waits (`_arrive_later`); False when it cannot."""
    placed = shift_start(plan.ctx.arrays, a, plan.route, plan.s0, reach - plan.speeds[a] * arrive, plan.length,
                         plan.d0, passing=passing)
    if placed is not None:
        plan.s0[a] = placed
        plan.moved[a] = True
        return True
    return _arrive_later(plan, a, reach, arrive)


def _arrive_later(plan: VariationPlan, a: int, reach: float, arrive: float) -> bool:
    """Actor a, with no room to start further back, covers `reach` [m] in `arrive` [s] instead by driving
    slower (within its timing range) and, if that is not slow enough, waiting at its start; False when it
    cannot arrive in time."""
    if reach <= 0 or arrive <= 0:
        return False
    sc = reach / arrive / plan.speeds[a]  # [-] on its planned speed
    if sc > timing.SPEED_SCALE[1]:
        return False
    sc = max(timing.SPEED_SCALE[0], sc)
    plan.scale[a] *= sc
    plan.speeds[a] *= sc
    plan.hold[a] = max(0.0, arrive - reach / plan.speeds[a])
    return True


def pushed_meetings(plan: VariationPlan, ti: int, xi: int, paths: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                    poses: list[tuple[float, float, float]], later: tuple[str, str, str]
                    ) -> list[tuple[int, float, str, str, float, float] | None]:
    """Where the third actor xi meets actor ti moving along each `path` after an impact (cascade.pushed_paths,
    clip_slide: forward, left, yaw in the frame of its `pose`), all measured at once (each point as it would
    be alone): (step of the path, station on xi's route from its start [m] (negative: behind it, where it is
    then placed), the class of that contact, ti's area facing xi, its half extent across xi's path [m], how
    far [deg] its heading is inside the written class's range): the step where that contact has the `later`
    (class, ti's area, xi's area) written (xi met as cascade.meeting_mode says), else the one nearest a drawn
    moment in the window after ti enters xi's path (the first step it reaches xi's side, when it comes
    alongside into it); None for a path that never meets xi."""
    if not paths:
        return []
    return meetings_along(plan, xi, along_route(plan, ti, xi, paths, poses), later)


@dataclass(frozen=True)
class AlongRoute:
    """Paths of a moving actor measured against a third actor's route (`along_route`), each point's: how far
    [m] left of the route's nearest point (inf: beyond NEAR_ROUTE), that point's station from the third actor's
    start [m] and heading [rad], the moving actor's heading [rad] and how far it is turned from the route's [rad],
    its half extent across the route [m], and whether the third actor could be placed further back to meet there;
    the paths' `sizes` (points each, concatenated in path order)."""

    lat: np.ndarray
    gap: np.ndarray
    yaw_x: np.ndarray
    turned: np.ndarray
    rel: np.ndarray
    extent: np.ndarray
    room: np.ndarray
    sizes: np.ndarray

    @cached_property
    def starts(self) -> np.ndarray:
        """Each path's first point in the concatenated arrays."""
        return np.cumsum(self.sizes) - self.sizes

    def lateral(self, path: int, step: int) -> float:
        """[m] how far left of the route's nearest point path `path` is at `step` (as stations.relative_to_route
        has it where that is within NEAR_ROUTE; inf further away)."""
        return float(self.lat[int(self.starts[path]) + step])


def along_route(plan: VariationPlan, ti: int, xi: int, paths: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                poses: list[tuple[float, float, float]]) -> AlongRoute:
    """Actor ti's `paths` (`pushed_meetings`) measured against actor xi's route from its start (what does not
    depend on where across its route xi starts: `meetings_along` of xi there)."""
    arrays = plan.ctx.arrays
    world = [cascade.to_world(px, py, pyaw, fwd, left) for (px, py, pyaw), (fwd, left, _) in zip(poses, paths)]
    sizes = np.array([len(w[0]) for w in world])
    wx, wy = np.concatenate([w[0] for w in world]), np.concatenate([w[1] for w in world])
    yaw = np.concatenate([p[2] for p in paths])
    pyaw = lockstep.per_element((p[2] for p in poses), sizes)
    r = plan.route[xi]
    xy = arrays.xy[r]
    k_route, dist = route_nearest(xy, wx, wy, sizes)
    ryaw = arrays.yaw[r, k_route]
    lat = -np.sin(ryaw) * (wx - xy[k_route, 0]) + np.cos(ryaw) * (wy - xy[k_route, 1])
    lat = np.where(dist <= NEAR_ROUTE, lat, np.inf)
    gap = k_route * ROUTE_DS - plan.s0[xi]
    yaw_x = arrays.point(np.full(len(gap), r), plan.s0[xi] + gap)[2]
    turned = pyaw + yaw
    rel = turned - yaw_x
    extent = plan.length[ti] / 2 * np.abs(np.sin(rel)) + plan.width[ti] / 2 * np.abs(np.cos(rel))
    # on its route far enough from its start for it to be placed further back to meet there
    room = k_route * ROUTE_DS > START_MARGIN + plan.length[xi]
    return AlongRoute(lat, gap, yaw_x, turned, rel, extent, room, sizes)


def meetings_along(plan: VariationPlan, xi: int, measured: AlongRoute, later: tuple[str, str, str]
                   ) -> list[tuple[int, float, str, str, float, float] | None]:
    """`pushed_meetings` of the paths `measured` against actor xi's route (`along_route`), xi starting where it
    is across its route now."""
    lat, gap, yaw_x, turned, rel, extent = (measured.lat, measured.gap, measured.yaw_x, measured.turned,
                                            measured.rel, measured.extent)
    sizes, starts = measured.sizes, measured.starts
    hits = (np.abs(lat - plan.d0[xi]) < plan.width[xi] / 2 + extent - 0.3) & measured.room
    side = cascade.meeting_mode(later[0], later[2]) == "side"
    # the face of ti turned towards xi: xi comes from behind it, or (side) ti comes into xi's side
    toward = cascade.toward_third(yaw_x, later[2]) - math.pi if side else yaw_x
    at = np.nonzero(hits)[0]  # every path's hits, path by path
    out: list = [None] * len(sizes)
    if not len(at):
        return out
    path = np.searchsorted(starts + sizes, at, side="right")
    hit = at - starts[path]  # [steps] along its path
    klass = cascade.contact_class(rel[at], side)
    area = cascade.facing_area(turned[at], toward[at])
    margin = cascade.class_margin(rel[at], later[0], side)
    # the steps with the written class and area (else the nearest to them), and among those the ones whose
    # heading is near the most central one: a struck car that spins fast is in the class's range only
    # briefly, and what the prediction does not foresee shifts the moment of contact
    # (then those where its centre is in xi's lane: it is in the path it meets xi in, not just reaching
    # into it; one coming alongside into xi's side touches it before it is in its lane)
    inside = side | (np.abs(lat[at] - plan.d0[xi]) < plan.lane_width / 2)
    # (class, area, inside) misses as one number ordered as the tuples are
    group = 4 * (klass != later[0]) + 2 * (area != later[1]) + ~inside
    best = _per_run(np.minimum, group, path)
    central = _per_run(np.maximum, np.where(group == best, margin, -np.inf), path) - CASCADE_CENTRAL
    # ...as soon as it reaches xi's side (later it would be inside xi's body), else at a drawn moment
    want = _per_run(np.minimum, hit, path) + (0.0 if side else plan.draws.cascade[xi] * CASCADE_WINDOW / cascade.DT)
    order = np.lexsort((np.abs(hit - want), margin < central, group, path))  # by path, then the smallest keys
    for i in order[_run_starts(path[order])]:  # each path's first
        p, k = int(path[i]), int(hit[i])
        out[p] = (k, float(gap[starts[p] + k]), str(klass[i]), str(area[i]), float(extent[starts[p] + k]),
                  float(margin[i]))
    return out


def _run_starts(values: np.ndarray) -> np.ndarray:
    """The indices where a run of equal values starts (`values` not empty)."""
    return np.nonzero(np.r_[True, values[1:] != values[:-1]])[0]


def route_nearest(xy: np.ndarray, x: np.ndarray, y: np.ndarray, sizes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index, distance [m]) of the nearest route point `xy` (K, 2) to each point (x, y) of paths of `sizes`
    points each (concatenated in path order), where that distance is at most NEAR_ROUTE (`nearest_within`);
    elsewhere further than NEAR_ROUTE (inf for every point of a path with a NaN point). A path point further
    than NEAR_ROUTE from the route cannot meet a car on it; only the route points within NEAR_ROUTE of a path's
    box are measured."""
    starts = np.cumsum(sizes) - sizes
    index, dist = np.zeros(len(x), dtype=np.intp), np.full(len(x), np.inf)
    if not len(x):
        return index, dist
    boxes = [np.minimum.reduceat(x, starts), np.maximum.reduceat(x, starts), np.minimum.reduceat(y, starts),
             np.maximum.reduceat(y, starts)]  # each path's; NaN when it has a NaN point
    near = (xy[None, :, 0] >= boxes[0][:, None] - NEAR_ROUTE) & (xy[None, :, 0] <= boxes[1][:, None] + NEAR_ROUTE) \
        & (xy[None, :, 1] >= boxes[2][:, None] - NEAR_ROUTE) & (xy[None, :, 1] <= boxes[3][:, None] + NEAR_ROUTE)
    rows = np.repeat(near.any(axis=1), sizes)  # the points of paths with a route point near their box
    cols = np.nonzero(near.any(axis=0))[0]
    if len(cols):
        nearest, dist[rows] = nearest_within(xy[cols], x[rows], y[rows], NEAR_ROUTE)
        index[rows] = cols[nearest]
    return index, dist


BLOCK = 16  # [-] consecutive points `nearest_within` rules out together by their box (8 m of route, ROUTE_DS)
BLOCK_SLACK = 1e-6  # [m] a block is measured when its box is this much beyond `reach` too (rounding of the box test)


def nearest_within(xy: np.ndarray, x: np.ndarray, y: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """(index, distance [m]) of the nearest of the points `xy` (K, 2) to each point (x, y) (N,) where that
    distance is at most `reach` [m]: the first of the smallest `np.hypot` distances, as `argmin` over them all
    gives it; elsewhere a distance further than `reach` (inf: none within reach of a block's box, or a NaN
    point). The points `xy` are taken in blocks of BLOCK consecutive ones (a route's lie together), and a block
    is measured point by point only for the points (x, y) within `reach` of its box; then only the few points
    whose squared distance is within rounding of the smallest are measured with `hypot` (a squared distance is
    off by a few ulps at most, so the nearest is always among them)."""
    index, dist = np.zeros(len(x), dtype=np.intp), np.full(len(x), np.inf)
    if not len(x) or not len(xy):
        return index, dist
    blocks = np.full((-(-len(xy) // BLOCK) * BLOCK, 2), np.inf)  # the last block filled with points never nearest
    blocks[:len(xy)] = xy
    blocks = blocks.reshape(-1, BLOCK, 2)
    lo, hi = blocks.min(axis=1), blocks.max(axis=1)  # each block's box (the last one's unbounded above)
    gx = np.maximum(np.maximum(lo[None, :, 0] - x[:, None], x[:, None] - hi[None, :, 0]), 0.0)
    gy = np.maximum(np.maximum(lo[None, :, 1] - y[:, None], y[:, None] - hi[None, :, 1]), 0.0)
    point, block = np.nonzero(gx * gx + gy * gy <= (reach + BLOCK_SLACK) ** 2)  # by point, then block
    if not len(point):
        return index, dist
    dx, dy = blocks[block, :, 0] - x[point, None], blocks[block, :, 1] - y[point, None]  # (pairs, BLOCK)
    squared = dx * dx + dy * dy
    least = _per_run(np.minimum, squared.min(axis=1), point)
    row, j = np.nonzero(squared <= least[:, None] * (1.0 + 1e-9) + 1e-300)
    point, col, measured = point[row], block[row] * BLOCK + j, np.hypot(dx[row, j], dy[row, j])  # by point, index
    first = np.nonzero(measured == _per_run(np.minimum, measured, point))[0]
    take = first[_run_starts(point[first])]  # each point's first of its smallest distances
    index[point[take]], dist[point[take]] = col[take], measured[take]
    return index, dist


def _per_run(ufunc: np.ufunc, values: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """`ufunc` reduced over each run of equal `keys` (not empty), given back at each of the run's elements."""
    runs = _run_starts(keys)
    return np.repeat(ufunc.reduceat(values, runs), np.diff(np.r_[runs, len(keys)]))


def later_terms(contact: tuple[str, str, str, str, str], mover: str) -> tuple[str, str, str]:
    """A written later contact (striking, struck, class, striking area, struck area) as a meeting plan reads it:
    (class, the area of the actor `mover` (the role a contact before set moving), the area of the other one)."""
    striking, struck, klass, striking_area, struck_area = contact
    return (klass, striking_area, struck_area) if striking == mover else (klass, struck_area, striking_area)


CLASS_MATCH = 2  # [-] what `matches` gives the written class (the area adds 1)


def matches(meeting: tuple[int, float, str, str, float, float], later: tuple[str, str, str]) -> int:
    """How well a predicted meeting (`pushed_meetings`) has the written later contact (class, area):
    2 for the class, plus 1 for the area."""
    return CLASS_MATCH * (meeting[2] == later[0]) + (meeting[3] == later[1])
