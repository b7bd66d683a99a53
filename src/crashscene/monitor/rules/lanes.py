"""Lane rules: CVC 21460 (double solid centre line), CVC 21650 (right half of the road)
and CVC 22107 (unsafe lane change)."""
from __future__ import annotations

import numpy as np
from pydantic import Field

from crashscene.geometry import heading_difference, relative_position
from crashscene.monitor.context import EvalContext
from crashscene.monitor.rules.base import Disposition, Rule, RuleOutcome, RuleParams, register_rule
from crashscene.monitor.timeseries import first_index, margin_in, runs, steps_for


def left_turn_exempt(ctx: EvalContext, near_junction: float) -> np.ndarray:
    """(V, A, T) steps of a left or U turn at a junction (or driveway): crossing the centre line is allowed."""
    a = ctx.arrays
    turning = ctx.is_code("maneuver", "left") | ctx.is_code("maneuver", "u_turn")
    dist = a.floats["stop_line_dist"]
    with np.errstate(invalid="ignore"):
        at_junction = a.flag("in_junction") | (np.abs(dist) <= near_junction)
    return turning & at_junction


class DoubleLineParams(RuleParams):
    max_intrusion: float = Field(default=0.1, ge=0, le=2, description="[m] footprint beyond the double line allowed")
    junction_distance: float = Field(default=10.0, ge=0, le=50,
                                     description="[m] from a stop line where a left turn counts as at the junction")


@register_rule
class DoubleLine(Rule):
    code = "CVC_21460"
    violation = "double_line_crossing"
    unit = "m"
    summary = "a footprint corner beyond a double solid centre line; left/U turn at a junction exempt"
    rank = 8
    columns = ("t", "x", "y", "yaw", "speed", "centerline_marker", "centerline_intrusion", "in_junction", "maneuver",
               "stop_line_dist")
    guide = "crossed a double solid centre line (add it beside CVC_21650 when road_marker is double_solid_line)"
    Params = DoubleLineParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: DoubleLineParams = self.params
        a = ctx.arrays
        intrusion = a.floats["centerline_intrusion"]
        double = ctx.is_code("centerline_marker", "double_solid_line") & np.isfinite(intrusion) & a.alive
        exempt = left_turn_exempt(ctx, p.junction_distance)
        counted = double & ~exempt
        bad = counted & (intrusion > p.max_intrusion)
        out = RuleOutcome.empty(ctx.shape, p.max_intrusion)
        out.applicable = double.any(axis=2)
        out.violated = bad.any(axis=2)
        out.first_t = ctx.time_at(first_index(bad))
        worst = np.where(counted, intrusion, -np.inf).max(axis=2)
        out.measured = np.where(np.isfinite(worst), worst, np.nan)
        out.robustness = np.where(np.isfinite(worst), p.max_intrusion - worst, np.inf)
        used = (double & exempt & (intrusion > p.max_intrusion)).any(axis=2)
        out.note = np.where(used, "left turn at a junction across the double line (exempt)", None).astype(object)
        return out.finalize()


class WrongSideParams(RuleParams):
    min_duration: float = Field(default=0.5, gt=0, le=30, description="[s] in an opposing lane before it counts")
    clear_distance: float = Field(default=60.0, ge=0, le=500,
                                  description="[m] an oncoming vehicle closer than this ahead means the lane is not "
                                              "clear for an overtake")
    max_overtake_duration: float = Field(default=15.0, gt=0, le=120,
                                         description="[s] longer stays are never a permitted overtake")
    lane_half_width: float = Field(default=1.8, gt=0, le=5,
                                   description="[m] lateral offset of an oncoming vehicle still in the actor's lane")


@register_rule
class WrongSide(Rule):
    code = "CVC_21650"
    violation = "wrong_side"
    unit = "s"
    summary = ("centre in an opposing lane outside junctions for the minimum duration (or until a crash ends it), "
               "outside a permitted overtake")
    rank = 9
    columns = ("t", "x", "y", "yaw", "speed", "lane_id", "opposing_lane", "in_junction")
    guide = "drove on the wrong side: entered or drifted into the opposing lanes (crossed the centre line)"
    Params = WrongSideParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: WrongSideParams = self.params
        a = ctx.arrays
        n_var, n_act, n_steps = a.shape
        opposing = a.flag("opposing_lane") & ~a.flag("in_junction") & a.alive
        out = RuleOutcome.empty(ctx.shape, p.min_duration)
        out.applicable = (a.known("opposing_lane") & a.alive).any(axis=2)
        ids, n_runs = runs(opposing)
        out.measured = np.where(out.applicable, 0.0, np.nan)
        out.robustness = np.full(ctx.shape, p.min_duration)
        if n_runs == 0:
            return out.finalize()
        flat = ids.ravel()
        inside = flat >= 0
        run_of = flat[inside]
        length = np.bincount(run_of, minlength=n_runs) * ctx.dt
        double = ctx.is_code("centerline_marker", "double_solid_line").ravel()[inside]
        has_double = np.bincount(run_of, weights=double.astype(float), minlength=n_runs) > 0
        close = self._oncoming_close(ctx, p, opposing).ravel()[inside]
        not_clear = np.bincount(run_of, weights=close.astype(float), minlength=n_runs) > 0
        start_flat = np.nonzero(inside)[0][np.unique(run_of, return_index=True)[1]]
        v_idx, a_idx, t_idx = np.unravel_index(start_flat, a.shape)
        va = v_idx * n_act + a_idx
        # a stay cut short by a crash counts whatever its length: the collision ended it, not the driver
        contact = ctx.first_contact[v_idx, a_idx]
        crashed = (contact >= t_idx) & (contact <= t_idx + np.round(length / ctx.dt) + 1)
        permitted = ~has_double & ~not_clear & ~crashed & (length <= p.max_overtake_duration)
        bad_run = ((length >= p.min_duration - 1e-9) | crashed) & ~permitted
        longest = np.zeros(n_var * n_act)
        np.maximum.at(longest, va[~permitted], length[~permitted])
        first = np.full(n_var * n_act, np.inf)
        reach = np.where(crashed, t_idx, t_idx + steps_for(p.min_duration, ctx.dt) - 1)
        times = ctx.time[v_idx, a_idx, np.minimum(reach, n_steps - 1)]
        np.minimum.at(first, va[bad_run], times[bad_run])
        longest = longest.reshape(ctx.shape)
        out.measured = np.where(out.applicable, longest, np.nan)
        out.robustness = p.min_duration - longest
        out.violated = np.isfinite(first).reshape(ctx.shape)
        out.first_t = first.reshape(ctx.shape)
        overtook = np.zeros(n_var * n_act, dtype=bool)
        overtook[va[permitted & (length >= p.min_duration)]] = True
        out.note = np.where(overtook.reshape(ctx.shape), "permitted overtake (lane clear, no double line)",
                            None).astype(object)
        return out.finalize()

    @staticmethod
    def _oncoming_close(ctx: EvalContext, p: WrongSideParams, opposing: np.ndarray) -> np.ndarray:
        """(V, A, T) an oncoming vehicle is ahead in the actor's lane within the clear distance."""
        a = ctx.arrays
        x, y, yaw = a.floats["x"], a.floats["y"], a.floats["yaw"]
        close = np.zeros(a.shape, dtype=bool)
        for i in range(a.shape[1]):
            rows = np.nonzero(opposing[:, i].any(axis=1))[0]   # only where i is ever in an opposing lane
            if not len(rows):
                continue
            for j in range(a.shape[1]):
                if i == j:
                    continue
                lon, lat = relative_position(x[rows, i], y[rows, i], yaw[rows, i], x[rows, j], y[rows, j])
                with np.errstate(invalid="ignore"):
                    hit = ((heading_difference(yaw[rows, i], yaw[rows, j]) > np.pi / 2) & (lon > 0)
                           & (lon < p.clear_distance) & (np.abs(lat) < p.lane_half_width))
                close[rows, i] |= hit & a.alive[rows, j]
        return close


class LaneChangeParams(RuleParams):
    max_brake: float = Field(default=2.0, gt=0, le=10,
                             description="[m/s2] deceleration a target-lane vehicle may be forced into")
    time_headway: float = Field(default=1.0, gt=0, le=10, description="[s] safe gap of the target-lane vehicle")
    min_gap: float = Field(default=5.0, ge=0, le=50, description="[m] safe gap never below this")
    after_window: float = Field(default=2.0, ge=0, le=10,
                                description="[s] after the lane change during which the follower is still checked")


@register_rule
class UnsafeLaneChange(Rule):
    code = "CVC_22107"
    violation = "unsafe_lane_change"
    unit = "m"
    summary = ("a target-lane vehicle behind or alongside ends closer than its safe gap or must brake harder than "
               "the limit")
    rank = 10
    columns = ("t", "x", "y", "yaw", "speed", "accel", "lane_id", "lane_change", "target_lane_id")
    guide = "changed lanes or merged into another vehicle"
    disposition = frozenset({Disposition.NO_GAP_CHECK})
    Params = LaneChangeParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: LaneChangeParams = self.params
        a = ctx.arrays
        n_var, n_act, n_steps = a.shape
        x, y, yaw, speed, accel = (a.floats[c] for c in ("x", "y", "yaw", "speed", "accel"))
        lane, target = a.codes["lane_id"], a.codes["target_lane_id"]
        changing = a.flag("lane_change") & (target >= 0) & a.alive
        steps = np.broadcast_to(np.arange(n_steps), changing.shape)
        last_change = np.maximum.accumulate(np.where(changing, steps, -10**9), axis=2)
        after = ~changing & (steps - last_change <= steps_for(p.after_window, ctx.dt)) & (last_change >= 0)
        target_lane = np.where(changing, target, np.where(after, lane, -1))
        if not changing.any():
            return RuleOutcome.empty(ctx.shape, p.min_gap).finalize()
        worst = np.full((n_var, n_act, n_steps), np.inf)      # margin [m]
        gap_at = np.full((n_var, n_act, n_steps), np.nan)
        safe_at = np.full((n_var, n_act, n_steps), np.nan)
        for i in range(n_act):
            rows = np.nonzero((target_lane[:, i] >= 0).any(axis=1))[0]   # variations where i changes lanes
            if not len(rows):
                continue
            tl = target_lane[rows, i]
            for j in range(n_act):
                if i == j:
                    continue
                lon, _ = relative_position(x[rows, j], y[rows, j], yaw[rows, j], x[rows, i], y[rows, i])  # i from j
                half_sum = (a.length[rows, i, None] + a.length[rows, j, None]) / 2
                gap = np.abs(lon) - half_sum        # negative: side by side
                safe = np.maximum(p.time_headway * speed[rows, j], p.min_gap)
                with np.errstate(invalid="ignore"):
                    # the target-lane vehicle behind the changer, or alongside it (changing into its side)
                    affected = (tl >= 0) & (lane[rows, j] == tl) & (lon > -half_sum) & a.alive[rows, j]
                brake = np.where(np.isfinite(accel[rows, j]),
                                 margin_in(safe, accel[rows, j] + p.max_brake, p.max_brake), np.inf)
                margin = np.where(affected, np.fmin(gap - safe, brake), np.inf)
                current = worst[rows, i]
                better = margin < current
                worst[rows, i] = np.where(better, margin, current)
                gap_at[rows, i] = np.where(better, gap, gap_at[rows, i])
                safe_at[rows, i] = np.where(better, safe, safe_at[rows, i])
        bad = worst < 0
        out = RuleOutcome.empty(ctx.shape, np.nan)
        out.applicable = changing.any(axis=2)
        out.violated = bad.any(axis=2)
        out.first_t = ctx.time_at(first_index(bad))
        k = np.argmin(worst, axis=2)[..., None]
        m = np.take_along_axis(worst, k, axis=2)[..., 0]
        affected_any = np.isfinite(m)
        out.measured = np.where(affected_any, np.take_along_axis(gap_at, k, axis=2)[..., 0], np.nan)
        out.threshold = np.where(affected_any, np.take_along_axis(safe_at, k, axis=2)[..., 0], p.min_gap)
        out.robustness = np.where(affected_any, m, np.inf)
        return out.finalize()
