"""Where a third actor meets a car an impact sets moving (pushed, deflected, or sliding after a clip), measured
on the predicted paths of every candidate at once, and the third actor placed to meet it there: its start moved
along its route, or (no room behind) slowed and held at its start.
"""
from __future__ import annotations

import math
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
    arrays = plan.ctx.arrays
    if not paths:
        return []
    world = [cascade.to_world(px, py, pyaw, fwd, left) for (px, py, pyaw), (fwd, left, _) in zip(poses, paths)]
    sizes = [len(w[0]) for w in world]
    ends = np.cumsum(sizes)
    wx, wy = np.concatenate([w[0] for w in world]), np.concatenate([w[1] for w in world])
    yaw = np.concatenate([p[2] for p in paths])
    pyaw = lockstep.per_element((p[2] for p in poses), sizes)
    r = plan.route[xi]
    xy = arrays.xy[r]
    # the nearest route point of each path point, among those within NEAR_ROUTE of its path's box: a path point
    # further than NEAR_ROUTE from xi's route cannot meet it, and any nearer one has its nearest among them
    k_route, dist = np.zeros(len(wx), dtype=np.intp), np.full(len(wx), np.inf)
    for end, size, (px, py) in zip(ends, sizes, world):
        near = np.nonzero((xy[:, 0] >= px.min() - NEAR_ROUTE) & (xy[:, 0] <= px.max() + NEAR_ROUTE)
                          & (xy[:, 1] >= py.min() - NEAR_ROUTE) & (xy[:, 1] <= py.max() + NEAR_ROUTE))[0]
        if len(near):  # else no point is near xi's route: it has no hit
            nearest, dist[end - size:end] = nearest_points(xy[near], px, py)
            k_route[end - size:end] = near[nearest]
    ryaw = arrays.yaw[r, k_route]
    lat = -np.sin(ryaw) * (wx - xy[k_route, 0]) + np.cos(ryaw) * (wy - xy[k_route, 1])
    lat = np.where(dist <= NEAR_ROUTE, lat, np.inf)
    gap = k_route * ROUTE_DS - plan.s0[xi]
    yaw_x = arrays.point(np.full(len(gap), r), plan.s0[xi] + gap)[2]
    turned = pyaw + yaw
    rel = turned - yaw_x
    extent = plan.length[ti] / 2 * np.abs(np.sin(rel)) + plan.width[ti] / 2 * np.abs(np.cos(rel))
    # on its route far enough from its start for it to be placed further back to meet there
    hits = (np.abs(lat - plan.d0[xi]) < plan.width[xi] / 2 + extent - 0.3) \
        & (k_route * ROUTE_DS > START_MARGIN + plan.length[xi])
    side = cascade.meeting_mode(later[0], later[2]) == "side"
    # the face of ti turned towards xi: xi comes from behind it, or (side) ti comes into xi's side
    toward = cascade.toward_third(yaw_x, later[2]) - math.pi if side else yaw_x
    out: list = []
    for end, size, (px, py, one_yaw) in zip(ends, sizes, poses):
        lo = end - size
        hit = np.nonzero(hits[lo:end])[0]
        if len(hit) == 0:
            out.append(None)
            continue
        at = lo + hit
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
        best = group.min()
        central = margin[group == best].max() - CASCADE_CENTRAL
        # ...as soon as it reaches xi's side (later it would be inside xi's body), else at a drawn moment
        want = hit[0] + (0.0 if side else plan.draws.cascade[xi] * CASCADE_WINDOW / cascade.DT)
        i = int(np.lexsort((np.abs(hit - want), margin < central, group))[0])  # the first of the smallest keys
        k = int(hit[i])
        out.append((k, float(gap[lo + k]), str(klass[i]), str(area[i]), float(extent[lo + k]), float(margin[i])))
    return out


def nearest_points(xy: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index, distance [m]) of the nearest of the points `xy` (K, 2) to each point (x, y) (N,): the first of
    the smallest `np.hypot` distances, as `argmin` over them all gives it. Only the few points whose squared
    distance is within rounding of the smallest are measured with `hypot` (a squared distance is off by a few
    ulps at most, so the nearest is always among them)."""
    dx, dy = xy[None, :, 0] - x[:, None], xy[None, :, 1] - y[:, None]
    squared = dx * dx + dy * dy
    rows, cols = np.nonzero(squared <= squared.min(axis=1, keepdims=True) * (1.0 + 1e-9) + 1e-300)
    dist = np.hypot(dx[rows, cols], dy[rows, cols])
    first = np.lexsort((cols, dist, rows))  # by point, then distance, then index
    take = first[np.r_[True, rows[first][1:] != rows[first][:-1]]] if len(rows) else rows  # each point's first
    if len(take) != len(x):  # a NaN point: every distance, as argmin takes them
        full = np.hypot(dx, dy)
        nearest = np.argmin(full, axis=1)
        return nearest, full[np.arange(len(x)), nearest]
    return cols[take], dist[take]


def later_terms(contact: tuple[str, str, str, str, str], mover: str) -> tuple[str, str, str]:
    """A written later contact (striking, struck, class, striking area, struck area) as a meeting plan reads it:
    (class, the area of the actor `mover` (the role a contact before set moving), the area of the other one)."""
    striking, struck, klass, striking_area, struck_area = contact
    return (klass, striking_area, struck_area) if striking == mover else (klass, struck_area, striking_area)


def matches(meeting: tuple[int, float, str, str, float, float], later: tuple[str, str, str]) -> int:
    """How well a predicted meeting (`pushed_meetings`) has the written later contact (class, area):
    2 for the class, plus 1 for the area."""
    return 2 * (meeting[2] == later[0]) + (meeting[3] == later[1])
