"""Lateral manoeuvres in a timing plan (a lane change, a centre-line crossing, an overtake, a loss of control,
leaving the road), aimed at the partner's path: a clip of the vehicle ahead (`clip`), a sideswipe placed
alongside, a sudden veer or a loss of control planned as a skid (`skid`), else a trigger time; and, in
reproduce mode, a wrong-way driver placed in its head-on partner's lane.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from crashscene.dsl.tokens import LANE_CHANGES, OPPOSING_PASSES
from crashscene.render.plan import LATERAL_BEHAVIORS
from crashscene.scene import SampledScene
from crashscene.simulate.drivers.behaviors import SPIN_RATE
from crashscene.simulate.embedded import skid as skid_plan
from crashscene.simulate.embedded import timing
from crashscene.simulate.embedded.clip import clip
from crashscene.simulate.embedded.stations import relative_to_route, route_bend

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import PlanContext, VariationPlan
    from crashscene.simulate.embedded.setup import ActorColumn

VEER_BEHAVIORS = LANE_CHANGES + OPPOSING_PASSES
DRIFT_BEHAVIORS = VEER_BEHAVIORS + ("leave_road",)  # lateral manoeuvres a driver steers (not a loss of control)
WRONG_WAY_LEFT = 0.4  # [lanes] a drift across several lanes starts this far short of the partner's lane


def plan_lateral(plan: VariationPlan, a: int) -> None:
    """A lane change, centre-line crossing, overtake, loss of control or leaving the road, aimed at the
    partner's path: a sideswipe placed alongside, a sudden veer planned as a skid, else a trigger time."""
    ctx, col = plan.ctx, plan.ctx.columns[a]
    partner = _lateral_partner(plan, a)
    if partner is not None and not skids_toward(plan.ctx, a, partner) and skids_toward(plan.ctx, partner, a) \
            and _lateral_partner(plan, partner) == a:
        return  # the partner's loss of control is planned to meet it on its way: it holds its lane till then
    if partner is None:
        plan.trigger[a] = plan.param(a, ("TRIGGER_TIME", "MANEUVER_TIME"), plan.draws.trigger[a])
        if col.behavior == "lose_control":
            plan.lateral_target[a] = plan.draws.spin[a]
        return
    other = plan.scene.actors[partner]
    gap, lateral = relative_to_route(ctx.arrays, plan.route[a], plan.s0[a], other.x, other.y)
    opposite = math.cos(other.yaw - plan.scene.actors[a].yaw) < -0.3
    dist = _lateral_distance(plan, a, lateral, opposite)
    lead = plan.lead_time(a)
    if col.behavior == "lose_control":
        lead = (lead - 1.4) / 1.2 * 0.6  # [-0.3, 0.3] s around reaching the partner's lane
    rate = timing.lateral_rate(col.behavior)
    p_col = ctx.columns[partner]
    if opposite and not p_col.is_ads and p_col.behavior not in LATERAL_BEHAVIORS and gap > 0:
        _slow_oncoming(plan, a, partner, gap, abs(dist) / rate + lead)
    contact = ctx.classes.get(frozenset((col.role, p_col.role)))
    if not opposite and contact in ("rear_end", "sideswipe") and col.behavior in VEER_BEHAVIORS \
            and plan.contact_area(a, partner) in ("front", "left", "right") \
            and clip(plan, a, partner, gap, contact, rate):
        return
    if contact == "sideswipe" and not opposite and col.behavior in LANE_CHANGES \
            and _place_alongside(plan, a, partner, gap, dist):
        return
    if _plan_skid(plan, a, partner, contact, gap, lateral, opposite):
        return
    if col.behavior == "lose_control":
        t_trig = timing.skid_trigger(gap, plan.speeds[a], plan.speeds[partner], lateral, SPIN_RATE,
                                     opposite=opposite) - lead
    else:
        t_trig = timing.lateral_trigger(gap, plan.speeds[a], plan.speeds[partner], opposite, dist, lead, rate)
    if t_trig < 0 and col.behavior in OPPOSING_PASSES and opposite:
        # too close for the whole manoeuvre: the actor is already drifting across at t = 0; several
        # lanes across (a wrong-way driver on a divided road), it has crossed all but the last part
        reach = max(abs(dist) * 0.6, abs(dist) - WRONG_WAY_LEFT * plan.lane_width)
        shift = float(np.clip(-t_trig * rate, 0.0, reach)) * math.copysign(1.0, dist)
        plan.d0[a] += shift
        plan.drifted[a] = shift
    plan.trigger[a] = max(0.0, t_trig)


def _lateral_partner(plan: VariationPlan, a: int) -> int | None:
    """The actor whose path actor a's lateral manoeuvre is aimed at: the anchor's written partner, else
    `_partner`."""
    partner = _written_partner(plan, a) if a == plan.ctx.anchor else None
    return _partner(a, plan.ctx.anchor, plan.ctx.columns, plan.scene) if partner is None else partner


def _written_partner(plan: VariationPlan, a: int) -> int | None:
    """The other actor of actor a's first written contact, None when it has none."""
    roles = [c.role for c in plan.ctx.columns]
    for striking, struck, *_ in plan.ctx.contacts:
        if roles[a] in (striking, struck):
            other = struck if striking == roles[a] else striking
            return roles.index(other) if other in roles else None
    return None


def _lateral_distance(plan: VariationPlan, a: int, lateral: float, opposite: bool) -> float:
    """[m] how far actor a steers sideways to reach its partner's path (sets a skid's side)."""
    behavior = plan.ctx.columns[a].behavior
    if behavior == "lose_control":
        plan.lateral_target[a] = 1.0 if lateral >= 0 else -1.0
        return 2.5
    if behavior == "cross_centerline" and opposite and lateral > plan.lateral_target[a] > 0:
        # several opposing lanes: drift as far as the oncoming partner's lane
        plan.lateral_target[a] = lateral
        return lateral - plan.d0[a]
    return plan.lateral_target[a] - plan.d0[a]


def _slow_oncoming(plan: VariationPlan, a: int, partner: int, gap: float, needed: float) -> None:
    """Too close to swerve in time (`needed` [s]): the oncoming partner comes a little slower (within its
    range)."""
    closing = gap / needed
    if closing < plan.speeds[a] + plan.speeds[partner]:
        plan.scale[partner] = max(timing.SPEED_SCALE[0], (closing - plan.speeds[a]) / plan.speeds[partner])
        plan.speeds[partner] *= plan.scale[partner]


def _place_alongside(plan: VariationPlan, a: int, partner: int, gap: float, dist: float) -> bool:
    """A same-direction sideswipe: side by side when it reaches the partner's lane, so it starts where it
    will be alongside then; False when its route has no room."""
    rate = timing.lateral_rate(plan.ctx.columns[a].behavior)
    t_trig = float(plan.draws.trigger[a])
    touch = t_trig + max(abs(dist) - 0.5 * (plan.width[a] + plan.width[partner]), 0.0) / rate
    want_gap = (plan.speeds[a] - plan.speeds[partner]) * touch + (plan.lead_time(a) - 1.4) * 1.5
    placed = plan.shift_start(a, gap - want_gap)
    if placed is None:
        return False
    plan.s0[a] = placed
    plan.moved[a] = True
    plan.trigger[a] = t_trig
    return True


def _plan_skid(plan: VariationPlan, a: int, partner: int, contact: str | None, gap: float, lateral: float,
               opposite: bool) -> bool:
    """A loss of control, or a lateral manoeuvre ending in an angle contact (a sudden veer), planned as a
    skid (skid.plan) into the partner; False when none fits."""
    if not skids_toward(plan.ctx, a, partner):
        return False
    rotation = plan.param(a, ("SKID_ROTATION",), plan.draws.rotation[a])  # sampled in a search, else drawn
    wanted = skid_plan.Wanted(contact, plan.contact_area(a, partner), plan.contact_area(partner, a),
                              skidder_first=a < partner)
    speed, across = float(plan.speeds[a]), lateral - plan.d0[a]

    def planned(bend: float) -> skid_plan.Skid | None:
        # on a bend the partner's lane, `across` from mine, is as much longer or shorter than my path
        along = 1.0 - bend * across
        # the candidate skids veer left, mirrored toward a partner on the right: so is the bend they are read on
        side = 1.0 if across >= 0 else -1.0
        return skid_plan.plan(skid_plan.along_road(plan.ctx.skid_paths.get(speed), side * bend), speed, gap,
                              plan.speeds[partner] / along, opposite, across,
                              skid_plan.Body(float(plan.length[a]), float(plan.width[a])),
                              skid_plan.Body(float(plan.length[partner]), float(plan.width[partner])),
                              skid_plan.rotation_for(contact, opposite, rotation), wanted,
                              plan.ctx.skid_paths.dt, _centre_line(plan, a) if opposite else None)

    # the skid is planned on the bend of the stretch it covers: that of the road within its horizon first,
    # then that of the planned skid's own stretch, from the loss of control to the contact
    s0 = float(plan.s0[a])
    bend = _path_bend(plan, a, s0, s0 + speed * skid_plan.HORIZON)
    skid = planned(bend)
    if skid is not None and bend != 0.0:
        start = s0 + speed * skid.trigger
        again = planned(_path_bend(plan, a, start, start + speed * skid.t_meet))
        skid = again if again is not None else skid
    if skid is not None and skid.partner_shift:
        placed = plan.shift_start(partner, skid.partner_shift)
        if placed is None:
            skid = None
        else:
            plan.s0[partner] = placed
            plan.moved[partner] = True
    if skid is None:
        return False
    plan.skids[a] = (skid.spin_rate, skid.drift, skid.hold)
    plan.trigger[a] = skid.trigger
    return True


def _path_bend(plan: VariationPlan, a: int, s_from: float, s_to: float) -> float:
    """[1/m] the mean curvature (left positive) of actor a's path, at its offset from its route, from station
    s_from to s_to of the route; 0.0 on a straight (stations.route_bend)."""
    bend = route_bend(plan.ctx.arrays, int(plan.route[a]), s_from, s_to)
    if bend == 0.0:
        return 0.0
    return bend / (1.0 - bend * float(plan.d0[a]))  # a path offset to the inside of the bend turns tighter


def _centre_line(plan: VariationPlan, a: int) -> float:
    """[m] the road's centre line from actor a's start, left positive (NaN on a one-way road)."""
    arrays = plan.ctx.arrays
    return float(arrays.sample(arrays.centerline_offset, np.array(plan.route[a]), np.array(plan.s0[a]))) \
        - float(plan.d0[a])


def enter_wrong_way(plan: VariationPlan, a: int) -> None:
    """A vehicle going straight that meets its written head-on partner coming the other way in another
    lane, a partner that keeps its lane, drives against traffic in that lane (a wrong-way entry, by a
    ramp or a crossover before the scene): it starts at the partner's offset from its route and keeps it."""
    ctx, col = plan.ctx, plan.ctx.columns[a]
    for b, other in enumerate(ctx.columns):
        if b == a or ctx.classes.get(frozenset((col.role, other.role))) != "head_on" \
                or other.behavior in LATERAL_BEHAVIORS:
            continue
        partner = plan.scene.actors[b]
        if math.cos(partner.yaw - plan.scene.actors[a].yaw) > -0.3:
            continue
        gap, lateral = relative_to_route(ctx.arrays, plan.route[a], plan.s0[a], partner.x, partner.y)
        if gap <= 0 or abs(lateral - plan.d0[a]) < plan.lane_width / 2:
            continue
        shift = lateral - plan.d0[a]
        plan.d0[a] = lateral
        plan.drifted[a] = shift
        plan.lateral_target[a] = lateral
        return


def skids_toward(ctx: PlanContext, a: int, partner: int) -> bool:
    """Whether actor a's lateral manoeuvre toward `partner` is planned as a skid: a loss of control, or a
    sudden veer (a lateral manoeuvre ending in an angle contact) toward a partner not losing control."""
    col, p_col = ctx.columns[a], ctx.columns[partner]
    if col.is_ads or col.behavior not in LATERAL_BEHAVIORS:
        return False
    contact = ctx.classes.get(frozenset((col.role, p_col.role)))
    return col.behavior == "lose_control" or (contact == "angle" and col.behavior in VEER_BEHAVIORS
                                              and p_col.behavior != "lose_control")


def _partner(a: int, anchor: int, columns: list[ActorColumn], scene: SampledScene) -> int | None:
    """The actor whose path a lateral manoeuvre of actor a is aimed at."""
    if a != anchor:
        return anchor
    me = scene.actors[a]
    behavior = columns[a].behavior
    best, best_dist = None, math.inf
    for b, other in enumerate(scene.actors):
        if b == a:
            continue
        opposite = math.cos(other.yaw - me.yaw) < -0.3
        if behavior in (*OPPOSING_PASSES, "lose_control") and not opposite:
            continue
        dist = math.hypot(other.x - me.x, other.y - me.y)
        if dist < best_dist:
            best, best_dist = b, dist
    if best is None and len(scene.actors) > 1:
        best = next(b for b in range(len(scene.actors)) if b != a)
    return best
