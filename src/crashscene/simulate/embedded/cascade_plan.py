"""A cascade, in reproduce mode: a written sequence that starts with an end-on contact (a rear-end into a
stopped car, a head-on) and goes on with a third vehicle meeting the struck car (pushed) or the striker
(deflected). The striker hits off the struck car's centre line on the side whose impulse (`cascade.pushes`, the
simulator's impact model) sends the moving one where the third vehicle meets it with the written class, and the
third vehicle is placed to meet it there (`meetings`).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from crashscene.dsl.tokens import STANDING
from crashscene.monitor.rules import Disposition
from crashscene.render.plan import LATERAL_BEHAVIORS
from crashscene.simulate.embedded import cascade, followon, lockstep, timing
from crashscene.simulate.embedded.clip import pull_out_path
from crashscene.simulate.embedded.lateral import DRIFT_BEHAVIORS
from crashscene.simulate.embedded.meetings import SIDE_ALONG, later_terms, matches, place_third, pushed_meetings
from crashscene.simulate.embedded.stations import STOP_DECEL, relative_to_route, start_clear

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

SPEEDING_RUN = 2.0  # [s] a striker charged with speeding drives this long before its impact (rules: 1 s over)
CASCADE_SETTLE = 1.5  # [s] a striker steering to the corner it is to hit is there this long before the impact
CASCADE_LAG = 0.7  # [-] a steering driver follows its lateral reference this much slower than the reference moves
CASCADE_ACROSS = 0.9  # [-] at most this part of the way across is done before the scene starts
NUDGES = (0.025, 0.05, 0.075)  # [s] how much further back (at its speed) a striker whose impact is to set off a
# fourth contact may start: a quarter, a half and three quarters of the simulator's step (0.1 s), where in that step
# the touch falls changing what an offset impact does (followon.steady)
STOP_NEAR_JUNCTION = 40.0  # [m] a stopping driver this close to a junction stops at its line


def plan_cascade(plan: VariationPlan) -> None:
    """A written sequence that starts with an end-on contact (a rear-end into a stopped car, a head-on) and
    goes on with a third vehicle meeting the struck one, or the striker: the striker hits the struck car off
    its centre line, on the side that sends the one the third vehicle meets (the struck car pushed, the striker
    deflected: the impulse of cascade.pushed_paths, the simulator's impact model) so that the third vehicle
    meets it as the later contact's class says, and the third vehicle is placed to reach it just after it is
    in its path (or, with no room behind, slowed and held at its start; or beside it, when it comes alongside
    into its side: `meetings.place_third`); a striker steering across (an overtake) is on its corner before the impact
    (`_settle_before`), one drifting (off the road, into the next lane) drifts into it (`_drift_into`)."""
    found = _cascade_actors(plan)
    if found is None:
        return
    si, ti, mover, xi = found[:4]
    nxt = followon.next_contact(plan, (si, ti, xi), mover, xi)  # a fourth contact after the third car's
    if nxt is None:
        _plan_cascade(plan, found)
        return
    # a fourth contact: when the plan where they are does not have it (followon.full), the cascade's three may start
    # further from the fourth actor's side (group_shifts), and then the striker a little further back (NUDGES);
    # the plan whose chosen options have it best (followon.choose's order) is kept
    before = plan.snapshot()
    alternatives = [(shift, 0.0) for shift in followon.group_shifts(plan, nxt.actor, (si, ti, xi))]
    alternatives += [(None, nudge) for nudge in NUDGES]
    best_key, best, best_shift = _plan_cascade(plan, found), None, 0.0
    for shift, nudge in alternatives:
        if best_key is not None and followon.full(best_key):
            break
        if best is None:
            best = plan.snapshot()
        plan.restore(before)
        shift = best_shift if shift is None else shift
        followon.shift_across(plan, (si, ti, xi), shift)
        if nudge:
            back = plan.start_back(si, nudge * float(plan.speeds[si]))
            if back is None:
                continue
            plan.s0[si], plan.moved[si] = back, True
        key = _plan_cascade(plan, found)
        if key is not None and (best_key is None or key > best_key):
            best_key, best, best_shift = key, plan.snapshot(), shift
    if best is not None:
        plan.restore(best)


def _plan_cascade(plan: VariationPlan, found: tuple[int, int, int, int, str, tuple[str, str, str]]) -> tuple | None:
    """`plan_cascade` with the actors where they start now; with a fourth contact, how well the chosen options
    have it (followon.Choice.key; None when nothing was placed)."""
    si, ti, mover, xi, first_class, later = found
    head_on = first_class == "head_on"
    arrays, cols = plan.ctx.arrays, plan.ctx.columns
    impact = _first_impact(plan, si, ti, head_on)
    if impact is None:
        return None
    t1, impact_s, v_t = impact
    px, py, pyaw = followon.route_pose(plan, ti, impact_s, float(plan.d0[ti]))  # the struck car's centre
    t_touch = _touch_time(plan, si, ti, t1, (px, py), head_on)
    x_actor = plan.scene.actors[xi]
    _, lat_x = relative_to_route(arrays, plan.route[ti], plan.s0[ti], x_actor.x, x_actor.y)
    preferred = -1.0 if lat_x - plan.d0[ti] >= 0 else 1.0  # tried first; both sides are tried
    # a car standing still is pushed as predicted: the plan chooses how far off its centre line to hit it; one
    # that is moving (and braking for what it sees coming) is hit at the usual corner
    corners = cascade.CORNERS if v_t == 0.0 or head_on else (cascade.CORNER,)
    nxt = followon.next_contact(plan, (si, ti, xi), mover, xi)  # a fourth contact after the third car's
    choice = None
    if nxt is not None and len(corners) > 1:
        corners = followon.CORNERS
    offsets = np.array([side * c for side in (preferred, -preferred) for c in corners])
    _, lat_s = relative_to_route(arrays, plan.route[si], plan.s0[si], px, py)
    drifting = cols[si].behavior in LATERAL_BEHAVIORS and not head_on
    # every offset's push at once, with every other variation's (lockstep.run); a drifting striker comes at the
    # heading its drift has when it reaches that corner (`_drift_into`)
    approaches = [_drift_approach(plan, si, t1, lat_s + o * plan.width[ti], t_touch) if drifting
                  else (0.0, 0.0, 0.0) for o in offsets]
    items = [cascade.Push(
        float(plan.speeds[si]), float(v_t), np.array([o + approach[2] / plan.width[ti]]), cols[si].limits.mass,
        cols[ti].limits.mass, float(plan.length[si]), float(plan.width[si]), float(plan.length[ti]),
        float(plan.width[ti]), plan.ctx.friction, head_on,
        (cols[si].limits.wheelbase_ratio, cols[ti].limits.wheelbase_ratio), plan.ctx.skid_paths.dt, *approach[:2],
        lead=cascade.step_lead(t_touch, plan.ctx.skid_paths.dt)) for o, approach in zip(offsets, approaches)]
    found = lockstep.together(cascade.pushes_moving if nxt is not None else cascade.pushes, items)
    fwd, left, yaw = (np.concatenate([one[0][q] for one in found]) for q in range(3))
    striker = tuple(np.concatenate([one[1][q] for one in found]) for q in range(3))
    rates = [tuple(np.concatenate([one[k][q] for one in found]) for q in range(3, 6))
             for k in (0, 1)] if nxt is not None else None  # [m/s, m/s, rad/s] (forward, left, yaw rate)
    again = cascade.touch_again((fwd, left, yaw), striker, float(plan.length[ti]), float(plan.width[ti]),
                                float(plan.length[si]), float(plan.width[si]))
    best, best_score = None, (-1, False, -math.inf)
    moving = (fwd, left, yaw) if mover == ti else striker
    meetings = pushed_meetings(plan, mover, xi, [tuple(q[j] for q in moving) for j in range(len(offsets))],
                               [(px, py, pyaw)] * len(offsets), later)
    # a corner the striker would have to start beside another vehicle's body for (a wide truck drifting into the
    # corner of a car on the shoulder, the next lane's car alongside) is not taken while another corner is clear
    clear = [start_clear(plan, si, _start_lateral(plan, si, t1, lat_s + o * plan.width[ti], head_on))
             for o in offsets]
    if any(clear):
        meetings = [meeting if ok else None for meeting, ok in zip(meetings, clear)]
    # a striker drifting out of the lane ahead of it is no obstacle to a start behind it
    passing = (si,) if plan.ctx.columns[si].behavior in LATERAL_BEHAVIORS else ()
    if nxt is not None:
        rate = rates[0] if mover == ti else rates[1]
        paths = [(*cascade.to_world(px, py, pyaw, moving[0][j], moving[1][j]), pyaw + moving[2][j],
                  *cascade.to_world(0.0, 0.0, pyaw, rate[0][j], rate[1][j]), rate[2][j])
                 for j in range(len(offsets))]
        alongs = followon.ALONGS if cascade.meeting_mode(later[0], later[2]) == "side" else (SIDE_ALONG,)
        # a push the striker does not repeat before the meeting, whose moving car is where it is predicted at the
        # meeting also when the impact comes a little otherwise than planned (followon.steady)
        steady = followon.steady(items, moving, mover == si, [m[0] if m is not None else None for m in meetings])
        choice = followon.choose(plan, nxt, [(j, float(o), m, not again[j, m[0]], steady[j]) for j, (o, m) in
                                             enumerate(zip(offsets, meetings)) if m is not None],
                                 paths, t_touch, mover, xi, later, passing, alongs)
        if choice is not None:
            best = (choice.offset, *choice.meeting)
    for j, (offset, meeting) in enumerate(zip(offsets, meetings) if nxt is None else ()):
        if meeting is None:
            continue
        # the written class first, then the side of the moving car it names, then a push the striker does not
        # repeat before the meeting (a second push turns the struck car otherwise than predicted), then the
        # heading furthest inside the class's range (the least sensitive to what the plan does not foresee)
        score = (matches(meeting, later), not again[j, meeting[0]], meeting[5])
        if score > best_score:
            best, best_score = (float(offset), *meeting), score
    if best is None:
        return None
    side, k = best[:2]
    # (the options for a fourth contact were predicted from the exact time of the touch)
    along, t0 = (choice.along, t_touch) if nxt is not None else (SIDE_ALONG, t1)
    if not place_third(plan, xi, best[1:], later, t0 + (k + 1) * cascade.DT, passing, along):
        return None
    # the striker holds its centre off the struck car's centre line, toward the corner it hits (its own
    # left is the struck car's right when it comes the other way)
    offset = side * plan.width[ti] * (-1.0 if head_on else 1.0)
    if cols[si].behavior in LATERAL_BEHAVIORS and head_on:
        plan.lateral_target[si] += offset
        _settle_before(plan, si, t1)
    elif cols[si].behavior in LATERAL_BEHAVIORS:
        _drift_into(plan, si, t1, lat_s + offset)
    else:
        target = (plan.lateral_target[si] if head_on else lat_s) + offset
        plan.drifted[si] += target - plan.d0[si]
        plan.d0[si] = target
        plan.lateral_target[si] = target
    if nxt is not None:  # the fourth actor, in the lane and at the time the chosen contact sends the car into
        followon.place(plan, nxt, choice)
    return choice.key if choice is not None else None


def _start_lateral(plan: VariationPlan, a: int, t1: float, target: float, head_on: bool) -> float:
    """[m] where across its route the striker a starts when it is to strike a corner `target` [m] off its route at
    t1 [s] (as `_plan_cascade` places it): a drifting one where its drift into it starts (`_drift_into`), one
    steering across to a head-on, or coming head-on, where it is; else on the corner's line."""
    if head_on:
        return float(plan.d0[a])
    if plan.ctx.columns[a].behavior in LATERAL_BEHAVIORS:
        k, rows, sign = _drift_lead(plan, a, t1, target)
        return target - sign * (float(np.abs(rows[1][0])[k]) if k >= 0 else 0.0)
    return target


def _touch_time(plan: VariationPlan, si: int, ti: int, t1: float, point: tuple[float, float], head_on: bool) -> float:
    """[s] when the first contact of a cascade happens (`_first_impact`'s time t1 [s], which measures the gap to the
    nearest route sample, ROUTE_DS): the gap to the struck car's centre `point` [m] measured exactly, closed at the
    striker's speed (both speeds, head-on)."""
    gap, _ = relative_to_route(plan.ctx.arrays, plan.route[si], plan.s0[si], *point)
    exact, _ = relative_to_route(plan.ctx.arrays, plan.route[si], plan.s0[si], *point, exact=True)
    closing = plan.speeds[si] + (plan.speeds[ti] if head_on else 0.0)
    return t1 + (exact - gap) / max(float(closing), 0.5)


def _drift_into(plan: VariationPlan, a: int, t1: float, target: float) -> None:
    """Actor a drifts (its lateral manoeuvre, swerve.path) into the corner of a stopped car it strikes at t1 [s],
    its centre `target` [m] off its route then: the manoeuvre is under way its lead time before (less when that
    would start it outside its lane), from where it takes it to the corner."""
    k, rows, sign = _drift_lead(plan, a, t1, target)
    dt = plan.ctx.skid_paths.dt
    across = np.abs(rows[1][0])  # [m] how far across it is every dt after its trigger
    lead = (k + 1) * dt if k >= 0 else 0.0
    shift = target - sign * (float(across[k]) if k >= 0 else 0.0) - plan.d0[a]
    plan.d0[a] += shift
    plan.drifted[a] += shift
    plan.trigger[a] = max(t1 - lead, 0.0)


def _drift_approach(plan: VariationPlan, a: int, t1: float, target: float, touch: float
                    ) -> tuple[float, float, float]:
    """(heading off its route [rad], yaw rate [rad/s], how much further across [m] than `target` it is) of actor a
    drifting (`_drift_into`) into a corner `target` [m] off its route at t1 [s], as it touches at `touch` [s]: its
    driver starts the drift at the first simulator step at or after its trigger, so that it is where its drift is
    then, not where the plan's whole steps put it."""
    k, rows, sign = _drift_lead(plan, a, t1, target)
    if k < 0:
        return 0.0, 0.0, 0.0
    _, across, yaw = (q[0] for q in rows)
    dt = plan.ctx.skid_paths.dt
    trigger = max(t1 - (k + 1) * dt, 0.0)
    start = math.ceil(trigger / dt - 1e-9) * dt  # [s] the step its driver sees the trigger at
    at = float(np.clip((touch - start) / dt - 1.0, -1.0, len(yaw) - 1.0))  # [steps of its path], -1: its start
    steps = np.arange(-1, len(yaw))
    heading = float(np.interp(at, steps, np.concatenate([[0.0], yaw])))
    j = int(np.clip(math.floor(at), 0, len(yaw) - 1))
    rate = float(yaw[j] - (yaw[j - 1] if j >= 1 else 0.0)) / dt
    further = float(np.interp(at, steps, np.concatenate([[0.0], across]))) - float(across[k])
    return sign * heading, sign * rate, sign * further


def _drift_lead(plan: VariationPlan, a: int, t1: float, target: float) -> tuple[int, tuple[np.ndarray, ...], float]:
    """(the step of its path actor a is at when it strikes at t1 [s] (-1: it starts there), its drift path
    (swerve.path, turning left), the side it turns to) when it drifts into a corner `target` [m] off its route
    (`_drift_into`): its lead time, less when that would start it outside its lane."""
    rows = pull_out_path(plan, a, timing.lateral_rate(plan.ctx.columns[a].behavior))
    sign = 1.0 if plan.lateral_target[a] >= plan.d0[a] else -1.0
    across = np.abs(rows[1][0])  # [m] how far across it is every dt after its trigger
    room = max(plan.lane_width - plan.width[a], 0.0) / 2  # [m] its start stays within its lane
    k = int(round(min(plan.lead_time(a), t1) / plan.ctx.skid_paths.dt)) - 1
    while k > 0 and abs(target - sign * across[k] - plan.d0[a]) > room:
        k -= 1
    return k, rows, sign


def _settle_before(plan: VariationPlan, a: int, t1: float) -> None:
    """Actor a steers across to its lateral target and is there CASCADE_SETTLE [s] before its impact at t1 [s]:
    it starts earlier, or is already part of the way across at the start (the corner it is to hit is further
    across than the partner's path its trigger was timed to)."""
    rate = CASCADE_LAG * timing.lateral_rate(plan.ctx.columns[a].behavior)
    left = plan.lateral_target[a] - plan.d0[a]
    plan.trigger[a] = float(np.clip(t1 - CASCADE_SETTLE - abs(left) / rate, 0.0, plan.trigger[a]))
    short = abs(left) - max(t1 - CASCADE_SETTLE - plan.trigger[a], 0.0) * rate
    if short > 0:
        shift = min(short, CASCADE_ACROSS * abs(left)) * math.copysign(1.0, left)
        plan.d0[a] += shift
        plan.drifted[a] += shift


def _first_impact(plan: VariationPlan, si: int, ti: int, head_on: bool) -> tuple[float, float, float] | None:
    """(time [s], the struck actor's station [m], its speed [m/s]) of the first written contact: a rear-end
    into a stopped car (a striker charged with speeding starts far enough back to be seen speeding), or a
    head-on between two actors closing in; None when it cannot be told."""
    arrays = plan.ctx.arrays
    v_s = plan.speeds[si]
    l_sum = (plan.length[si] + plan.length[ti]) / 2
    if head_on:
        v_t = plan.speeds[ti]
        other = plan.scene.actors[si]
        gap, _ = relative_to_route(arrays, plan.route[ti], plan.s0[ti], other.x, other.y)
        t1 = (gap - l_sum) / max(v_s + v_t, 0.5)
        return (t1, plan.s0[ti] + v_t * t1, v_t) if t1 > 0 else None
    impact_s = _stop_station(plan, ti)
    if impact_s is None:
        return None
    px, py, _ = (float(q) for q in arrays.point(np.array(plan.route[ti]), np.array(impact_s)))
    gap_s, _ = relative_to_route(arrays, plan.route[si], plan.s0[si], px, py)
    t1 = (gap_s - l_sum) / max(v_s, 0.5)
    if 0 < t1 < SPEEDING_RUN and Disposition.SPEEDING in plan.ctx.columns[si].traits:
        # a driver charged with speeding is seen speeding before it strikes: it started further back
        back = plan.start_back(si, (SPEEDING_RUN - t1) * v_s)
        if back is not None:
            t1 = SPEEDING_RUN
            plan.s0[si] = back
            plan.moved[si] = True
    return (t1, impact_s, 0.0) if t1 > 0 else None


def _cascade_actors(plan: VariationPlan) -> tuple[int, int, int, int, str, tuple[str, str, str]] | None:
    """(striker, struck, the one of them that meets a third actor next, the third actor, first class, (later
    class, the mover's area in it, the third's)) of a written end-on first contact (a rear-end into a stopped
    car, a head-on) followed by a contact of either of its two actors with a third one that drives freely
    straight on (the struck car pushed into its path, or the striker deflected into it); else None."""
    seq = plan.ctx.contacts
    cols = plan.ctx.columns
    roles = [c.role for c in cols]
    if len(seq) < 2 or seq[0][2] not in ("rear_end", "head_on") \
            or not all(r in roles for c in seq for r in c[:2]):
        return None
    si, ti = roles.index(seq[0][0]), roles.index(seq[0][1])
    for later_contact in seq[1:]:
        striking, struck = later_contact[:2]
        pair = {striking, struck}
        if (roles[ti] in pair) != (roles[si] in pair):
            mover = ti if roles[ti] in pair else si
            xi = roles.index((pair - {roles[mover]}).pop())
            later = later_terms(later_contact, roles[mover])
            break
    else:
        return None
    if cols[si].is_ads or cols[xi].is_ads or cols[xi].behavior != "go_forward":
        return None
    # a rear-end into a stopped car, by a driver going straight on or drifting into it (not one whose loss of
    # control is planned as a skid)
    if seq[0][2] == "rear_end" and (cols[si].behavior not in ("go_forward", *DRIFT_BEHAVIORS)
                                    or cols[ti].behavior not in STANDING):
        return None
    if seq[0][2] == "head_on" and (cols[ti].is_ads or cols[ti].behavior != "go_forward"
                                   or cols[si].behavior not in ("go_forward", "overtake", "cross_centerline")):
        return None
    return si, ti, mover, xi, seq[0][2], later


def _stop_station(plan: VariationPlan, a: int) -> float | None:
    """[m] where a stopping (or static) actor stands still: after its trigger and braking, or at its line."""
    v = plan.speeds[a]
    if plan.ctx.columns[a].behavior == "static":
        return float(plan.s0[a])
    trig = plan.trigger[a]
    if not np.isfinite(trig):
        return None
    s = plan.s0[a] + v * trig + v * v / (2 * STOP_DECEL)
    entries = plan.ctx.arrays.entry_s[plan.route[a]]
    ahead = entries[np.isfinite(entries) & (entries > plan.s0[a])]
    if len(ahead) and ahead[0] - plan.s0[a] < s - plan.s0[a] + STOP_NEAR_JUNCTION:
        s = min(s, ahead[0] - 1.0 - plan.length[a] / 2)
    return float(s)
