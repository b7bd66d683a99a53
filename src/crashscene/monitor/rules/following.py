"""CVC 21703: following too closely (time headway to a moving leader in the same lane)."""
from __future__ import annotations

import numpy as np
from pydantic import Field

from crashscene.monitor.context import EvalContext
from crashscene.monitor.rules.base import Disposition, Rule, RuleOutcome, RuleParams, register_rule
from crashscene.monitor.timeseries import first_index, steps_for, window_max


class FollowingParams(RuleParams):
    min_headway: float = Field(default=2.0, gt=0, le=10, description="[s] time headway below this is too close")
    min_duration: float = Field(default=1.0, gt=0, le=30, description="[s] the short headway must last this long")
    moving_leader_speed: float = Field(default=5.0, ge=0, le=40,
                                       description="[m/s] the leader must be faster than this")
    start_grace: float = Field(default=2.0, ge=0, le=30, description="[s] from the start of a trace during which "
                               "an ADS's headway is the test's initial condition, not its choice")
    advisory_headway: float = Field(default=3.0, gt=0, le=10,
                                    description="[s] the handbook's 3-second rule, reported as an advisory note")


@register_rule
class FollowingTooClosely(Rule):
    code = "CVC_21703"
    violation = "following_too_closely"
    unit = "s"
    summary = "time headway to a moving same-lane leader below the minimum for the minimum duration"
    rank = 11
    columns = ("t", "x", "y", "yaw", "speed", "lane_id")
    guide = "struck a MOVING vehicle ahead in the same lane (following too closely)"
    disposition = frozenset({Disposition.TAILGATES, Disposition.INATTENTIVE})
    Params = FollowingParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: FollowingParams = self.params
        a = ctx.arrays
        leaders = ctx.leaders
        speed = a.floats["speed"]
        with np.errstate(divide="ignore", invalid="ignore"):
            headway = np.where(speed > 0.1, leaders.gap / speed, np.inf)
            counted = (leaders.index >= 0) & (leaders.speed > p.moving_leader_speed) & ctx.settled(p.start_grace)
        headway = np.where(counted, headway, np.inf)
        sustained = window_max(headway, steps_for(p.min_duration, ctx.dt))   # held below for the whole window
        bad = sustained < p.min_headway
        out = RuleOutcome.empty(ctx.shape, p.min_headway)
        out.applicable = counted.any(axis=2)
        out.violated = bad.any(axis=2)
        out.first_t = ctx.time_at(first_index(bad))
        worst = sustained.min(axis=2)
        out.measured = np.where(np.isfinite(worst), worst, np.nan)
        out.robustness = worst - p.min_headway
        advisory = out.applicable & ~out.violated & (worst < p.advisory_headway)
        out.note = np.where(advisory, f"advisory: headway below the {p.advisory_headway:g}-second rule",
                            None).astype(object)
        return out.finalize()
