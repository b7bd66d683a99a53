"""Stop-line rules: CVC 21453 (steady red signal) and CVC 22450 (stop sign).

Both look at the step where the front bumper crosses the stop line
(`stop_line_dist` going from > 0 to <= 0) and at the state of the approach
just before it: the signal and how long it has been red, or whether the actor
came to a full stop within the last metres before the line.
"""
from __future__ import annotations

import numpy as np
from pydantic import Field

from crashscene.monitor.context import EvalContext
from crashscene.monitor.rules.base import Disposition, Rule, RuleOutcome, RuleParams, register_rule
from crashscene.monitor.timeseries import (
    crossings,
    first_index,
    run_length,
    segment_running_min,
)


def _previous(values: np.ndarray, fill) -> np.ndarray:
    """values[..., t-1] at every t (fill at t = 0)."""
    out = np.empty_like(values)
    out[..., 0] = fill
    out[..., 1:] = values[..., :-1]
    return out


def approach_min_speed(ctx: EvalContext, window: float) -> np.ndarray:
    """(V, A, T) lowest speed [m/s] within `window` [m] before the line on the current approach, up to t-1."""
    dist = ctx.arrays.floats["stop_line_dist"]
    speed = ctx.arrays.floats["speed"]
    with np.errstate(invalid="ignore"):
        include = (dist >= 0) & (dist <= window) & np.isfinite(speed)
    running = segment_running_min(speed, include, crossings(dist))
    # min over the approach up to the step before the crossing, and the speed at that step
    return np.fmin(_previous(running, np.inf), _previous(speed, np.inf))


class RedLightParams(RuleParams):
    red_grace: float = Field(default=0.2, ge=0, le=5, description="[s] time after the signal turned red "
                             "before crossing the line counts")
    right_turn_on_red: bool = Field(default=True, description="a right turn after a full stop is allowed")
    full_stop_speed: float = Field(default=0.3, gt=0, le=3, description="[m/s] below this the actor has stopped")
    stop_window: float = Field(default=10.0, gt=0, le=50, description="[m] before the line where the stop counts")


@register_rule
class RedLight(Rule):
    code = "CVC_21453"
    violation = "red_light"
    unit = "s"  # measured: red time at the crossing (negative: crossed that long before red)
    summary = "front bumper crosses the stop line on a steady red (after the grace time); right turn after a stop exempt"
    rank = 1
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "maneuver", "control", "signal", "stop_line_dist")
    guide = "entered against a red light"
    disposition = frozenset({Disposition.RUNS_RED})
    Params = RedLightParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: RedLightParams = self.params
        a = ctx.arrays
        dist = a.floats["stop_line_dist"]
        signal_ctrl = _previous(ctx.is_code("control", "signal"), False)
        red = ctx.is_code("signal", "red")
        known_signal = a.codes["signal"] >= 1
        red_prev = _previous(red, False)
        elapsed = _previous(run_length(red), 0) * ctx.dt        # [s] red before the crossing step
        cross = crossings(dist) & signal_ctrl
        turning_right = _previous(ctx.is_code("maneuver", "right"), False)
        stopped = approach_min_speed(ctx, p.stop_window) < p.full_stop_speed
        exempt = turning_right & stopped & p.right_turn_on_red
        on_red = cross & red_prev & (elapsed > p.red_grace)
        bad = on_red & ~exempt
        out = RuleOutcome.empty(ctx.shape, p.red_grace)
        out.applicable = (ctx.is_code("control", "signal") & known_signal & np.isfinite(dist)).any(axis=2)
        out.violated = bad.any(axis=2)
        out.first_t = ctx.time_at(first_index(bad))
        # before red: how long before the signal turned red the line was crossed (negative red time),
        # so a search sees a yellow crossing as closer to a violation than an early green one
        n_steps = red.shape[-1]
        steps = np.arange(n_steps)
        next_red = np.minimum.accumulate(np.where(red, steps, n_steps)[..., ::-1], axis=-1)[..., ::-1]
        to_red = np.where(next_red < n_steps, (next_red - steps) * ctx.dt, np.inf)
        measured_at = np.where(cross & ~exempt, np.where(red_prev, elapsed, -to_red), -np.inf)
        worst = measured_at.max(axis=2)
        crossed = (cross & ~exempt).any(axis=2)
        out.measured = np.where(crossed & np.isfinite(worst), worst, np.nan)
        out.robustness = np.where(crossed, p.red_grace - worst, np.inf)
        used = (cross & red_prev & exempt).any(axis=2)
        out.note = np.where(used, "right turn on red after a full stop (exempt)", None).astype(object)
        return out.finalize()


class StopSignParams(RuleParams):
    full_stop_speed: float = Field(default=0.3, gt=0, le=3, description="[m/s] below this the actor has stopped")
    stop_window: float = Field(default=10.0, gt=0, le=50, description="[m] before the line where the stop counts")


@register_rule
class StopSign(Rule):
    code = "CVC_22450"
    violation = "stop_sign"
    unit = "m/s"
    summary = "crosses a stop-controlled line without a full stop within the last metres before it"
    rank = 2
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "maneuver", "control", "stop_line_dist")
    guide = "did not stop at a stop sign"
    disposition = frozenset({Disposition.RUNS_STOP, Disposition.NO_YIELD})
    Params = StopSignParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: StopSignParams = self.params
        a = ctx.arrays
        dist = a.floats["stop_line_dist"]
        stop_ctrl = ctx.is_code("control", "stop")
        cross = crossings(dist) & _previous(stop_ctrl, False)
        min_speed = approach_min_speed(ctx, p.stop_window)
        bad = cross & (min_speed >= p.full_stop_speed)
        out = RuleOutcome.empty(ctx.shape, p.full_stop_speed)
        out.applicable = (stop_ctrl & np.isfinite(dist)).any(axis=2)
        out.violated = bad.any(axis=2)
        out.first_t = ctx.time_at(first_index(bad))
        worst = np.where(cross, min_speed, -np.inf).max(axis=2)
        crossed = np.isfinite(worst)
        out.measured = np.where(crossed, worst, np.nan)
        out.robustness = np.where(crossed, p.full_stop_speed - worst, np.inf)
        return out.finalize()
