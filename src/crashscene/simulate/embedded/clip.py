"""A pull-out around the vehicle ahead that clips it, timed on the puller's path (`swerve`) so that where they
first touch the contact has the written class (`skid.contact_choices`); in reproduce mode, when the striker's
slide after the clip (`cascade.clip_slides`) is written to meet a third actor, the trigger and the partner's
speed that make it so, and the third actor placed to meet it (`meetings`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from crashscene.simulate.embedded import cascade, clipahead, lockstep, swerve, timing
from crashscene.simulate.embedded import skid as skid_plan
from crashscene.simulate.embedded.meetings import later_terms, matches, place_third, pushed_meetings
from crashscene.simulate.embedded.stations import bent_frames, relative_to_route

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

CLIP_CLOSING = 3.0  # [m/s] a vehicle pulling out around the one ahead and clipping it comes up at least this fast
CLIP_SPEEDS = 5  # [-] partner speeds (down to the slowest of its range) a clip followed by a later contact tries
CLIP_PARTS = 8  # [-] a clip's partner may start within a step's closing further ahead, in this many parts
CLIP_STARTS = 8  # [-] pull-out starts (trigger steps) with the written clip a clip followed by a later contact tries


@dataclass(frozen=True)
class ClipTiming:
    """A pull-out clipping the vehicle ahead: its trigger [s] and simulator step [s], when after it they touch
    (`t_meet` [s]), its path (x, y, yaw every step after it, turning left; mirrored when `sign` is -1), the
    partner's centre ahead at the step [m] and its lateral offset from the striker's route [m]."""

    trigger: float
    t_step: float
    t_meet: float
    rows: tuple[np.ndarray, np.ndarray, np.ndarray]
    sign: float
    ahead: float
    lateral: float


def clip(plan: VariationPlan, a: int, partner: int, gap: float, contact: str, rate: float) -> bool:
    """Pulling out around the vehicle ahead and clipping it (a written rear-end or sideswipe with it): the
    manoeuvre is only partly done when it reaches the partner's rear, timed on its path (swerve.path) so that
    where they first touch the contact has the written class (skid.first_contact); when no start does,
    across by a drawn part of the overlap (a rear-end: still well behind it; a sideswipe: nearly clear).
    False when it does not close in."""
    reach = gap - (plan.length[a] + plan.length[partner]) / 2
    p_col = plan.ctx.columns[partner]
    if reach <= 0 or p_col.is_ads:
        return False
    if plan.speeds[a] - plan.speeds[partner] < CLIP_CLOSING and p_col.behavior == "go_forward":
        # it came up on a slower vehicle ahead: the partner drives slower (within its range)
        plan.scale[partner] = max(timing.SPEED_SCALE[0], (plan.speeds[a] - CLIP_CLOSING) / plan.speeds[partner])
        plan.speeds[partner] = plan.planned[partner] * plan.scale[partner]
    closing = plan.speeds[a] - plan.speeds[partner]
    if closing < 0.5:
        return False
    if plan.ctx.reproduce and _clip_then_meet(plan, a, partner, gap, contact, rate):
        return True
    timed = _clip_on_path(plan, a, partner, contact, rate, reach / closing)
    if timed is not None:
        plan.trigger[a] = timed.trigger
        return True
    half = (plan.width[a] + plan.width[partner]) / 2
    u = (plan.lead_time(a) - 0.8) / 1.2  # [0, 1)
    across = half * (0.15 + 0.35 * u) if contact == "rear_end" else half - 0.2 - 0.4 * u
    plan.trigger[a] = max(0.0, reach / closing - across / rate)
    return True


def pull_out_path(plan: VariationPlan, a: int, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Actor a's path steering to its lateral target (swerve.path), with other variations' (lockstep.run)."""
    limits = plan.ctx.columns[a].limits
    offset = float(plan.lateral_target[a] - plan.d0[a])
    return lockstep.together(swerve.paths, [(float(plan.speeds[a]), abs(offset), rate,
                                             float(plan.length[a]) * limits.wheelbase_ratio, limits.steer_rate,
                                             limits.steer_max, plan.ctx.skid_paths.dt)])[0]


def _clip_on_path(plan: VariationPlan, a: int, partner: int, contact: str, rate: float, t_reach: float
                  ) -> ClipTiming | None:
    """The pull-out of actor a whose path (`pull_out_path`) first touches the partner ahead (both at their
    planned speeds) with the written class, before a reaches it straight on (`t_reach` [s]): its trigger [s]
    and where they touch (`ClipTiming`); None if none."""
    found, path, relative = _clip_searches(plan, a, partner, contact, rate, [float(plan.speeds[partner])],
                                           [t_reach])
    return _clip_timing(plan, a, partner, found[0][0] if found[0] else None, path, relative)


def _clip_searches(plan: VariationPlan, a: int, partner: int, contact: str, rate: float, partner_speeds: list[float],
                   t_reaches: list[float], count: int = 1
                   ) -> tuple[list, tuple[np.ndarray, np.ndarray, np.ndarray], tuple[float, float]]:
    """The first contacts (skid.contact_choices: up to `count` starts, the best first) of actor a's pull-out
    with the partner ahead at each of `partner_speeds` [m/s], each before a reaches it straight on (`t_reaches`
    [s]), searched at once; with a's path and the partner's place (gap, lateral [m]) relative to a's start."""
    other = plan.scene.actors[partner]
    gap, lateral = relative_to_route(plan.ctx.arrays, plan.route[a], plan.s0[a], other.x, other.y, exact=True)
    offset = float(plan.lateral_target[a] - plan.d0[a])
    dt = plan.ctx.skid_paths.dt
    path = pull_out_path(plan, a, rate)
    wanted = skid_plan.Wanted(contact, plan.contact_area(a, partner), plan.contact_area(partner, a),
                              skidder_first=a < partner)
    sign = 1.0 if offset >= 0 else -1.0
    found = skid_plan.contact_choices(path, sign, float(plan.speeds[a]), gap, partner_speeds, False,
                                      lateral - float(plan.d0[a]),
                                      skid_plan.Body(float(plan.length[a]), float(plan.width[a])),
                                      skid_plan.Body(float(plan.length[partner]), float(plan.width[partner])),
                                      skid_plan.CLASS_HEADING[contact], wanted, dt,
                                      latests=[t_reach - dt for t_reach in t_reaches], place=False,
                                      fine=CLIP_PARTS, count=count)
    return found, path, (gap, lateral)


def _clip_timing(plan: VariationPlan, a: int, partner: int, found: tuple[int, float, float, float] | None,
                 path: tuple[np.ndarray, np.ndarray, np.ndarray], relative: tuple[float, float]
                 ) -> ClipTiming | None:
    """The `ClipTiming` of a first contact `found` by `_clip_searches` at the partner's present speed (its
    start moved as the contact needs); None if none or the partner cannot start there."""
    if found is None:
        return None
    gap, lateral = relative
    if found[3]:
        placed = plan.shift_start(partner, found[3])
        if placed is None:
            return None
        plan.s0[partner] = placed
        plan.moved[partner] = True
    dt = plan.ctx.skid_paths.dt
    offset = float(plan.lateral_target[a] - plan.d0[a])
    sign = 1.0 if offset >= 0 else -1.0
    t_step = found[1] + dt / 2 if found[1] > 0 else 0.0  # the simulator step the pull-out starts on
    ahead = gap + found[3] - (plan.speeds[a] - plan.speeds[partner]) * t_step
    return ClipTiming(found[1], t_step, found[2], tuple(q[0] for q in path), sign, float(ahead), float(lateral))


def _clip_then_meet(plan: VariationPlan, a: int, partner: int, gap: float, contact: str, rate: float) -> bool:
    """A clip followed by a written contact of the striker with a third actor that drives freely straight on
    (the striker's own motion after the clip carries it there): the partner comes as much slower (within its
    range), and the pull-out starts on the one of its trigger steps whose first contact is the written clip
    (skid.contact_choices: up to CLIP_STARTS of them at each partner speed), that makes the striker's slide
    after the clip (cascade.clip_slides, the simulator's impact, upset and tyre model) meet the third actor with
    the written class, and the third actor is placed to meet it there (`meetings.place_third`); False when the
    sequence is another one or no such meeting is found."""
    found = _after_clip(plan, a, partner)
    if found is None:
        return False
    third, later = found
    ctx, cols = plan.ctx, plan.ctx.columns
    arrays, dt = ctx.arrays, ctx.skid_paths.dt
    lo = timing.SPEED_SCALE[0]
    best, best_score = None, (-1, -math.inf)
    before = plan.snapshot()
    tried = []  # (scale, timing, the partner's shifted start) of each partner speed with a clip
    scales, t_reaches = [], []  # the partner speeds that close in, and when actor a reaches the partner
    for scale in np.linspace(float(plan.scale[partner]), lo, CLIP_SPEEDS):
        closing = plan.speeds[a] - plan.planned[partner] * scale
        reach = gap - (plan.length[a] + plan.length[partner]) / 2
        if closing < 0.5 or reach <= 0:
            continue
        scales.append(scale)
        t_reaches.append(reach / closing)
    # every partner speed's first contact at once (actor a's path and the partner's place are the same)
    found, path, relative = (_clip_searches(plan, a, partner, contact, rate,
                                            [float(plan.planned[partner] * scale) for scale in scales],
                                            t_reaches, CLIP_STARTS) if scales else ([], None, None))
    for scale, choices in zip(scales, found):
        for one in choices:
            plan.scale[partner], plan.speeds[partner] = scale, plan.planned[partner] * scale
            timed = _clip_timing(plan, a, partner, one, path, relative)
            shifted = (plan.s0[partner], plan.moved[partner])
            plan.restore(before)
            if timed is not None:
                tried.append((scale, timed, shifted))
    if clipahead.ahead_in_lane(plan, partner, third):  # the clipped car is in the way: stepped with it
        return clipahead.plan_ahead(plan, a, partner, third, later[0], tried)
    me = (float(plan.length[a]), float(plan.width[a]), cols[a].limits.mass, cols[a].limits.wheelbase_ratio)
    them = (float(plan.length[partner]), float(plan.width[partner]), cols[partner].limits.mass,
            cols[partner].limits.wheelbase_ratio)
    # every partner speed's slide at once, with every other variation's (lockstep.run)
    slides = lockstep.together(cascade.clip_slides, [
        cascade.Clip(timed.rows, timed.sign, float(plan.speeds[a]), float(plan.d0[a]), timed.ahead,
                     float(plan.planned[partner] * scale), timed.lateral, timed.t_meet, dt, me, them, ctx.friction)
        for scale, timed, _ in tried])
    slid = [(scale, timed, shifted, slide) for (scale, timed, shifted), slide in zip(tried, slides)
            if slide is not None]
    # where each slide starts: the striker's route at the clip's step (on a bend, turned to where they touch)
    px, py, pyaw = bent_frames(arrays, plan.route[a],
                               np.array([plan.s0[a] + plan.speeds[a] * timed.t_step for _, timed, _, _ in slid]),
                               np.array([float(slide[1][0][0]) for *_, slide in slid]))
    meetings = pushed_meetings(plan, a, third, [slide[1] for *_, slide in slid],
                               [(float(x), float(y), float(yaw)) for x, y, yaw in zip(px, py, pyaw)], later)
    for (scale, timed, shifted, (t_touch, _)), meeting in zip(slid, meetings):
        if meeting is None:
            continue
        score = (matches(meeting, later), meeting[5])
        if score > best_score:
            best, best_score = (scale, timed, shifted, t_touch, meeting), score
    if best is None or best[4][2] != later[0]:
        return False
    scale, timed, shifted, t_touch, meeting = best
    if not place_third(plan, third, meeting, later, timed.t_step + t_touch + (meeting[0] + 1) * cascade.DT,
                       passing=(a,)):
        return False
    plan.scale[partner], plan.speeds[partner] = scale, plan.planned[partner] * scale
    plan.s0[partner], plan.moved[partner] = shifted
    plan.trigger[a] = timed.trigger
    return True


def _after_clip(plan: VariationPlan, a: int, partner: int) -> tuple[int, tuple[str, str, str]] | None:
    """(third actor, (class, actor a's area, the third's)) of actor a's next written contact after its first one
    with `partner`, when it is with a third actor that drives freely straight on (not the ADS); else None."""
    cols, roles = plan.ctx.columns, [c.role for c in plan.ctx.columns]
    mine = [c for c in plan.ctx.contacts if roles[a] in c[:2] and all(r in roles for r in c[:2])]
    if cols[a].is_ads or len(mine) < 2 or roles[partner] not in mine[0][:2]:
        return None
    striking, struck, *_ = mine[1]
    third = roles.index(striking if struck == roles[a] else struck)
    if third == partner or cols[third].is_ads or cols[third].behavior != "go_forward":
        return None
    return third, later_terms(mine[1], roles[a])
