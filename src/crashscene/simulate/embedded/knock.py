"""A car knocked aside, in reproduce mode: a striker that rear-ends a vehicle and later rear-ends another one
ahead of it in the same lane hits the first at the rear corner that turns it out of the lane soonest
(`cascade.pushed_paths`), and the actors ahead start far enough on that it is out of their lane first.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from crashscene.simulate.embedded import cascade
from crashscene.simulate.embedded.stations import lane_motion, same_lane

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

KNOCK_HORIZON = 15.0  # [s] a knocked-aside car's first impact is looked for this long after the start
KNOCK_CLEAR = 0.5  # [m] ...and it passes the actors ahead of it in its lane this far clear


def knock_aside(plan: VariationPlan) -> None:
    """A striker that rear-ends a vehicle and then, later in the written sequence, rear-ends another one
    ahead of it in the same lane went past the first: it hits the first at a rear corner (its centre a
    fraction of that car's width off the car's, `_room_to_leave`), so that the eccentric impulse and the
    striker's continued push (a heavy striker keeps its driver, crashscene.upset) turn that car out of the lane
    and leave the way on to the next one open."""
    seq, roles = plan.ctx.contacts, [c.role for c in plan.ctx.columns]
    if not seq or seq[0][2] != "rear_end" or not all(r in roles for r in seq[0][:2]):
        return
    si, ti = roles.index(seq[0][0]), roles.index(seq[0][1])
    cols = plan.ctx.columns
    if cols[si].is_ads or cols[si].behavior != "go_forward" or not same_lane(plan.route, plan.d0, si, ti):
        return
    if not any(striking == roles[si] and struck != roles[ti] and klass == "rear_end" and struck in roles
               and same_lane(plan.route, plan.d0, ti, roles.index(struck))
               and plan.s0[roles.index(struck)] > plan.s0[ti] for striking, struck, klass, *_ in seq[1:]):
        return
    drawn = 1.0 if plan.draws.spin[si] > 0 else -1.0
    side, corner = _room_to_leave(plan, si, ti, drawn)
    target = float(plan.d0[ti]) + side * corner * plan.width[ti]
    plan.drifted[si] += target - plan.d0[si]
    plan.d0[si] = target
    plan.lateral_target[si] = target


def _room_to_leave(plan: VariationPlan, si: int, ti: int, drawn: float) -> tuple[float, float]:
    """(side, corner) for the car knocked aside (ti, struck at that rear corner by si, its centre `corner` of
    ti's width off ti's): it leaves its lane only over some distance (cascade.pushed_paths, and carried on by
    a striker that keeps its driver), so the corner that takes it out of the way of the actors ahead of it in
    its lane soonest (`stations.lane_motion`) is chosen (the `drawn` side and cascade.CORNER when nothing is ahead
    in the way), and those actors start far enough further on that it is out of their lane before it reaches
    them."""
    cols = plan.ctx.columns
    lane = [b for b in range(len(cols)) if same_lane(plan.route, plan.d0, ti, b) and plan.s0[b] > plan.s0[ti]]
    default = (drawn, cascade.CORNER)
    times = np.arange(0.0, KNOCK_HORIZON, cascade.DT)
    s_s, _ = lane_motion(plan, si, times)
    s_t, v_t = lane_motion(plan, ti, times)
    hit = np.nonzero(s_s + (plan.length[si] + plan.length[ti]) / 2 >= s_t)[0]
    if not lane or len(hit) == 0 or hit[0] == 0:
        return default
    k1 = int(hit[0])
    choices = [default] + [(side, c) for side in (drawn, -drawn) for c in cascade.CORNERS if (side, c) != default]
    fwd, left, yaw = cascade.pushed_paths(float(plan.speeds[si]), float(v_t[k1]),
                                          np.array([side * c for side, c in choices]), cols[si].limits.mass,
                                          cols[ti].limits.mass, float(plan.length[si]), float(plan.width[si]),
                                          float(plan.length[ti]), float(plan.width[ti]), plan.ctx.friction,
                                          stepped=False)
    # a striker that keeps its driver (a heavy one, crashscene.upset) drives on and pushes it again: it is carried
    # on at least at the striker's speed while it is in the lane
    fwd = np.maximum(fwd, float(plan.speeds[si]) * cascade.DT * np.arange(1, fwd.shape[1] + 1))
    reach_along = plan.length[ti] / 2 * np.abs(np.cos(yaw)) + plan.width[ti] / 2 * np.abs(np.sin(yaw))
    reach_across = plan.length[ti] / 2 * np.abs(np.sin(yaw)) + plan.width[ti] / 2 * np.abs(np.cos(yaw))
    deficit = np.zeros(len(choices))
    for b in lane:
        # until it is clear of b's footprint across the lane, its front stays behind b's rear
        clear = np.abs(left - (plan.d0[b] - plan.d0[ti])) - reach_across > plan.width[b] / 2 + KNOCK_CLEAR
        s_b, _ = lane_motion(plan, b, times[k1:k1 + fwd.shape[1]])
        rear_b = s_b - plan.length[b] / 2 - s_t[k1]
        n = len(rear_b)
        short = fwd[:, :n] + reach_along[:, :n] + KNOCK_CLEAR - rear_b[None, :]
        before = ~np.logical_or.accumulate(clear[:, :n], axis=1)
        deficit = np.maximum(deficit, np.where(before, short, -np.inf).max(axis=1, initial=0.0))
    best = int(np.argmin(deficit))
    if deficit[best] > 0:
        for b in sorted(lane, key=lambda b: -plan.s0[b]):  # the front one first: each makes room for the next
            placed = plan.shift_start(b, float(deficit[best]))
            if placed is None:
                break
            plan.s0[b] = placed
            plan.moved[b] = True
    return choices[best]
