"""CVC 21804: leaving a driveway (an uncontrolled T stem) into the path of through traffic.

The through road runs east-west, the driveway joins it from the south at x = 0
(lanes 3.5 m, junction box |x|, |y| < 7 m): npc1 comes north out of the
driveway and turns onto the road; the ego drives east along it.
"""
from __future__ import annotations

import pytest

from crashscene.dsl import loads
from tests.monitor.builders import tables
from tests.monitor.test_right_of_way import eastbound, junction_columns, northbound

T_JUNCTION = """\
dsl_version: 1
summary: "npc1 pulls out of a driveway in front of the ego"
environment: {{weather: clear, time_of_day: daytime, road_surface: dry}}
road_network: {{road_type: {road_type}, number_of_ways: 2, number_of_lanes: 2, road_marker: broken_line,
               traffic_signs: []}}
actors:
  ego: {{type: car, behavior: go_forward, position: {{reference: intersection, relation: behind}}}}
  npc1: {{type: car, behavior: turn_right, position: {{reference: intersection, relation: right,
          heading: from_right}}}}
oracle:
  - {{code: CVC_21804, violation: driveway_yield, actor: npc1}}
"""


def scenario(road_type: str = "t_intersection"):
    return loads(T_JUNCTION.format(road_type=road_type))


def pull_out(ego_x0: float, control: str = "none") -> dict:
    return {"ego": eastbound(ego_x0, 10.0),
            "npc1": junction_columns(northbound(23.5, 10.0), control, maneuver="right", axis="y")}


def test_pulling_out_in_front_of_close_through_traffic_is_violated(check):
    row = check(tables(pull_out(47.0)), "CVC_21804", "npc1", scenario())
    assert row["verdict"] == "violated" and 2.5 < row["measured"] < 3.0
    assert check(tables(pull_out(47.0)), "CVC_21804", "ego", scenario())["verdict"] == "not_applicable"


def test_pulling_out_with_enough_time_is_satisfied(check):
    row = check(tables(pull_out(52.0)), "CVC_21804", "npc1", scenario())
    assert row["verdict"] == "satisfied" and 3.0 < row["measured"] < 3.5


@pytest.mark.parametrize("road_type", ["intersection", "straight"])
def test_only_a_t_junction_has_a_driveway(check, road_type):
    assert check(tables(pull_out(47.0)), "CVC_21804", "npc1", scenario(road_type))["verdict"] == "not_applicable"


def test_a_stop_controlled_stem_is_cvc_21802s_business(check):
    actors = pull_out(47.0, control="stop")
    assert check(tables(actors), "CVC_21804", "npc1", scenario())["verdict"] == "not_applicable"
    assert check(tables(actors), "CVC_21802", "npc1", scenario())["verdict"] == "violated"


def test_listed_by_the_rules_command():
    from typer.testing import CliRunner

    from crashscene.cli import app

    out = CliRunner().invoke(app, ["rules"]).output
    assert "CVC_21804" in out and "driveway_yield" in out
