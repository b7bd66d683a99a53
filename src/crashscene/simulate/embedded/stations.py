"""Where an actor of one variation's plan starts along its route, and where it is later on its lane: the
stations a plan moves a start to (only where the lane has room), an actor's gap and lateral offset from a route
point, and its motion along its lane as its behaviour has it (no car following).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from crashscene.geometry import footprints_overlap
from crashscene.simulate.drivers.behaviors import DECELERATE_RATE, DECELERATE_TO
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

START_MARGIN = 5.0  # [m] an actor moved back along its route stays this far from the route's start
END_MARGIN = 100.0  # [m] ...and one moved on, this far from its end (room to drive through the crash)
START_GAP = 4.0  # [m] bumper gap a moved start keeps from another car of its lane
STRAIGHT_CURVATURE = 1e-5  # [1/m] a route bending less (a radius over 100 km) is straight for a plan's geometry
STOP_DECEL = 4.0  # [m/s2] a stopping driver's braking (drivers.behaviors.DECELERATE_RATE)


def lane_motion(plan: VariationPlan, a: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(station [m], speed [m/s]) of actor a at `times` [s] driving along its lane as its behaviour has it
    (its planned speed; a decelerating or stopping driver brakes from its trigger on); no car following."""
    v0, behavior = float(plan.speeds[a]), plan.ctx.columns[a].behavior
    if behavior == "static":
        return np.full(len(times), float(plan.s0[a])), np.zeros(len(times))
    end = {"decelerate": DECELERATE_TO * v0, "stop": 0.0}.get(behavior, v0)
    rate = DECELERATE_RATE if behavior == "decelerate" else STOP_DECEL
    trig = float(plan.trigger[a]) if np.isfinite(plan.trigger[a]) else math.inf
    braking = np.clip(times - trig, 0.0, (v0 - end) / rate)
    speed = v0 - rate * braking
    s = plan.s0[a] + v0 * np.minimum(times, trig) + (v0 * braking - rate * braking ** 2 / 2) \
        + end * np.maximum(times - trig - (v0 - end) / rate, 0.0)
    return s, speed


def same_lane(route: np.ndarray, d0: np.ndarray | None, a: int, b: int) -> bool:
    """Whether actors a and b start in the same lane (same route, lateral offsets within a lane); (A,) rows."""
    return b != a and route[b] == route[a] and (d0 is None or abs(d0[b] - d0[a]) < 2.0)


def shift_start(arrays: RouteArrays, a: int, route: np.ndarray, s0: np.ndarray, shift: float,
                length: np.ndarray, d0: np.ndarray | None = None, passing: tuple[int, ...] = ()) -> float | None:
    """Station `shift` [m] along actor a's route from its start (negative: back), if the route has room and
    no other actor on the same route is in the way; else None."""
    if shift < 0:
        return start_back(arrays, a, route, s0, -shift, length, d0, passing)
    new = s0[a] + shift
    if new > arrays.length[route[a]] - END_MARGIN:
        return None
    for b in range(len(route)):
        if same_lane(route, d0, a, b) and s0[a] < s0[b] < new + (length[a] + length[b]) / 2 + START_GAP:
            return None
    return float(new)


def start_back(arrays: RouteArrays, a: int, route: np.ndarray, s0: np.ndarray, dist: float,
               length: np.ndarray, d0: np.ndarray | None = None, passing: tuple[int, ...] = ()) -> float | None:
    """Station `dist` [m] behind actor a's start on its route, if the route has room and no other actor on the
    same route is within a car length and a margin of the new start, or between the two (unless it is
    `passing`: leaving the lane); else None. (A,) rows of one variation."""
    new = s0[a] - dist
    if new < START_MARGIN:
        return None
    for b in range(len(route)):
        if same_lane(route, d0, a, b) and (abs(s0[b] - new) < (length[a] + length[b]) / 2 + START_GAP
                                           or (new < s0[b] < s0[a] and b not in passing)):
            return None
    return float(new)


def route_bend(arrays: RouteArrays, r: int, s_from: float, s_to: float) -> float:
    """[1/m] the mean curvature of route r from station s_from to s_to (left positive): its turn over the
    distance; 0.0 on a straight (bending less than STRAIGHT_CURVATURE); the stations are kept on the route."""
    k0, _ = arrays.index(np.array(min(s_from, s_to)))
    k1, _ = arrays.index(np.array(max(s_from, s_to)))
    if k1 <= k0:
        return 0.0
    turn = float(arrays.yaw[r, k1] - arrays.yaw[r, k0])
    bend = math.remainder(turn, math.tau) / (float(k1 - k0) * ROUTE_DS)
    return bend if abs(bend) >= STRAIGHT_CURVATURE else 0.0


def bent_frames(arrays: RouteArrays, r: int, s: np.ndarray, along: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Poses (x, y, yaw) (N,) of the frames in which paths planned along a straight road from stations s (N,)
    of route r are read: the route's pose at s; where the route bends between s and s + along, the frame
    turned and moved so that its point `along` [m] ahead (where the path matters: a contact) lies on the route
    at s + along, heading with it. A lane-keeping driver's offset across the lane and turn from it are the
    straight road's there; what follows that point (a slide) moves as the world has it."""
    x, y, yaw = arrays.point(np.full(len(s), r), s)
    bent = np.array([route_bend(arrays, r, a, a + b) != 0.0 for a, b in zip(s, along)], dtype=bool)
    if bent.any():
        ahead = along[bent]
        cx, cy, x_yaw = arrays.point(np.full(len(ahead), r), s[bent] + ahead)
        x[bent], y[bent], yaw[bent] = cx - np.cos(x_yaw) * ahead, cy - np.sin(x_yaw) * ahead, x_yaw
    return x, y, yaw


def relative_to_route(arrays: RouteArrays, r: int, s: float, x: float, y: float, exact: bool = False
                      ) -> tuple[float, float]:
    """(gap along route r from station s to the point, lateral offset of the point) [m]; the gap to the nearest
    route sample (ROUTE_DS), or with `exact` to the point's own projection on the route."""
    xy = arrays.xy[r]
    k = int(np.argmin(np.hypot(xy[:, 0] - x, xy[:, 1] - y)))
    yaw = arrays.yaw[r, k]
    dx, dy = x - xy[k, 0], y - xy[k, 1]
    lateral = -math.sin(yaw) * dx + math.cos(yaw) * dy
    along = math.cos(yaw) * dx + math.sin(yaw) * dy if exact else 0.0
    return k * ROUTE_DS + along - s, lateral


def start_pose(plan: VariationPlan, a: int, lateral: float | None = None) -> tuple[float, float, float]:
    """World pose [m, m, rad] actor a starts at, as the simulator places it (setup._apply_plan_moves): moved along
    its route, the route's point at its start, `lateral` [m] off it when that is a planned offset (over 1 m, or
    drifted), else on it; otherwise its sampled pose shifted across its route by how far the plan drifted it.
    `lateral`: the start offset a plan step would give it instead of its present one (`plan.d0`)."""
    d0 = float(plan.d0[a])
    lateral = d0 if lateral is None else float(lateral)
    drifted = float(plan.drifted[a]) + lateral - d0
    px, py, pyaw = (float(q[0]) for q in plan.ctx.arrays.point(np.array([plan.route[a]]),
                                                              np.array([float(plan.s0[a])])))
    if plan.moved[a]:
        lateral = lateral if abs(lateral) > 1.0 or drifted != 0.0 else 0.0
        return px - math.sin(pyaw) * lateral, py + math.cos(pyaw) * lateral, pyaw
    actor = plan.scene.actors[a]
    return actor.x - math.sin(pyaw) * drifted, actor.y + math.cos(pyaw) * drifted, actor.yaw


def start_clear(plan: VariationPlan, a: int, lateral: float | None = None) -> bool:
    """Whether actor a's body at its start (`start_pose`, `lateral` [m] off its route) is clear of every other
    actor's body at its own: two bodies that overlap at t = 0 make the variation invalid (a spawn overlap)."""
    xa, ya, yawa = start_pose(plan, a, lateral)
    others = [b for b in range(len(plan.ctx.columns)) if b != a]
    if not others:
        return True
    xb, yb, yawb = (np.array(q) for q in zip(*(start_pose(plan, b) for b in others)))
    return not footprints_overlap(xa, ya, yawa, plan.length[a], plan.width[a], xb, yb, yawb, plan.length[others],
                                  plan.width[others]).any()
