"""A chain of rear-ends after a push, planned in reproduce mode: a car struck from behind is pushed into the car
ahead of it in its lane, and that one into the next.

A car an impact upsets (`crashscene.upset`) rolls on out of its driver's control, slowed by its tyres at
ROLL_FRACTION of mu g along its body (`impact.tyre_slide`), so it reaches the car ahead only when that car is
within its roll-out. The impact is the simulator's own (`impact.exchange`): end-on along the lane it gives the
struck car (1 + RESTITUTION) m_striker / (m_striker + m_struck) of the closing speed. `place_chain` finds the
written links (a rear-end whose striker was struck earlier in the sequence, by a car behind it in its lane, and
whose struck car starts ahead of it in the same lane), predicts each push along the lane (the first striker
approaching as its own car following drives it), and places the car ahead so that the pushed car reaches its rear
at a drawn part (`REACH`) of its roll-out relative to it: a queue of cars close together, which the plan only
places (their drivers and speeds are the ones sampled). The next link starts from the closing speed the
prediction gives at that contact.

It covers a car ahead that stands, drives on at its planned speed (`stations.lane_motion`) or, going forward
ahead of a car standing in its lane, waits in the queue (held at its start till the push reaches it); a pushed car
whose driver the predicted impact leaves in control drives on and brakes: no link is planned after it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from crashscene.dsl.tokens import STANDING
from crashscene.monitor.rules import Disposition
from crashscene.simulate.drivers.base import idm_accel
from crashscene.simulate.drivers.behaviors import LATE_REACTION, REACTION, rules_for
from crashscene.simulate.embedded import impact
from crashscene.simulate.embedded.stations import START_MARGIN, lane_motion, same_lane
from crashscene.units import G
from crashscene.upset import CONTROL_DELTA_V

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

REACH = (0.2, 0.45)  # [-] the pushed car meets the car ahead this part of the way through its roll-out relative to
# it (drawn): well inside it, as the striker's speed at the first impact is known only to within its braking
MIN_GAP = 0.5  # [m] the car ahead starts at least this far (bumper to bumper) from any car in its lane
HORIZON = 20.0  # [s] the first impact of a chain is looked for this long after the start
STEP = 0.05  # [s] ...at this step
UPSET_MARGIN = 1.2  # [-] a car pushed on in turn is met while the push still changes its speed by this much more
# than it takes to upset it (crashscene.upset)
QUEUE_WAIT = 2.0  # [s] a car waiting in a queue ahead of a pushed car is held at its start this long after the push
# reaches it
PASSES = 3  # [-] placements, each from the striker's approach to the cars placed in the one before


@dataclass(frozen=True)
class Link:
    """One written push: `pusher` rear-ends `pushed`, which then rear-ends `ahead` (actor indices)."""

    pusher: int
    pushed: int
    ahead: int


def links(plan: VariationPlan) -> list[Link]:
    """The written chain of pushes starting at the sequence's first contact: each a rear-end by the car struck from
    behind in the link before (the first: in the first contact), on the car ahead of it in its lane (same start
    lane, starting ahead of it), that drives freely (not the ADS; it goes forward, stops or stands)."""
    seq, cols = plan.ctx.contacts, plan.ctx.columns
    roles = [c.role for c in cols]
    if not seq or seq[0][2] != "rear_end" or not all(r in roles for r in seq[0][:2]):
        return []
    pusher, pushed = roles.index(seq[0][0]), roles.index(seq[0][1])
    if not same_lane(plan.route, plan.d0, pusher, pushed) or plan.s0[pushed] <= plan.s0[pusher]:
        return []
    out: list[Link] = []
    for striking, struck, klass, *_ in seq[1:]:
        if klass != "rear_end" or striking != roles[pushed] or struck not in roles:
            break
        ahead = roles.index(struck)
        if cols[ahead].is_ads or cols[ahead].behavior not in ("go_forward", *STANDING) \
                or ahead in (pusher, pushed) or any(ahead in (k.pusher, k.pushed) for k in out) \
                or not same_lane(plan.route, plan.d0, pushed, ahead) or plan.s0[ahead] <= plan.s0[pushed]:
            break
        out.append(Link(pusher, pushed, ahead))
        pusher, pushed = pushed, ahead
    return out


def pushed_speed(v_striker: float, v_struck: float, m_striker: float, m_struck: float) -> float:
    """[m/s] the struck car's speed along the lane after an end-on impact (impact.exchange along one axis)."""
    return v_struck + (1.0 + impact.RESTITUTION) * m_striker / (m_striker + m_struck) * (v_striker - v_struck)


def roll_decel(friction: float) -> float:
    """[m/s2] how fast a car an impact upset slows rolling straight on (impact.tyre_slide along its body)."""
    return impact.ROLL_FRACTION * friction * G


def meeting(closing: float, decel: float, part: float) -> tuple[float, float, float]:
    """(time [s], gap [m], closing speed [m/s]) where a car rolling out at `decel` [m/s2], `closing` [m/s] faster
    than the car ahead, reaches it when the gap between them is `part` of its relative roll-out."""
    gap = part * closing ** 2 / (2.0 * decel)
    at = closing * math.sqrt(1.0 - part)
    return (closing - at) / decel, gap, at


def first_impact(plan: VariationPlan, striker: int, struck: int) -> tuple[float, float, float, float] | None:
    """(time [s], the struck car's station [m], the striker's and the struck car's speeds [m/s]) when the striker
    reaches the struck car's rear: the struck car and every other car in the lane as their behaviours have them
    (`stations.lane_motion`), the striker as its driver drives (`approach`); None if not within HORIZON."""
    times = np.arange(0.0, HORIZON, STEP)
    s_a, v_a = approach(plan, striker, times)
    s_b, v_b = motion(plan, struck, times)
    hit = np.nonzero(s_a + (plan.length[striker] + plan.length[struck]) / 2 >= s_b)[0]
    if len(hit) == 0:
        return None
    k = int(hit[0])
    return float(times[k]), float(s_b[k]), float(v_a[k]), float(v_b[k])


def motion(plan: VariationPlan, a: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(station [m], speed [m/s]) of actor a at `times` [s] as its behaviour has it (`stations.lane_motion`);
    one that stops or stands and starts at rest (setup: a sampled speed of 0) stays where it is, one held at its
    start (`VariationPlan.hold`) until then."""
    if plan.speed[a] <= 0.0 and plan.ctx.columns[a].behavior in STANDING:
        return np.full(len(times), float(plan.s0[a])), np.zeros(len(times))
    hold = float(plan.hold[a])
    if hold <= 0.0:
        return lane_motion(plan, a, times)
    s, v = lane_motion(plan, a, np.maximum(times - hold, 0.0))  # (driving off at once after it: an upper bound)
    waiting = times < hold
    return np.where(waiting, float(plan.s0[a]), s), np.where(waiting, 0.0, v)


def approach(plan: VariationPlan, a: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(station [m], speed [m/s]) of actor a at `times` [s] (from 0, every STEP) as its driver drives along its lane:
    car following (`idm_accel`, its rules and limits) behind the nearest car ahead in its lane that it perceives
    (not the ones it strikes in the written sequence: in reproduce mode it never saw them,
    setup.unseen_partners), seen its reaction time late."""
    cols = plan.ctx.columns
    col = cols[a]
    roles = [c.role for c in cols]
    unseen = {roles.index(c[1]) for c in plan.ctx.contacts if c[0] == col.role and c[1] in roles}
    seen = [b for b in range(len(cols)) if same_lane(plan.route, plan.d0, a, b) and b not in unseen
            and plan.s0[b] > plan.s0[a]]
    rules = rules_for(col.dispositions, plan.ctx.friction)
    delay = LATE_REACTION if Disposition.INATTENTIVE in col.traits else REACTION
    lag = int(round(delay / STEP))
    motions = [motion(plan, b, times) for b in seen]
    n = len(times)
    s, v = np.zeros(n), np.zeros(n)
    s[0], v[0] = float(plan.s0[a]), float(plan.speeds[a])
    desired = np.array(max(float(plan.speeds[a]), 0.1))
    for k in range(n - 1):
        j = max(k - lag, 0)  # what it perceives now
        gap, lead = math.inf, math.nan
        for b, (s_b, v_b) in zip(seen, motions):
            g = s_b[j] - s[j] - (plan.length[a] + plan.length[b]) / 2
            if g < gap:
                gap, lead = g, float(v_b[j])
        accel = float(idm_accel(np.array(v[k]), desired, np.array(gap), np.array(lead), col.limits.accel_max,
                                rules.brake_comfort, rules.headway, rules.min_gap))
        accel = min(max(accel, -col.limits.brake_max), col.limits.accel_max)
        v[k + 1] = max(v[k] + accel * STEP, 0.0)
        s[k + 1] = s[k] + (v[k] + v[k + 1]) / 2 * STEP
    return s, v


def place_chain(plan: VariationPlan) -> int:
    """Place the car ahead of each written push (`links`) where the pushed car reaches it (module docstring), in
    PASSES (the striker brakes for the cars it sees ahead, so where they stand changes how hard it strikes).
    Returns how many links it placed; stops at the first it cannot."""
    chain = links(plan)
    placed = 0
    queued: set[int] = set()  # the cars it holds at their start, waiting in the queue
    for _ in range(PASSES if chain else 0):
        placed = _place(plan, chain, queued)
        if not placed:
            break
    return placed


def _place(plan: VariationPlan, chain: list[Link], queued: set[int]) -> int:
    """One pass of `place_chain`; `queued`: the cars it holds at their start (updated)."""
    found = first_impact(plan, chain[0].pusher, chain[0].pushed)
    if found is None:
        return 0
    t, station, v_striker, v_struck = found
    cols, decel = plan.ctx.columns, roll_decel(plan.ctx.friction)
    placed = 0
    for i, link in enumerate(chain):
        m_s, m_p = cols[link.pusher].limits.mass, cols[link.pushed].limits.mass
        u = pushed_speed(v_striker, v_struck, m_s, m_p)
        if u - v_struck < CONTROL_DELTA_V:
            break  # the pushed car's driver keeps control and brakes: no roll-out to plan on
        times = t + np.arange(0.0, HORIZON, STEP)
        held = float(plan.hold[link.ahead])
        if v_struck == 0.0 and cols[link.ahead].behavior == "go_forward" and (held == 0.0 or link.ahead in queued):
            # the car ahead of one standing in its lane waits in the queue: it is held at its start (the queue moves
            # on QUEUE_WAIT after the push has reached it)
            queued.add(link.ahead)
            plan.hold[link.ahead] = float(times[-1])
        s_q, v_q = motion(plan, link.ahead, times)
        part = REACH[0] + (REACH[1] - REACH[0]) * float(plan.draws.cascade[link.ahead])
        v_ahead = float(v_q[0])
        if u - v_ahead <= 0.5:
            plan.hold[link.ahead] = held
            if held == 0.0:
                queued.discard(link.ahead)
            break
        if i + 1 < len(chain):  # the car ahead is pushed on in turn: met early enough that the push upsets it,
            # where that leaves it within REACH
            part = min(part, max(_upsetting_part(u - v_ahead, m_p, cols[link.ahead].limits.mass), REACH[0]))
        tau, gap, closing = meeting(u - v_ahead, decel, part)
        k = min(int(round(tau / STEP)), len(times) - 1)
        travelled = u * tau - decel * tau ** 2 / 2  # [m] the pushed car's roll-out until it meets the car ahead
        rear_then = station + plan.length[link.pushed] / 2 + travelled
        shift = rear_then - (s_q[k] - plan.length[link.ahead] / 2)
        new = _room(plan, link.ahead, float(plan.s0[link.ahead] + shift), (link.pushed,))
        if new is None:
            plan.hold[link.ahead] = held
            if held == 0.0:
                queued.discard(link.ahead)
            break
        plan.s0[link.ahead] = new
        plan.moved[link.ahead] = True
        if link.ahead in queued:
            plan.hold[link.ahead] = float(times[k]) + QUEUE_WAIT
        placed += 1
        # the next push: the car ahead struck at the predicted closing speed, where it is then
        t, station = float(times[k]), float(s_q[k] + shift)
        v_struck = float(v_q[k])
        v_striker = v_struck + closing
    return placed


def _upsetting_part(closing: float, m_pushed: float, m_ahead: float) -> float:
    """[-] the largest part of its relative roll-out (`meeting`) at which a car `closing` [m/s] faster than the car
    ahead still pushes it by UPSET_MARGIN times CONTROL_DELTA_V (`pushed_speed`), 0 when none does."""
    need = UPSET_MARGIN * CONTROL_DELTA_V / ((1.0 + impact.RESTITUTION) * m_pushed / (m_pushed + m_ahead))
    return max(0.0, 1.0 - (need / closing) ** 2)


def _room(plan: VariationPlan, a: int, new: float, behind: tuple[int, ...]) -> float | None:
    """`new` [m] as actor a's start when it keeps MIN_GAP from every other actor starting in its lane and stays on
    its route, else None; the actors in `behind` must stay behind it."""
    route, length = plan.route, plan.length
    if new < START_MARGIN or new > plan.ctx.arrays.length[route[a]] - 100.0:
        return None
    for b in range(len(route)):
        if not same_lane(route, plan.d0, a, b):
            continue
        if abs(plan.s0[b] - new) < (length[a] + length[b]) / 2 + MIN_GAP or (b in behind and plan.s0[b] >= new):
            return None
    return new
