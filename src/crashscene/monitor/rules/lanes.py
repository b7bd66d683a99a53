"""Lane rules: CVC 21460 (double solid centre line), CVC 21650 (right half of the road)
and CVC 22107 (unsafe lane change)."""
from __future__ import annotations

import numpy as np
from pydantic import Field

from crashscene.geometry import footprint_separation, heading_difference, relative_position, wrap_angle
from crashscene.monitor.context import EvalContext
from crashscene.monitor.judging import contact_indices, judged_until
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
    own_lateral_speed: float = Field(default=0.3, ge=0, le=5,
                                     description="[m/s] lateral speed towards the opposite lane before an upsetting "
                                                 "contact above which a stay beginning just after it is the "
                                                 "driver's own (the recorder's lane-change motion, 0.3 m/s; a car "
                                                 "keeping its lane moves far less)")


@register_rule
class WrongSide(Rule):
    """CVC 21650: drive on the right half of a two-way roadway.

    rules.md's check: the actor's centre in a lane of the opposite direction
    (`opposing_lane`) for `min_duration` or more, outside junctions and
    outside a permitted overtake (no double solid line, the opposing lane
    clear of oncoming vehicles within `clear_distance` for the whole stay, at
    most `max_overtake_duration`). Our additions: a stay cut short by the
    actor's first contact counts whatever its length (the crash ended it, not
    the driver); steps off the road between two steps in an opposing lane are
    part of the stay (the car ran off the far edge and came back into the
    opposing lanes without returning to its own side: one pass, which must be
    clear as a whole, not two); measured is the longest stay [s], robustness
    `min_duration` less it.

    After an upsetting contact (`crashscene.monitor.judging`) an actor is
    judged only a grace longer, so that a vehicle pushed across the centre
    line by an impact is not blamed. A stay that *begins* within that grace is
    nevertheless the driver's own, and counts with its whole duration (past
    the judging end too; an integrator's decision, issue 10), when the actor
    was already moving towards the opposite lane by itself: at the last
    recorded step before the contact its centre was still on its own side
    (a stay it was already in was judged as such) and its lateral speed
    towards the centre line exceeded `own_lateral_speed`. That speed is taken from the
    trace as a lower bound: the rate of `centerline_intrusion` (the farthest
    corner beyond the centre line) less the most the vehicle's rotation moves
    that corner (yaw rate times half the footprint's diagonal). A vehicle that
    kept its lane and was pushed over is never charged; junctions and
    permitted overtakes stay exempt.
    """

    code = "CVC_21650"
    violation = "wrong_side"
    unit = "s"
    summary = ("centre in an opposing lane outside junctions for the minimum duration (or until a crash ends it), "
               "outside a permitted overtake")
    rank = 9
    columns = ("t", "x", "y", "yaw", "speed", "lane_id", "opposing_lane", "off_road", "in_junction")
    guide = "drove on the wrong side: entered or drifted into the opposing lanes (crossed the centre line)"
    Params = WrongSideParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        out = self._stays(ctx)
        if ctx.whole is None or ctx.driven_until is None:
            return out
        # variations where a stay begun just after an upsetting contact is the driver's own: judged again on
        # their whole traces, each such actor up to the end of that stay
        rows, whole = ctx.whole.rows, ctx.whole.arrays
        upset = ctx.driven_until[rows]
        opposing = self._opposing(whole)
        own = self._own_stay_starts(whole, upset, ctx.grace, opposing)
        if not (own >= 0).any():
            return out
        stay_end = np.where(own >= 0, _run_ends(opposing, own), -1)
        last = judged_until(upset, ctx.grace)
        last = np.where(own >= 0, np.maximum(last, stay_end), last)
        arrays = whole.select(np.arange(len(rows)))
        arrays.truncate(last)
        collisions = ctx.collisions
        if collisions is not None:
            keep = np.isin(collisions.column("variation").to_numpy(), arrays.variations)
            collisions = collisions.filter(keep)
        sub = EvalContext(arrays=arrays, scenario=ctx.scenario, collisions=collisions, driven_until=upset,
                          grace=ctx.grace)
        again = self._stays(sub)
        for name in ("applicable", "violated", "first_t", "measured", "threshold", "robustness", "note"):
            getattr(out, name)[rows] = getattr(again, name)
        return out

    def past_judging(self, arrays, upset: np.ndarray, grace: int) -> np.ndarray | None:
        return (self._own_stay_starts(arrays, upset, grace) >= 0).any(axis=1)

    @staticmethod
    def _opposing(a) -> np.ndarray:
        """(V, A, T) the centre in an opposing lane outside junctions, or off the road between two such steps
        (`_off_between`): a car that runs off the far edge of the opposing lanes and comes back into them never
        returned to its own side, and its pass is one stay, not two."""
        inside = a.flag("opposing_lane") & ~a.flag("in_junction") & a.alive
        return inside | _off_between(inside, a.flag("off_road") & a.alive)

    def _own_stay_starts(self, a, upset: np.ndarray, grace: int, opposing: np.ndarray | None = None) -> np.ndarray:
        """(V, A) first step of a stay in an opposing lane that begins within `grace` steps after the actor's
        upsetting contact (at step `upset`, -1 none) while, at the last recorded step before that contact, the
        actor's centre was on its own side and moving towards the opposite lane by itself faster than
        `own_lateral_speed`; -1 none. `opposing`: `_opposing(a)` when the caller has it."""
        p: WrongSideParams = self.params
        out = np.full(upset.shape, -1, dtype=np.int64)
        n_steps = a.shape[2]
        vv, aa = np.nonzero((upset >= 2) & (upset < n_steps))
        if not len(vv):
            return out
        k = upset[vv, aa]
        if opposing is None:
            opposing = self._opposing(a)
        start = np.full(len(vv), -1, dtype=np.int64)
        for off in range(grace, -1, -1):  # the earliest start wins
            s = np.minimum(k + off, n_steps - 1)
            begins = opposing[vv, aa, s] & ~opposing[vv, aa, s - 1] & (k + off < n_steps)
            start = np.where(begins, s, start)
        intrusion, yaw = a.floats["centerline_intrusion"], a.floats["yaw"]
        corner = (intrusion[vv, aa, k - 1] - intrusion[vv, aa, k - 2]) / a.dt
        turn = np.abs(wrap_angle(yaw[vv, aa, k - 1] - yaw[vv, aa, k - 2])) / a.dt
        reach = np.hypot(a.length[vv, aa], a.width[vv, aa]) / 2
        with np.errstate(invalid="ignore"):  # moving towards the opposite lane from its own side of the road
            own = (start >= 0) & ~opposing[vv, aa, k - 1] & (corner - turn * reach > p.own_lateral_speed)
        out[vv[own], aa[own]] = start[own]
        return out

    def _stays(self, ctx: EvalContext) -> RuleOutcome:
        p: WrongSideParams = self.params
        a = ctx.arrays
        n_var, n_act, n_steps = a.shape
        opposing = self._opposing(a)
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
        """(V, A, T) an oncoming vehicle is ahead in the actor's lane within the clear distance: seen from the
        actor (ahead of it, within a lane's half width of its axis) or from the oncoming vehicle (the actor ahead
        of it in its lane, as when the actor's body is turned across the road)."""
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
                lon_j, lat_j = relative_position(x[rows, j], y[rows, j], yaw[rows, j], x[rows, i], y[rows, i])
                with np.errstate(invalid="ignore"):
                    ahead = (lon > 0) & (lon < p.clear_distance) & (np.abs(lat) < p.lane_half_width)
                    in_its_lane = (lon_j > 0) & (lon_j < p.clear_distance) & (np.abs(lat_j) < p.lane_half_width)
                    hit = (heading_difference(yaw[rows, i], yaw[rows, j]) > np.pi / 2) & (ahead | in_its_lane)
                close[rows, i] |= hit & a.alive[rows, j]
        return close


def _off_between(inside: np.ndarray, off: np.ndarray) -> np.ndarray:
    """(V, A, T) the steps of `off` (V, A, T) whose nearest steps on either side that are not `off` are both
    `inside` (V, A, T)."""
    n_steps = inside.shape[2]
    steps = np.broadcast_to(np.arange(n_steps), inside.shape)
    before = np.maximum.accumulate(np.where(off, -1, steps), axis=2)  # the last step not off, at or before
    after = np.flip(np.minimum.accumulate(np.flip(np.where(off, n_steps, steps), axis=2), axis=2), axis=2)

    def inside_at(k: np.ndarray) -> np.ndarray:
        return np.take_along_axis(inside, np.clip(k, 0, n_steps - 1), axis=2) & (k >= 0) & (k < n_steps)

    return off & inside_at(before) & inside_at(after)


def _run_ends(mask: np.ndarray, start: np.ndarray) -> np.ndarray:
    """(V, A) last step of the True run of `mask` (V, A, T) that contains step `start` (V, A; >= 0)."""
    n_steps = mask.shape[2]
    steps = np.arange(n_steps)
    first_gap = first_index(~mask & (steps >= np.maximum(start, 0)[..., None]))
    return np.where(first_gap >= 0, first_gap, n_steps) - 1


class LaneChangeParams(RuleParams):
    max_brake: float = Field(default=2.0, gt=0, le=10,
                             description="[m/s2] deceleration a target-lane vehicle may be forced into")
    time_headway: float = Field(default=1.0, gt=0, le=10, description="[s] safe gap of the target-lane vehicle")
    min_gap: float = Field(default=5.0, ge=0, le=50, description="[m] safe gap never below this")
    after_window: float = Field(default=2.0, ge=0, le=10,
                                description="[s] after the lane change during which the follower is still checked")


@register_rule
class UnsafeLaneChange(Rule):
    """CVC 22107: no lane change unless it can be made with reasonable safety.

    rules.md's check: during a lane change (and `after_window` past it), a
    vehicle in the target lane behind or alongside the changer must brake
    harder than `max_brake`, or its gap falls below its safe distance
    (`time_headway` at its speed, at least `min_gap`). Measured: that gap [m];
    threshold: that safe distance [m]; robustness: gap less safe distance (the
    braking margin scaled into metres where it is the smaller).

    Beyond rules.md's wording (an integrator's decision, issue 10): a lane
    change during which the changer *strikes* another vehicle (the monitor's
    own attribution of a contact, `collisions.striking_actor`: the actor whose
    front made it; a sideswipe has no striker) was not made with reasonable
    safety, wherever that vehicle is (the lane being left, as when a car pulls
    out to pass and clips the rear of the car it follows). The lane change is
    in progress at the contact when the changer's `lane_change` flag is set at
    the contact's step or the recorded step before it. For such a contact the
    rule reports the clearance [m] between the two footprints at the contact's
    step (zero or less: they touch) against a threshold of 0 m, and that
    clearance as the robustness, unless the target-lane check gives a smaller
    margin. The struck vehicle is not charged by this clause.
    """

    code = "CVC_22107"
    violation = "unsafe_lane_change"
    unit = "m"
    summary = ("a target-lane vehicle behind or alongside ends closer than its safe gap or must brake harder than "
               "the limit, or the changer strikes a vehicle while changing lanes")
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
        struck = self._strikes(ctx, changing)
        better = struck < worst
        worst = np.where(better, struck, worst)
        gap_at = np.where(better, struck, gap_at)
        safe_at = np.where(better, 0.0, safe_at)
        bad = (worst < 0) | np.isfinite(struck)
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

    @staticmethod
    def _strikes(ctx: EvalContext, changing: np.ndarray) -> np.ndarray:
        """(V, A, T) at the step of each contact an actor strikes while its lane change is in progress (its flag set
        at that step or the one before), the clearance [m] between the two footprints there, at most 0; inf
        elsewhere."""
        out = np.full(changing.shape, np.inf)
        table = ctx.collisions
        if table is None or not table.num_rows:
            return out
        a = ctx.arrays
        striker = table.column("striking_actor").to_pylist()
        rows = [k for k, role in enumerate(striker) if role is not None]
        if not rows:
            return out
        v, first, second, step = (q[rows] for q in contact_indices(a, table))
        i = np.array([a.roles.index(striker[k]) for k in rows], dtype=np.int64)
        j = np.where(i == first, second, first)  # the one it strikes
        step = np.minimum(step, a.shape[2] - 1)
        in_progress = changing[v, i, step] | changing[v, i, np.maximum(step - 1, 0)]
        if not in_progress.any():
            return out
        v, i, j, step = v[in_progress], i[in_progress], j[in_progress], step[in_progress]
        f = a.floats
        with np.errstate(invalid="ignore"):
            clearance = footprint_separation(f["x"][v, i, step], f["y"][v, i, step], f["yaw"][v, i, step],
                                             a.length[v, i], a.width[v, i], f["x"][v, j, step], f["y"][v, j, step],
                                             f["yaw"][v, j, step], a.length[v, j], a.width[v, j])
        clearance = np.where(np.isfinite(clearance), np.minimum(clearance, 0.0), 0.0)  # a contact touches
        np.minimum.at(out, (v, i, step), clearance)
        return out
