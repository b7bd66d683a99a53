"""A clip whose striker then slides into a car further ahead in the clipped car's lane, planned in reproduce mode
(a car pulls out to pass the one ahead in a queue, clips its rear corner, spins and strikes the next car of the
queue): the clip predicted as the simulator steps the two bodies through it (`rollout`: the exchanges while they
touch, the upsets, the tyre slides), the clipped car's motion included, so that the third car is placed only where
the striker's slide meets it first with the written class, before the clipped car (pushed on by the clip) does.

`clip_pairs` steps each clip's pair from the simulator step before they touch; `place_ahead` finds where along its
lane the third car (driving straight on at its planned speed) must start for that. The third car is only ever
moved along its lane, never held or slowed: a car standing in the queue would be braked for by the clipped car's
driver, who would then not be where the clip was planned.

What the contact model gives here (`benchmarks/bench_clip_reach.py`): a front-to-rear clip takes the normal closing
speed out of the contact point (`impact.exchange`, nearly plastic), so the striker keeps no speed to pass the
clipped car, which the clip pushes on ahead of it (and, on its rear corner, out of its lane in 747 of 1116 clips);
turned 60-120 deg within reach of the lane, the striker's centre is at most 2.1 m past where the clipped car's front
would be (median 4.1 m short of it). None of the 1116 clips of a car at 13-29 m/s by a striker at 17-31 m/s, 3 m/s
or more faster, on a dry road, meets a third car ahead of the clipped one (1-1.4 times its speed, any gap) first at an
angle (0 too on a road of friction 0.5 or 0.3): the plan then places nothing, and the clip is planned alone.
What stops it is the clipped car between them, not the striker's reach: with the third car slower than the clipped
one (0.6-0.9 times its speed; the striker 19.7-24.5 m/s, the clipped car 11.8-20 m/s) the striker meets it first at an
angle in 578 of 1186 clips when the clipped car's motion is left out, in none when it is not.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from crashscene.simulate.embedded import cascade, lockstep, pushchain, rollout
from crashscene.simulate.embedded.skid import Body, monitor_class, overlap_interval
from crashscene.simulate.embedded.stations import relative_to_route, same_lane

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

PLACE_RANGE = 40.0  # [m] how far along its lane the third car may be moved from where it was sampled
PLACE_STEP = 0.25  # [m] the grid of such moves
START_GAP = 0.5  # [m] the third car starts at least this far ahead of the clipped car's front (pushchain.MIN_GAP)
BRAKE_TOLERANCE = 0.5  # [m/s] the clipped car may be this much slower than planned when clipped (its driver's
# following of the cars ahead), else the clip is not where it was planned


@dataclass(frozen=True)
class Ahead:
    """The third car, in a clip's frame (along the striker's route from where its manoeuvre starts, across from its
    centre line [m]): its centre `along` [m] at the simulation's start as sampled, `across` [m], `speed` [m/s] (it
    drives straight on along the road), its body; and the clip's simulator step `t_step` [s] (the frame's origin
    in time: the striker's manoeuvre starts then)."""

    along: float
    across: float
    speed: float
    body: Body
    t_step: float


def clip_pairs(clips: list[cascade.Clip]) -> list[tuple[float, np.ndarray, np.ndarray] | None]:
    """Each clip's pair stepped through the clip as the simulator steps them (`rollout.stepped`, from the simulator
    step before they touch: the striker driven along its path's heading and turn, the clipped car straight on):
    (time [s] from the start of the striker's manoeuvre to the touch, the striker's (along, across, yaw) and the
    clipped car's, each (3, steps) every cascade.DT after the touch, in the clip's frame (`cascade.Clip`)); None for
    a clip whose rows do not reach t_meet or whose pair never touches. All pairs stepped at once, each element as it
    would be alone."""
    out: list = [None] * len(clips)
    live = []
    for i, c in enumerate(clips):
        k = int(round(c.t_meet / c.dt)) - 1
        if 0 <= k < len(c.rows[0]):
            live.append((i, k))
    if not live:
        return out

    def pose(c: cascade.Clip, j: int) -> tuple[float, float, float]:
        if j < 0:
            return 0.0, c.lateral, 0.0
        return float(c.rows[0][j]), c.lateral + c.sign * float(c.rows[1][j]), c.sign * float(c.rows[2][j])

    sel = [clips[i] for i, _ in live]

    def column(values) -> np.ndarray:
        return np.array(list(values), dtype=float)

    before = [pose(c, k - 1) for c, (_, k) in zip(sel, live)]
    after = [pose(c, k) for c, (_, k) in zip(sel, live)]
    dt = column(c.dt for c in sel)
    t0 = column(k for _, k in live) * dt
    bx, by, byaw = (column(p[j] for p in before) for j in range(3))
    speed = column(math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(after, before)) / dt
    turn = column(a[2] - b[2] for a, b in zip(after, before)) / dt
    la, wa, ma, ra = (column(c.me[j] for c in sel) for j in range(4))
    lb, wb, mb, rb = (column(c.partner[j] for c in sel) for j in range(4))
    p_speed, zero = column(c.partner_speed for c in sel), np.zeros(len(sel))
    free = np.zeros(len(sel), dtype=bool)
    striker = rollout.Bodies(bx, by, byaw, speed * np.cos(byaw), speed * np.sin(byaw), turn, la, wa, ma, ra * la,
                             free, turn)
    p_along, p_across = column(c.partner_ahead for c in sel) + p_speed * t0, column(c.partner_lateral for c in sel)
    partner = rollout.Bodies(p_along, p_across, zero, p_speed, zero.copy(), zero.copy(), lb, wb, mb, rb * lb,
                             free.copy(), zero.copy())
    friction = column(c.friction for c in sel)
    steps = int(cascade.HORIZON / cascade.DT)
    pa, pb, first = rollout.stepped(striker, partner, friction, float(dt[0]), steps, cascade.DT) \
        if len(set(dt.tolist())) == 1 else _each_dt(striker, partner, friction, dt, steps)
    for j, (i, _) in enumerate(live):
        if np.isfinite(first[j]):
            out[i] = float(t0[j] + first[j]), pa[:, j], pb[:, j]
    return out


def _each_dt(striker: rollout.Bodies, partner: rollout.Bodies, friction: np.ndarray, dt: np.ndarray, steps: int):
    """`rollout.stepped` of pairs of several simulator steps, each group of one step at once."""
    n = len(dt)
    pa, pb, first = np.zeros((3, n, steps)), np.zeros((3, n, steps)), np.full(n, np.nan)
    for one in np.unique(dt):
        r = np.nonzero(dt == one)[0]
        pa[:, r], pb[:, r], first[r] = rollout.stepped(striker.take(r), partner.take(r), friction[r], float(one), steps,
                                                       cascade.DT)
    return pa, pb, first


def first_overlaps(path: np.ndarray, body: Body, ahead: Ahead, t_touch: float, shifts: np.ndarray) -> np.ndarray:
    """(S,) the first step of `path` ((along, across, yaw) (3, K) every cascade.DT after the touch at `t_touch` [s]
    from the manoeuvre's start) whose footprint overlaps the third car's moved `shifts` (S,) [m] along its lane from
    where it was sampled; K where it never does."""
    x, y, yaw = path
    steps = len(x)
    lo, hi = overlap_interval(y - ahead.across, yaw, body, ahead.body)
    # the third car's centre at each step, before its shift: it drives straight on from its sampled start
    third = ahead.along + ahead.speed * (ahead.t_step + t_touch + cascade.DT * np.arange(1, steps + 1))
    rel = x - third  # my centre ahead of its unshifted one: they overlap where rel - shift is within [lo, hi]
    inside = (rel[:, None] - shifts[None, :] >= lo[:, None]) & (rel[:, None] - shifts[None, :] <= hi[:, None])
    return np.where(inside.any(axis=0), inside.argmax(axis=0), steps)


def place_ahead(pairs: list[tuple[float, np.ndarray, np.ndarray] | None], me: Body, partner: Body, ahead: Ahead,
                partner_start: list[float], klass: str, striker_first: bool
                ) -> tuple[int, float, int] | None:
    """(pair index, the third car's shift along its lane [m], the step of the striker's path they meet at) of the
    least shift with which some clip's striker (`clip_pairs`) meets the third car first with the class `klass`
    (the monitor's classification at that step, `striker_first`: the striker is the monitor's actor_a), before the
    clipped car does (its stepped path), the third car starting at least START_GAP ahead of the clipped car's front
    (`partner_start`: each clip's clipped car's centre [m] along the clip's frame at the simulation's start; it
    drives on no faster than the third car, which the caller checks). None when no clip and shift does."""
    shifts = np.arange(-PLACE_RANGE, PLACE_RANGE + PLACE_STEP / 2, PLACE_STEP)
    best: tuple[float, int, float, int] | None = None
    for i, (pair, start) in enumerate(zip(pairs, partner_start)):
        if pair is None:
            continue
        t_touch, mine, theirs = pair
        room = ahead.along + shifts - ahead.body.length / 2 - (start + partner.length / 2) >= START_GAP
        k_me = first_overlaps(mine, me, ahead, t_touch, shifts)
        k_them = first_overlaps(theirs, partner, ahead, t_touch, shifts)
        steps = mine.shape[1]
        ok = room & (k_me < steps) & (k_me < k_them)
        if not ok.any():
            continue
        k = np.minimum(k_me, steps - 1)
        got = _classes(mine[:, k], ahead, t_touch, shifts, k, me, striker_first)
        ok &= got == klass
        for j in np.nonzero(ok)[0]:
            key = abs(float(shifts[j]))
            if best is None or key < best[0]:
                best = (key, i, float(shifts[j]), int(k_me[j]))
    return None if best is None else best[1:]


def _classes(poses: np.ndarray, ahead: Ahead, t_touch: float, shifts: np.ndarray, k: np.ndarray, me: Body,
             striker_first: bool) -> np.ndarray:
    """The monitor's class (skid.monitor_class) of the striker at `poses` (3, S) against the third car moved
    `shifts` (S,) at steps `k` (S,) of the path, in the monitor's actor order."""
    px, py, pyaw = poses
    third = ahead.along + shifts + ahead.speed * (ahead.t_step + t_touch + cascade.DT * (k + 1))
    # the third car drives along the frame's axis (heading 0): the striker's pose relative to its centre
    return monitor_class(px - third, py - ahead.across, pyaw, 0.0, me, ahead.body, striker_first)


def ahead_in_lane(plan: VariationPlan, partner: int, third: int) -> bool:
    """Whether the third actor starts ahead of the clipped car in its lane (this module's configuration)."""
    return same_lane(plan.route, plan.d0, partner, third) and plan.s0[third] > plan.s0[partner]


def plan_ahead(plan: VariationPlan, a: int, partner: int, third: int, klass: str, tried: list) -> bool:
    """Actor a's clip of `partner` followed by its written contact of class `klass` with `third`, ahead of the
    partner in its lane: among the clips `tried` ((partner speed scale, clip.ClipTiming, the partner's shifted start
    (s0, moved)) each, from clip._clip_then_meet), the one and the third actor's start (`place_ahead`, moved
    along its lane only) with which the striker's stepped slide meets it first as written, its pull-out trigger,
    the partner's speed and start and the third's start set; False (nothing changed) when none does, or when the
    partner's driver would brake for the third actor before the clip (`pushchain.approach`)."""
    cols, arrays, dt = plan.ctx.columns, plan.ctx.arrays, plan.ctx.skid_paths.dt
    if not tried or plan.speeds[third] <= 0.0:
        return False
    me_t = (float(plan.length[a]), float(plan.width[a]), cols[a].limits.mass, cols[a].limits.wheelbase_ratio)
    them_t = (float(plan.length[partner]), float(plan.width[partner]), cols[partner].limits.mass,
              cols[partner].limits.wheelbase_ratio)
    speeds = [float(plan.planned[partner] * scale) for scale, _, _ in tried]
    clips = [cascade.Clip(timed.rows, timed.sign, float(plan.speeds[a]), float(plan.d0[a]), timed.ahead, p_speed,
                          timed.lateral, timed.t_meet, dt, me_t, them_t, plan.ctx.friction)
             for (_, timed, _), p_speed in zip(tried, speeds)]
    pairs = lockstep.together(clip_pairs, clips)
    other = plan.scene.actors[third]
    gap3, across3 = relative_to_route(arrays, plan.route[a], plan.s0[a], other.x, other.y, exact=True)
    me, them = Body(me_t[0], me_t[1]), Body(them_t[0], them_t[1])
    body3 = Body(float(plan.length[third]), float(plan.width[third]))
    v3 = float(plan.speeds[third])
    # one candidate at a time (each has its own frame: the striker's manoeuvre starts on its own step), the partner
    # no faster than the third actor before the clip (it would close in on it and brake)
    found = None
    for i, ((scale, timed, shifted), pair, p_speed) in enumerate(zip(tried, pairs, speeds)):
        if pair is None or p_speed > v3:
            continue
        ahead = Ahead(gap3 - float(plan.speeds[a]) * timed.t_step, across3, v3, body3, timed.t_step)
        start = timed.ahead - p_speed * timed.t_step
        got = place_ahead([pair], me, them, ahead, [start], klass, a < third)
        if got is not None and (found is None or abs(got[1]) < abs(found[1])):
            found = (i, got[1])
    if found is None:
        return False
    (scale, timed, shifted), shift = tried[found[0]], found[1]
    saved = plan.snapshot()
    placed = plan.shift_start(third, shift) if shift else float(plan.s0[third])
    if placed is None:
        return False
    plan.s0[third], plan.moved[third] = placed, plan.moved[third] or bool(shift)
    plan.scale[partner], plan.speeds[partner] = scale, plan.planned[partner] * scale
    plan.s0[partner], plan.moved[partner] = shifted
    # the partner's driver follows the cars it sees ahead: it must still drive at the clip's speed when clipped
    t_clip = timed.t_step + timed.t_meet
    times = np.arange(0.0, t_clip + pushchain.STEP, pushchain.STEP)
    _, v = pushchain.approach(plan, partner, times)
    if float(np.min(v)) < plan.speeds[partner] - BRAKE_TOLERANCE:
        plan.restore(saved)
        return False
    plan.trigger[a] = timed.trigger
    return True
