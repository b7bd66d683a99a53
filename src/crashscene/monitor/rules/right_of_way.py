"""Right-of-way rules at junctions: CVC 21800 (uncontrolled / all-way stop), 21801
(left turn), 21802 (leaving a stop sign) and 21803 (yield sign).

All four compare the subject actor a with each other actor b whose path a
crosses (see `crashscene.monitor.conflicts`): when a enters b's path, how long
b still needs to reach the crossing (time to reach, TTR), or, for 21800, which
of the two had priority and the post-encroachment time (PET) that resulted.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from crashscene.geometry import heading_difference, wrap_angle
from crashscene.monitor.arrays import code_of
from crashscene.monitor.context import EvalContext
from crashscene.monitor.rules.base import Disposition, Rule, RuleOutcome, RuleParams, register_rule
from crashscene.monitor.timeseries import first_index, margin_in, take


@dataclass
class PairState:
    """State of each ordered pair (a, b) when a enters b's path; arrays (V, A, A)."""

    enter_a: np.ndarray    # step a enters b's path, -1 never
    t_enter_a: np.ndarray  # [s]
    ttr_b: np.ndarray      # [s] b's time to reach the crossing at that moment (0 inside, inf passed/not coming)
    ctrl_a: np.ndarray     # control code of a's approach at its entry
    ctrl_b: np.ndarray     # control code of b's approach at that moment
    maneuver_a: np.ndarray
    crossing: np.ndarray   # bool


def pair_state(ctx: EvalContext) -> PairState:
    cached = ctx.cache.get("pair_state")
    if cached is not None:
        return cached
    a = ctx.arrays
    n_var, n_act, _ = a.shape
    c = ctx.conflicts
    shape = (n_var, n_act, n_act)
    ttr = np.full(shape, np.nan)
    ctrl_a = np.full(shape, -1, dtype=np.int32)
    ctrl_b = np.full(shape, -1, dtype=np.int32)
    maneuver_a = np.full(shape, -1, dtype=np.int32)
    t_enter = np.full(shape, np.nan)
    speed = a.floats["speed"]
    for i in range(n_act):
        for j in range(n_act):
            if i == j:
                continue
            enter = c.enter[:, i, j]
            t_enter[:, i, j] = take(ctx.time[:, i], enter)
            ctrl_a[:, i, j] = take(a.codes["control"][:, i], enter, -1)
            maneuver_a[:, i, j] = take(a.codes["maneuver"][:, i], enter, -1)
            ctrl_b[:, i, j] = take(a.codes["control"][:, j], enter, -1)
            s_b_now = take(c.s[:, j], enter)
            dist_b = c.s_enter[:, j, i] - s_b_now
            speed_b = take(speed[:, j], enter)
            with np.errstate(divide="ignore", invalid="ignore"):
                value = np.where(speed_b > 0.1, np.maximum(dist_b, 0.0) / speed_b, np.inf)
            enter_b, exit_b = c.enter[:, j, i], c.exit[:, j, i]
            passed = (exit_b >= 0) & (exit_b < enter)
            inside = (enter_b >= 0) & (enter_b <= enter) & ~passed
            value = np.where(passed | ~np.isfinite(dist_b), np.inf, np.where(inside, 0.0, value))
            ttr[:, i, j] = np.where(enter >= 0, value, np.nan)
    state = PairState(enter_a=c.enter, t_enter_a=t_enter, ttr_b=ttr, ctrl_a=ctrl_a, ctrl_b=ctrl_b,
                      maneuver_a=maneuver_a, crossing=c.crossing)
    ctx.cache["pair_state"] = state
    return state


def _ttr_outcome(ctx: EvalContext, qualifies: np.ndarray, applicable: np.ndarray, max_ttr: float) -> RuleOutcome:
    """Violated when, for some qualifying pair, b's time to reach the crossing is below `max_ttr` [s]."""
    s = pair_state(ctx)
    ttr = np.where(qualifies & (s.enter_a >= 0), s.ttr_b, np.inf)
    bad = ttr < max_ttr
    out = RuleOutcome.empty(ctx.shape, max_ttr)
    out.applicable = applicable
    out.violated = bad.any(axis=2)
    out.first_t = np.where(bad, s.t_enter_a, np.inf).min(axis=2)
    worst = ttr.min(axis=2)
    out.measured = np.where(np.isfinite(worst), worst, np.nan)
    out.robustness = worst - max_ttr
    return out.finalize()


def enters_junction_with(ctx: EvalContext, control: str) -> np.ndarray:
    """(V, A) the actor is in a junction at some step while its approach has `control`."""
    return (ctx.arrays.flag("in_junction") & ctx.is_code("control", control)).any(axis=2)


class YieldParams(RuleParams):
    min_time_to_reach: float = Field(default=3.0, gt=0, le=20,
                                     description="[s] the other vehicle closer in time than this is a hazard")


@register_rule
class LeftTurnYield(Rule):
    code = "CVC_21801"
    violation = "left_turn_yield"
    unit = "s"
    summary = "a left-turning actor enters an oncoming vehicle's path while that one is less than the TTR away"
    rank = 4
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "maneuver", "control")
    guide = "turned left across oncoming traffic that was too close"
    disposition = frozenset({Disposition.NO_YIELD})
    Params = YieldParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: YieldParams = self.params
        s = pair_state(ctx)
        left = code_of("maneuver", "left")
        oncoming = self._oncoming(ctx)
        # no crossing-angle filter: a left turner's front reaches the oncoming lane early in its turn,
        # still nearly anti-parallel to it
        qualifies = (s.enter_a >= 0) & (s.maneuver_a == left) & oncoming
        applicable = (ctx.is_code("maneuver", "left") & ctx.arrays.flag("in_junction")).any(axis=2)
        return _ttr_outcome(ctx, qualifies, applicable, p.min_time_to_reach)

    @staticmethod
    def _oncoming(ctx: EvalContext) -> np.ndarray:
        """(V, A, A) b travelled against a's approach direction (heading difference over 135 deg)."""
        a = ctx.arrays
        yaw = a.floats["yaw"]
        n_steps = a.shape[2]
        s = pair_state(ctx)
        # a's heading before it turned: at its junction entry, else 2 s before it entered b's path
        ref = np.where(ctx.junction_entry >= 0, ctx.junction_entry, -1)
        out = np.zeros(s.enter_a.shape, dtype=bool)
        back = round(2.0 / ctx.dt)
        for i in range(a.shape[1]):
            for j in range(a.shape[1]):
                if i == j:
                    continue
                step = np.where(ref[:, i] >= 0, ref[:, i], np.maximum(s.enter_a[:, i, j] - back, 0))
                step = np.where(s.enter_a[:, i, j] >= 0, np.minimum(step, s.enter_a[:, i, j]), -1)
                step = np.clip(step, -1, n_steps - 1)
                diff = heading_difference(take(yaw[:, i], step), take(yaw[:, j], step))
                out[:, i, j] = diff > np.radians(135)
        return out


def _controlled_entry_outcome(ctx: EvalContext, control: str, max_ttr: float) -> RuleOutcome:
    """Entering from an approach under `control` (stop, yield) into the path of a through vehicle (one with no
    control or a signal) less than `max_ttr` [s] away (`_ttr_outcome`)."""
    s = pair_state(ctx)
    through = np.isin(s.ctrl_b, [-1, code_of("control", "none"), code_of("control", "signal")])
    qualifies = s.crossing & (s.ctrl_a == code_of("control", control)) & through
    return _ttr_outcome(ctx, qualifies, enters_junction_with(ctx, control), max_ttr)


@register_rule
class StopSignYield(Rule):
    code = "CVC_21802"
    violation = "stop_sign_yield"
    unit = "s"
    summary = "leaving a stop-controlled approach into a through vehicle's path less than the TTR away"
    rank = 5
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "maneuver", "control")
    guide = "stopped (or stop not stated) at a stop sign, then entered into cross traffic"
    disposition = frozenset({Disposition.NO_YIELD})
    Params = YieldParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        return _controlled_entry_outcome(ctx, "stop", self.params.min_time_to_reach)


@register_rule
class YieldSign(Rule):
    code = "CVC_21803"
    violation = "yield_sign"
    unit = "s"
    summary = "entering from a yield-controlled approach into a through vehicle's path less than the TTR away"
    rank = 12
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "maneuver", "control")
    guide = "did not yield at a yield sign"
    disposition = frozenset({Disposition.NO_YIELD})
    Params = YieldParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        return _controlled_entry_outcome(ctx, "yield", self.params.min_time_to_reach)


class IntersectionParams(RuleParams):
    min_pet: float = Field(default=1.5, gt=0, le=10, description="[s] post-encroachment time below this is a conflict")
    max_brake: float = Field(default=2.0, gt=0, le=10,
                             description="[m/s2] deceleration the priority vehicle may be forced into")
    arrival_tie: float = Field(default=1.0, ge=0, le=10,
                               description="[s] arrivals this close count as together (vehicle on the right first)")
    arrival_distance: float = Field(default=3.0, ge=0, le=30,
                                    description="[m] before its stop line where an actor has arrived")
    reaction_window: float = Field(default=1.0, ge=0, le=10,
                                   description="[s] before the entry from which the priority vehicle's braking counts")


@register_rule
class IntersectionRightOfWay(Rule):
    code = "CVC_21800"
    violation = "intersection_right_of_way"
    unit = "s"
    summary = ("at an uncontrolled or all-way-stop junction, entering ahead of a vehicle with priority "
               "(entered first, or arrived together on the right) with PET below the minimum or forcing it to brake")
    rank = 3
    columns = ("t", "x", "y", "yaw", "speed", "accel", "in_junction", "maneuver", "control", "stop_line_dist")
    guide = "at an uncontrolled junction, did not yield to the vehicle with priority"
    disposition = frozenset({Disposition.NO_YIELD})
    Params = IntersectionParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: IntersectionParams = self.params
        a = ctx.arrays
        n_var, n_act, n_steps = a.shape
        s = pair_state(ctx)
        c = ctx.conflicts
        none_code, stop_code = code_of("control", "none"), code_of("control", "stop")
        dist = a.floats["stop_line_dist"]
        with np.errstate(invalid="ignore"):
            arrived = a.flag("in_junction") | ((dist <= p.arrival_distance) & (dist > -p.arrival_distance))
        arrival = ctx.time_at(first_index(arrived & a.alive))
        yaw, accel = a.floats["yaw"], a.floats["accel"]
        steps = np.arange(n_steps)
        react = round(p.reaction_window / ctx.dt)
        pet_all = np.full((n_var, n_act, n_act), np.inf)
        margin_all = np.full((n_var, n_act, n_act), np.inf)
        bad_all = np.zeros((n_var, n_act, n_act), dtype=bool)
        for i in range(n_act):
            for j in range(n_act):
                if i == j:
                    continue
                enter_a, exit_a = c.enter[:, i, j], c.exit[:, i, j]
                enter_b, exit_b = c.enter[:, j, i], c.exit[:, j, i]
                same_class = (((s.ctrl_a[:, i, j] == none_code) & np.isin(s.ctrl_b[:, i, j], [none_code, -1]))
                              | ((s.ctrl_a[:, i, j] == stop_code) & (s.ctrl_b[:, i, j] == stop_code)))
                arr_a, arr_b = arrival[:, i], arrival[:, j]
                ref = np.clip(np.where(enter_a >= 0, enter_a, 0), 0, n_steps - 1)
                rel = wrap_angle(take(yaw[:, j], ref) - take(yaw[:, i], ref))
                from_right = (rel > np.radians(45)) & (rel < np.radians(135))
                with np.errstate(invalid="ignore"):
                    priority_b = (arr_b < arr_a - p.arrival_tie) | ((np.abs(arr_b - arr_a) <= p.arrival_tie) & from_right)
                not_cleared = ~((exit_b >= 0) & (exit_b < enter_a))
                relevant = s.crossing[:, i, j] & same_class & priority_b & (enter_a >= 0) & not_cleared
                t_exit_a = take(ctx.time[:, i], exit_a)
                t_enter_b = take(ctx.time[:, j], enter_b)
                overlap = (enter_b >= 0) & (enter_b <= exit_a)
                pet = np.where(overlap, 0.0, np.where(enter_b >= 0, t_enter_b - t_exit_a, np.inf))
                stop = np.where(enter_b >= 0, enter_b, n_steps - 1)
                window = (steps[None, :] >= (enter_a - react)[:, None]) & (steps[None, :] <= stop[:, None])
                min_accel = np.where(window & np.isfinite(accel[:, j]), accel[:, j], np.inf).min(axis=1)
                brake_margin = np.where(np.isfinite(min_accel),
                                        margin_in(p.min_pet, min_accel + p.max_brake, p.max_brake), np.inf)
                margin = np.fmin(pet - p.min_pet, brake_margin)
                pet_all[:, i, j] = np.where(relevant, pet, np.inf)
                margin_all[:, i, j] = np.where(relevant, margin, np.inf)
                bad_all[:, i, j] = relevant & (margin < 0)
        out = RuleOutcome.empty(ctx.shape, p.min_pet)
        in_junction = a.flag("in_junction")
        out.applicable = (in_junction & (ctx.is_code("control", "none") | ctx.is_code("control", "stop"))).any(axis=2)
        out.violated = bad_all.any(axis=2)
        out.first_t = np.where(bad_all, s.t_enter_a, np.inf).min(axis=2)
        worst = np.argmin(margin_all, axis=2)[..., None]
        m = np.take_along_axis(margin_all, worst, axis=2)[..., 0]
        pet_w = np.take_along_axis(pet_all, worst, axis=2)[..., 0]
        out.measured = np.where(np.isfinite(pet_w), pet_w, np.nan)
        out.robustness = m
        return out.finalize()
