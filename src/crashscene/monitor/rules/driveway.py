"""CVC 21804: entering a highway from a driveway or private road, yield to approaching traffic.

Like CVC 21802 without the stop. A driveway, alley or private road joining
the road is a T junction's uncontrolled stem in the DSL (dsl.md: "a driveway
or a business access -> t_intersection"), so on a `t_intersection` scenario
the rule checks an actor that turns (left or right) out of an uncontrolled
approach into the path of a vehicle going straight along the road, which
comes from the actor's side (its heading 45-135 deg off the actor's at the
actor's junction entry): that vehicle's time to reach the crossing when the
actor enters its path must be at least the minimum.
"""
from __future__ import annotations

import numpy as np

from crashscene.dsl.tokens import RoadType
from crashscene.monitor.arrays import code_of
from crashscene.monitor.context import EvalContext
from crashscene.monitor.rules.base import Disposition, Rule, RuleOutcome, register_rule
from crashscene.monitor.rules.right_of_way import YieldParams, _ttr_outcome, pair_state
from crashscene.monitor.timeseries import take

SIDE_COS = float(np.cos(np.radians(45)))  # |cos| of the heading difference below this: from a side


@register_rule
class DrivewayYield(Rule):
    code = "CVC_21804"
    violation = "driveway_yield"
    unit = "s"
    summary = ("turning out of a driveway or private road (an uncontrolled T stem) into the path of a through "
               "vehicle less than the TTR away")
    rank = 13
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "maneuver", "control")
    guide = "left a driveway, alley, parking lot or private road into the path of traffic on the road"
    disposition = frozenset({Disposition.NO_YIELD})
    Params = YieldParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: YieldParams = self.params
        if ctx.scenario is None or ctx.scenario.road_network.road_type != RoadType.T_INTERSECTION:
            return RuleOutcome.empty(ctx.shape, p.min_time_to_reach).finalize()
        a = ctx.arrays
        s = pair_state(ctx)
        turning = np.isin(s.maneuver_a, [code_of("maneuver", "left"), code_of("maneuver", "right")])
        uncontrolled = s.ctrl_a == code_of("control", "none")
        through = np.zeros(s.enter_a.shape, dtype=bool)
        yaw, maneuver = a.floats["yaw"], a.codes["maneuver"]
        entry = ctx.junction_entry
        for i in range(a.shape[1]):
            for j in range(a.shape[1]):
                if i == j:
                    continue
                enter = s.enter_a[:, i, j]
                straight = take(maneuver[:, j], enter, -1) == code_of("maneuver", "straight")
                ref = np.where(entry[:, i] >= 0, np.minimum(entry[:, i], np.maximum(enter, 0)), enter)
                side = np.abs(np.cos(take(yaw[:, j], ref) - take(yaw[:, i], ref))) < SIDE_COS
                through[:, i, j] = straight & side & (enter >= 0)
        qualifies = s.crossing & uncontrolled & turning & through
        applicable = (a.flag("in_junction") & ctx.is_code("control", "none")
                      & (ctx.is_code("maneuver", "left") | ctx.is_code("maneuver", "right"))).any(axis=2)
        return _ttr_outcome(ctx, qualifies, applicable, p.min_time_to_reach)
