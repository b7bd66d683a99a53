"""Junction conflicts in a timing plan: each actor arrives at its conflict point with the anchor at the
anchor's arrival plus its offset (a written contact: when the striker's front meets the struck one's side,
`struck_offset`; where the routes' meeting point cannot give the written class, where the paths they drive do,
`touch.class_meeting`), by its speed scale and hold, a start further along or back on its approach, or else the
anchor delayed.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from crashscene.dsl.tokens import STANDING
from crashscene.geometry import clip_scalar, wrap_angle
from crashscene.monitor.rules import Disposition
from crashscene.simulate.embedded import slap, timing, touch
from crashscene.simulate.embedded.control import entry_before
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan
    from crashscene.simulate.embedded.setup import ActorColumn

SYNC_SLACK = 0.8  # [s] an actor moved back to meet later is placed this much early (sync.Meeting slows it)
PULL_OUT_WAIT = 1.0  # [s] an actor pulling out to meet a written contact on its turn waits this long for its partner
ADVANCE_MARGIN = 3.0  # [m] an actor advanced by its timing plan stays this far before its junction entry
CLASS_RELATIVE = {"angle": math.pi / 2}  # [rad] relative heading at contact the class is judged by (rules.md)


def plan_junction(plan: VariationPlan, a: int, offset: float) -> None:
    """Actor a's arrival at its conflict point with the anchor, at the anchor's arrival plus `offset` [s]
    (a written contact: when the striker's front meets the struck one's side): its speed scale and hold,
    a start further along or back on its approach, or else the anchor delayed."""
    ctx, col = plan.ctx, plan.ctx.columns[a]
    arrays, anchor = ctx.arrays, ctx.anchor
    r, ra = plan.route[a], plan.route[anchor]
    cs_a = arrays.conflict_s[r, ra]
    cs_e = arrays.conflict_s[ra, r]
    if np.isnan(cs_a) or cs_a <= plan.s0[a] or cs_e <= plan.s0[anchor]:
        return
    moved = _class_meeting(plan, a, cs_a, cs_e)
    if moved is not None:
        cs_a, cs_e = moved
    anchor_arrival = _anchor_arrival(plan, cs_e)
    target = anchor_arrival + _meeting_offset(plan, a, cs_a, cs_e, offset, None if moved is None else 0.0)
    # the first written contact's pair meets closed loop (sync.Meeting): place the free one a little early;
    # one that waits at its line to pull out (`touch_at`) is met by the other coming a little late instead
    slack = SYNC_SLACK if ctx.reproduce and ctx.first_pair == frozenset((col.role,
                                                                         ctx.columns[anchor].role)) else 0.0
    if plan.pull_out is not None and {a, anchor} == {plan.pull_out.actor, plan.pull_out.partner}:
        slack = 0.0
        target += PULL_OUT_WAIT if plan.pull_out.actor == anchor else -PULL_OUT_WAIT
    sc, hd, late = _fit_arrival(plan, a, cs_a, target, slack)
    if late > 0.1 and plan.stop_dist(a) is None:
        late = _advance_start(plan, a, cs_a, sc, target, late)
    if late > 0.1:
        _delay_anchor(plan, cs_e, late, slack)
    plan.scale[a], plan.hold[a] = sc, hd
    plan.conflict_time = min(plan.conflict_time, plan.arrival_anchor)


def _anchor_arrival(plan: VariationPlan, cs_e: float) -> float:
    """[s] the anchor's nominal arrival at its conflict point cs_e [m] (the first one asked stays)."""
    if plan.arrival_anchor is None:
        ctx = plan.ctx
        anchor, anchor_col = ctx.anchor, ctx.columns[ctx.anchor]
        ra, va, anchor_stop = plan.route[anchor], plan.anchor_speed, plan.anchor_stop
        if anchor_stop is None:
            lat_e = 2.0 if anchor_col.is_ads else 2.5
            plan.arrival_anchor = ctx.arrays.travel_time(ra, plan.s0[anchor], cs_e, va, lat_e, v0=va)
        else:
            v_eff = _effective_speed(ctx.arrays, ra, plan.s0[anchor], cs_e, va, anchor_col)
            plan.arrival_anchor = timing.arrival_time(cs_e - plan.s0[anchor], v_eff, anchor_col.limits.accel_max,
                                                      stop_dist=anchor_stop)
    return plan.arrival_anchor


def _class_meeting(plan: VariationPlan, a: int, cs_a: float, cs_e: float) -> tuple[float, float] | None:
    """Reproduce mode, a written contact of actor a with the anchor whose class the routes' meeting point
    cannot give (`touch.needs_moving`: a turn into a lane meets almost aligned): (cs_a, cs_e) [m] moved to
    where the class happens on the paths they drive (`touch.class_meeting`), in `_meeting_offset`'s terms (the
    striker's front at the struck centre, no struck offset); None keeps the routes' meeting point."""
    ctx = plan.ctx
    anchor = ctx.anchor
    pair = frozenset((ctx.columns[a].role, ctx.columns[anchor].role))
    striking, klass = ctx.strikers.get(pair), ctx.classes.get(pair)
    if not ctx.reproduce or striking is None:
        return None
    s_idx = a if striking == ctx.columns[a].role else anchor
    t_idx = anchor if s_idx == a else a
    cs = {a: cs_a, anchor: cs_e}
    if not touch.needs_moving(ctx.arrays, plan.route[s_idx], cs[s_idx], plan.route[t_idx], cs[t_idx], klass):
        return None

    lines = {i: (None if (stop := plan.stop_dist(i)) is None else float(plan.s0[i] + stop)) for i in cs}

    def mover(i: int) -> touch.Mover:
        rest = None if lines[i] is None else lines[i] - float(plan.length[i]) / 2  # its front at its line
        return touch.Mover(int(plan.route[i]), float(cs[i]), float(plan.speeds[i]), rest, float(plan.length[i]),
                           float(plan.width[i]), ctx.columns[i].limits,
                           Disposition.NO_YIELD in ctx.columns[i].traits)

    met = touch.class_meeting(ctx.arrays, mover(s_idx), mover(t_idx),
                              (klass, plan.contact_area(s_idx, t_idx), plan.contact_area(t_idx, s_idx)))
    if met is None:
        return None
    reach = float(plan.length[s_idx] / 2 + plan.width[t_idx] / 2)
    at = {s_idx: met.striker_s + reach, t_idx: met.struck_s}
    if pair == ctx.first_pair:
        plan.touch_at = (at[s_idx], at[t_idx])
    waiting = [i for i in cs if lines[i] is not None]
    if pair == ctx.first_pair and len(waiting) == 1 and not ctx.columns[waiting[0]].is_ads:
        w = waiting[0]
        partner = t_idx if w == s_idx else s_idx
        front = (met.striker_s if partner == s_idx else met.struck_s) + float(plan.length[partner]) / 2
        # released at the first step its partner is that near: on average half a step late
        tta = (met.struck_t if w == t_idx else met.striker_t) + ctx.skid_paths.dt / 2
        plan.pull_out = touch.Waiting(w, partner, lines[w], front, tta, mover(w).rest,
                                      met.struck_v if w == t_idx else met.striker_v)
    return at[a], at[anchor]


def _meeting_offset(plan: VariationPlan, a: int, cs_a: float, cs_e: float, offset: float,
                    u: float | None = None) -> float:
    """[s] actor a's arrival after the anchor's: the turner first, and a written contact's striker's
    front at the struck one's side (`u` [m] past the striker's path, by default `struck_offset`)."""
    ctx, col = plan.ctx, plan.ctx.columns[a]
    arrays, anchor = ctx.arrays, ctx.anchor
    anchor_col = ctx.columns[anchor]
    r, ra = plan.route[a], plan.route[anchor]
    # a turning vehicle is struck on its side in its turn: it reaches the conflict point first
    turn_a = _turns_at(arrays, r, cs_a)
    turn_e = _turns_at(arrays, ra, cs_e)
    if turn_a and not turn_e:
        offset -= timing.TURNER_LEAD
    elif turn_e and not turn_a:
        offset += timing.TURNER_LEAD
    striking = ctx.strikers.get(frozenset((col.role, anchor_col.role)))
    if striking is None:
        return offset
    # the written contact says who strikes: the striker's front meets the middle of the struck one's side
    s_idx = a if striking == col.role else anchor
    t_idx = anchor if s_idx == a else a
    r_t, cs_t = (r, cs_a) if t_idx == a else (ra, cs_e)
    s_t0 = plan.s0[t_idx]
    v_struck = _effective_speed(arrays, r_t, max(cs_t - 10.0, s_t0), cs_t, plan.speeds[t_idx],
                                ctx.columns[t_idx])
    r_s, cs_s = (ra, cs_e) if t_idx == a else (r, cs_a)
    if u is None and slap.slaps_after(ctx.contacts, ctx.columns[s_idx].role, ctx.columns[t_idx].role):
        u = plan.slap_offset = slap.slap_offset(
            ctx.arrays, _body(plan, s_idx, cs_s, float(plan.speeds[s_idx])),
            _body(plan, t_idx, cs_t, float(v_struck)), ctx.friction, ctx.skid_paths.dt)  # a side slap follows
    if u is None:
        u = struck_offset(arrays, r_t, cs_t, r_s, cs_s, float(plan.length[t_idx]),
                          ctx.classes.get(frozenset((col.role, anchor_col.role))))
    side_hit = (plan.length[s_idx] / 2 + plan.width[t_idx] / 2) / max(plan.speeds[s_idx], 1.0) \
        + u / max(v_struck, 1.0)
    jitter = offset - timing.ARRIVAL_OFFSET_MEAN * (timing.REPRODUCE_OFFSET_SCALE if ctx.reproduce else 1.0)
    return (side_hit if s_idx == a else -side_hit) + jitter


def _body(plan: VariationPlan, i: int, meet: float, speed: float) -> slap.Body:
    """Actor i driving through station `meet` [m] of its route at `speed` [m/s] (slap)."""
    limits = plan.ctx.columns[i].limits
    return slap.Body(touch.Mover(int(plan.route[i]), meet, speed, None, float(plan.length[i]),
                                 float(plan.width[i]), limits), limits.mass)


def _fit_arrival(plan: VariationPlan, a: int, cs_a: float, target: float, slack: float) -> tuple[float, float, float]:
    """(speed scale, hold [s], lateness [s]) that bring actor a to its conflict point cs_a [m] at `target`
    [s]: stopping at its line first and waiting there; or a cruise scale, a start further back, the
    slowest scale and a hold at its start."""
    ctx, col = plan.ctx, plan.ctx.columns[a]
    arrays, r = ctx.arrays, plan.route[a]
    s_a, va_ = plan.s0[a], plan.speeds[a]
    stop = plan.stop_dist(a)
    if stop is not None:
        v_eff = _effective_speed(arrays, r, s_a, cs_a, va_, col)
        sc, hd = timing.junction_plan(target, cs_a - s_a, v_eff, col.limits.accel_max, stop_dist=stop)
        # stopping at its line first, it can come late even when it does not wait at all (hd == 0)
        t_stop_go = timing.arrival_time(cs_a - s_a, v_eff, col.limits.accel_max, stop_dist=stop)
        return sc, hd, (max(0.0, t_stop_go - target) if hd == 0.0 else 0.0)
    t_at = _travel_time(plan, a, cs_a)
    lo, hi = timing.SPEED_SCALE
    if t_at(hi) > target:
        return hi, 0.0, t_at(hi) - target
    if t_at(lo) < target and (back := plan.start_back(a, max(target - t_at(1.0) - slack, 0.0) * va_)) is not None:
        # far too early: it was further back along its approach, driving at its own speed
        plan.s0[a] = back
        plan.moved[a] = True
        return 1.0, 0.0, 0.0
    if t_at(lo) < target:
        lat_a = 2.0 if col.is_ads else 2.5
        return lo, max(0.0, target - arrays.travel_time(r, s_a, cs_a, va_ * lo, lat_a, v0=0.0)), 0.0
    # travel time is nearly proportional to 1/speed: two secant corrections suffice
    sc = clip_scalar(t_at(1.0) / target, lo, hi)
    for _ in range(2):
        sc = clip_scalar(sc * t_at(sc) / target, lo, hi)
    return sc, 0.0, 0.0


def _travel_time(plan: VariationPlan, a: int, cs: float):
    """t_at(k, s_start, v_start): actor a's travel time [s] to station cs [m] at k times its planned speed."""
    arrays, r, va_ = plan.ctx.arrays, plan.route[a], plan.speeds[a]
    lat_a = 2.0 if plan.ctx.columns[a].is_ads else 2.5
    s_first = plan.s0[a]

    def t_at(k: float, s_start: float = s_first, v_start: float | None = None) -> float:
        v_init = va_ * min(k, 1.0) if v_start is None else v_start
        return arrays.travel_time(r, s_start, cs, va_ * k, lat_a, v0=v_init)

    return t_at


def _advance_start(plan: VariationPlan, a: int, cs_a: float, sc: float, target: float, late: float) -> float:
    """Even at its fastest actor a would come `late` [s]: it has already been driving for a while, so it
    starts further along its own approach (never closer than ADVANCE_MARGIN to the junction); returns what
    lateness is left."""
    arrays, r = plan.ctx.arrays, plan.route[a]
    t_at = _travel_time(plan, a, cs_a)
    va_ = plan.speeds[a]
    entries = arrays.entry_s[r]
    first_entry = entries[np.isfinite(entries) & (entries > plan.s0[a])]
    room = (first_entry[0] - plan.s0[a] - ADVANCE_MARGIN) if len(first_entry) else 0.0
    if room <= 0:
        return late
    best = plan.s0[a]
    for cand in np.linspace(plan.s0[a], plan.s0[a] + room, 12)[1:]:
        v_start = min(va_ * sc, max(float(arrays.curve_speed(np.array(r), np.array(cand),
                                                             np.array(60.0), 2.5, 2.0)), 3.0))
        best = cand
        late = t_at(sc, cand, v_start) - target
        if late <= 0.05:
            break
    plan.s0[a] = best
    plan.moved[a] = True
    return late


def _delay_anchor(plan: VariationPlan, cs_e: float, late: float, slack: float) -> None:
    """Reproduce mode: the scripted anchor comes `late` [s] later instead (slower, else it waits); also for
    an actor that must first stop at its line, which no advance along its approach fixes."""
    ctx = plan.ctx
    anchor = ctx.anchor
    anchor_col = ctx.columns[anchor]
    if anchor_col.is_ads or anchor_col.behavior in STANDING or plan.anchor_stop is not None \
            or plan.hold[anchor] != 0.0:
        return
    arrays, ra, va = ctx.arrays, plan.route[anchor], plan.anchor_speed
    lat_e = 2.0 if anchor_col.is_ads else 2.5
    t_new = plan.arrival_anchor + late
    lo, hi = timing.SPEED_SCALE[0], 1.0
    # ...placed a little early rather than late: on the way it can slow down to meet (sync), rarely speed up
    back = plan.start_back(anchor, max(late - slack, 0.0) * va)
    if back is not None:
        # it started that much further back along its approach, at its own speed
        plan.s0[anchor] = back
        plan.moved[anchor] = True
    elif arrays.travel_time(ra, plan.s0[anchor], cs_e, va * lo, lat_e, v0=va * lo) < t_new:
        plan.scale[anchor] = lo
        t_rest = arrays.travel_time(ra, plan.s0[anchor], cs_e, va * lo, lat_e, v0=0.0)
        plan.hold[anchor] = max(0.0, t_new - t_rest)
    else:
        for _ in range(8):
            mid = (lo + hi) / 2
            t_mid = arrays.travel_time(ra, plan.s0[anchor], cs_e, va * mid, lat_e, v0=va * mid)
            lo, hi = (lo, mid) if t_mid < t_new else (mid, hi)
        plan.scale[anchor] = (lo + hi) / 2
    plan.arrival_anchor = t_new


def struck_offset(arrays: RouteArrays, r_t: int, cs_t: float, r_s: int, cs_s: float, length_t: float,
                  contact_class: str | None) -> float:
    """How far [m] past the striker's path the struck actor's centre is when the striker's front meets its side:
    where along its body the heading relative to the striker is closest to the class's (an angle contact: the
    part of a turn that is most nearly square to the striker); a quarter length behind the middle otherwise."""
    default = length_t / 4
    target = CLASS_RELATIVE.get(contact_class or "")
    if target is None:
        return default
    reach = max(length_t / 2 - 0.6, 0.0)
    u = np.linspace(-reach, reach, 9)
    n = arrays.yaw.shape[1] - 1
    k = np.clip(((cs_t + u) / ROUTE_DS).astype(int), 0, n)
    yaw_s = arrays.yaw[r_s, min(int(cs_s / ROUTE_DS), n)]
    rel = np.abs(wrap_angle(arrays.yaw[r_t, k] - yaw_s))
    miss = np.abs(rel - target) + 0.02 * np.abs(u - default)
    return float(u[int(np.argmin(miss))])


def _effective_speed(arrays: RouteArrays, r: int, s0: float, s1: float, speed: float, col: ActorColumn) -> float:
    """Average speed [m/s] from s0 to s1, slowing in curves as the driver will (not when careless)."""
    if s1 <= s0 or Disposition.CARELESS in col.traits:
        return speed
    lat = 2.0 if col.is_ads else 2.5
    return (s1 - s0) / max(arrays.travel_time(r, s0, s1, speed, lat), 1e-3)


def _turns_at(arrays: RouteArrays, r: int, s: float) -> bool:
    """Whether route r turns (left, right, U) at the junction containing station s."""
    j = entry_before(arrays, r, s)
    return j is not None and int(arrays.entry_maneuver[r, j]) in (2, 3, 4)


def stop_dist(arrays: RouteArrays, r: int, s0: float, entry_control: np.ndarray, col: ActorColumn) -> float | None:
    """Distance [m] to the stop line of a stop-controlled first junction the actor will stop at, else None."""
    entries = arrays.entry_s[r]
    idx = np.nonzero(entries > s0)[0]
    if len(idx) == 0 or entry_control[r, idx[0]] != 2 or Disposition.RUNS_STOP in col.traits:
        return None
    return float(entries[idx[0]] - s0 - 1.0)
