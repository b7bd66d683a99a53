"""Rule-based extraction: every bundled case validates; field checks where the narrative is unambiguous."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.dsl import dumps, validate, validate_text
from crashscene.extract.case_input import Report, load_report
from crashscene.extract.rules import extract_rules
from crashscene.extract.sketch import SketchFact

CIREN = Path(__file__).resolve().parents[2] / "examples" / "ciren"
CASES = sorted(p.name for p in CIREN.iterdir() if p.is_dir())


def _extract(case: str, facts: list[SketchFact] | None = None):
    return extract_rules(load_report(CIREN / case), facts or [])


def _text(narrative: str, facts: list[SketchFact] | None = None):
    return extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), facts or [])


@pytest.mark.parametrize("case", CASES)
def test_every_case_gives_a_valid_scenario(case):
    scenario = _extract(case)
    warnings = validate(scenario)  # raises on errors
    # a wrong-way driver on a divided roadway is oncoming traffic on a one-way carriageway, as in the golden file
    assert {w.message for w in warnings} <= {"oncoming traffic on a one-way roadway"}
    validate_text(dumps(scenario))  # the written file validates too
    assert scenario.actors["ego"].label == "V1"
    assert [a.label for a in scenario.npcs.values()] == [f"V{i}" for i in range(2, len(scenario.actors) + 1)]
    assert scenario.scenario_id == f"CIREN-{case}"
    assert scenario.evidence  # decisions carry their quotes
    assert _extract(case) == scenario  # deterministic


def test_head_on_after_drifting_over_the_centerline():
    s = _extract("103378")
    assert (s.environment.weather.value, s.environment.time_of_day.value) == ("clear", "nighttime")
    road = s.road_network
    assert (road.road_type.value, road.number_of_ways, road.number_of_lanes) == ("straight", 2, 2)
    assert s.actors["ego"].behavior.value == "cross_centerline"
    npc = s.actors["npc1"].position
    assert (npc.reference, npc.relation.value, npc.heading.value) == ("ego", "front", "opposite_direction")
    assert ("CVC_21650", "ego") in {(o.code, o.actor) for o in s.oracle}
    assert "centerline" in s.evidence["actors.ego.behavior"]


def test_crossing_traffic_from_the_right_at_a_4_leg_intersection():
    s = _extract("100237")
    assert s.road_network.road_type.value == "intersection"
    assert (s.environment.weather.value, s.environment.road_surface.value) == ("cloudy", "dry")
    npc = s.actors["npc1"]
    assert (npc.behavior.value, npc.position.relation.value, npc.position.heading.value) == \
        ("go_forward", "right", "from_right")


def test_signalised_left_turn_across_oncoming_traffic():
    s = _extract("3-C4-2018-012")
    road = s.road_network
    assert [x.value for x in road.traffic_signs] == ["traffic_light", "speed_limit_sign"]
    assert (road.speed_limit_mph, road.number_of_lanes) == (45, 4)  # turn lanes are not through lanes
    assert s.actors["ego"].position.reference == "traffic_light"
    assert s.actors["npc1"].behavior.value == "turn_left"
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_21801", "npc1")]


def test_stopped_waiting_to_turn_and_struck_from_behind():
    s = _extract("3-C2-2018-008")
    assert (s.environment.weather.value, s.environment.road_surface.value) == ("rainy", "wet")
    assert s.road_network.road_type.value == "t_intersection"
    assert s.actors["ego"].behavior.value == "stop"
    npc = s.actors["npc1"].position
    assert (npc.relation.value, npc.heading.value) == ("behind", "same_direction")
    assert ("CVC_22350", "npc1") in {(o.code, o.actor) for o in s.oracle}


def test_single_vehicle_on_a_divided_interstate():
    s = _extract("3-C5-2017-002")
    assert list(s.actors) == ["ego"]
    road = s.road_network
    assert (road.number_of_ways, road.number_of_lanes, road.road_marker.value) == (1, 4, "none")
    assert s.oracle == []


@pytest.mark.parametrize("v2_direction, side", [("north", "right"), ("south", "left")])
def test_cross_traffic_side_follows_travel_directions(v2_direction, side):
    s = _text("Vehicle one (V1) was traveling east in the eastbound lane of a two-lane, two-way road and was "
              "approaching a 4-leg intersection. Vehicle two (V2) was traveling " + v2_direction +
              " on the intersecting road. It was daylight and the sky was clear. The front of V2 struck V1.")
    npc = s.actors["npc1"].position
    assert (npc.reference, npc.relation.value, npc.heading.value) == ("intersection", side, f"from_{side}")
    expected = {("CVC_21800", "ego")} if side == "right" else {("CVC_21800", "npc1")}
    assert {(o.code, o.actor) for o in s.oracle} == expected  # the vehicle on the right has priority


def test_stop_sign_violation_and_the_stop_sign_reference():
    s = _text("V1 was traveling north on a two-lane, two-way road approaching a 4-leg intersection. V2 was "
              "traveling west and was controlled by a stop sign. The driver of V2 failed to stop at the stop sign "
              "and entered the intersection. The front of V1 struck the left side of V2.")
    assert [x.value for x in s.road_network.traffic_signs] == ["stop_sign"]
    npc = s.actors["npc1"].position
    assert (npc.reference, npc.relation.value, npc.heading.value) == ("stop_sign", "right", "from_right")
    assert s.actors["ego"].position.reference == "intersection"
    assert {(o.code, o.actor) for o in s.oracle} == {("CVC_22450", "npc1")}


def test_sketch_facts_fill_what_the_text_does_not_say():
    narrative = ("V1 was traveling south in the southbound lane of a two-lane, two-way road. V2 was traveling "
                 "north in the northbound lane. V1 crossed the centerline and struck V2.")
    plain = _text(narrative)
    assert plain.road_network.speed_limit_mph is None and plain.road_network.road_marker.value == "not_mentioned"
    facts = [SketchFact(text="speed limit 45 mph", confidence=0.99),
             SketchFact(text="double solid line drawn", source="sketch:lines", confidence=0.8)]
    s = _text(narrative, facts)
    assert s.road_network.speed_limit_mph == 45
    assert s.road_network.road_marker.value == "double_solid_line"
    assert {(o.code, o.actor) for o in s.oracle} == {("CVC_21650", "ego"), ("CVC_21460", "ego")}
    assert s.evidence["road_network.speed_limit_mph"] == "sketch: speed limit 45 mph"


def test_text_speed_limit_wins_over_the_sketch():
    s = _text("V1 was traveling east on a two-lane road with a posted speed limit of 89 km/h (55 mph). The front of "
              "V1 struck a tree.", [SketchFact(text="speed limit 50 mph")])
    assert s.road_network.speed_limit_mph == 55


@pytest.mark.slow
def test_with_real_sketch_facts(tmp_path, monkeypatch):
    from crashscene.extract.sketch import sketch_facts

    monkeypatch.setenv("CRASHSCENE_CACHE_DIR", str(tmp_path))
    report = load_report(CIREN / "108812")
    s = extract_rules(report, sketch_facts(report.sketch))
    assert s.road_network.road_marker.value == "broken_line"  # the text is silent; the sketch draws it
    assert s.evidence["road_network.road_marker"] == "sketch: broken line drawn"


def test_stated_travel_speeds_are_kept_and_speeding_is_a_violation():
    s = _text("V1 was traveling north in the northbound lane of a two-lane, two-way road with a posted speed limit of "
              "56 km/h (35 mph). V2 was traveling south at approximately 97 km/h (60 mph) and was speeding. V2 crossed "
              "the centerline and the front of V2 struck the front of V1.")
    assert s.actors["npc1"].speed_mph == 60
    assert s.actors["ego"].speed_mph is None
    assert s.road_network.speed_limit_mph == 35
    assert {("CVC_22349", "npc1"), ("CVC_21650", "npc1")} <= {(o.code, o.actor) for o in s.oracle}


def test_red_light_runner_at_a_signalised_intersection():
    s = _text("V1 was traveling east approaching a 4-leg intersection controlled by traffic signals. V2 was traveling "
              "south on the intersecting road. The driver of V2 failed to stop for the red light and entered the "
              "intersection. The front of V2 struck the left side of V1.")
    assert s.road_network.road_type.value == "intersection"
    assert s.actors["ego"].position.reference == "traffic_light"
    npc = s.actors["npc1"].position
    assert (npc.reference, npc.relation.value, npc.heading.value) == ("traffic_light", "left", "from_left")
    assert ("CVC_21453", "npc1") in {(o.code, o.actor) for o in s.oracle}


def test_leaving_a_driveway_into_traffic():
    s = _text("V1 was traveling west in the westbound lane of a two-lane, two-way road. V2 was exiting a private "
              "driveway on the north side of the road and was turning left to travel east. It was daylight. "
              "The front of V1 struck the left side of V2.")
    assert s.road_network.road_type.value == "t_intersection"
    assert s.actors["npc1"].behavior.value == "turn_left"
    assert ("CVC_21804", "npc1") in {(o.code, o.actor) for o in s.oracle}


def test_stopped_at_the_sign_then_proceeded_is_go_forward():
    s = _text("Vehicle #1 (V1), a 2010 Toyota Camry, was traveling south on a two-lane, two-way residential street "
              "and was stopped at a stop sign at a four-leg intersection. Vehicle #2 (V2), a 2008 Honda CR-V, was "
              "traveling east on the intersecting road. It was daylight and the weather was clear. V1 then proceeded "
              "into the intersection and the front of V2 struck the left side of V1.")
    assert s.actors["ego"].behavior.value == "go_forward"
    assert s.actors["ego"].position.reference == "stop_sign"
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_21802", "ego")]


def test_location_sentence_box_truck_and_red_light():
    s = _text("This crash occurred at a four-leg intersection controlled by a traffic signal. Vehicle #1, a 2003 Ford "
              "Taurus, was eastbound in the outside lane. Vehicle #2, a 2007 Ford F-350 box truck, was northbound. The "
              "driver of V2 ran the red light and the front of V2 struck the right side of V1. Conditions were "
              "daylight, clear and dry.")
    assert s.road_network.road_type.value == "intersection"
    assert (s.actors["npc1"].type.value, s.actors["npc1"].position.heading.value) == ("truck", "from_right")
    assert ("CVC_21453", "npc1") in {(o.code, o.actor) for o in s.oracle}


def test_parked_vehicle_struck_from_behind():
    s = _text("The case vehicle (V1) was traveling south on a residential street at night. V1 drifted to the right and "
              "struck the rear of a parked 2001 Toyota Corolla (V2) that was parked along the west curb.")
    npc = s.actors["npc1"]
    assert (npc.behavior.value, npc.position.relation.value, npc.position.heading.value) == \
        ("static", "right", "same_direction")
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_22350", "ego")]


def test_lane_change_on_a_one_way_street():
    s = _text("V1 was traveling west in lane two of a three-lane one-way street. V2 was traveling west in lane three "
              "to the left of V1. The driver of V2 changed lanes to the right and the right side of V2 struck the left "
              "side of V1. It was foggy in the early morning darkness.")
    road = s.road_network
    assert (road.number_of_ways, road.number_of_lanes) == (1, 3)
    assert (s.environment.weather.value, s.environment.time_of_day.value) == ("foggy", "nighttime")
    npc = s.actors["npc1"]
    assert (npc.behavior.value, npc.position.relation.value) == ("change_lane_right", "left")
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_22107", "npc1")]


def test_left_turn_into_a_driveway_across_oncoming_traffic():
    s = _text("The crash occurred during daylight on a two-lane, undivided, two-way roadway with a posted speed limit "
              "of 56 km/h (35 mph). Vehicle 1, a 2015 Honda Civic, was traveling north in the northbound lane. Vehicle "
              "2, a 2010 Ford Escape, was traveling south and began a left turn into a private driveway on the east "
              "side of the road. The front of Vehicle 1 struck the right side of Vehicle 2.")
    assert s.road_network.road_type.value == "t_intersection"
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_21801", "npc1")]


def test_odd_lane_total_on_a_divided_road_is_one_carriageway():
    s = _text("Vehicle 1 was traveling west in the second lane of a three-lane divided interstate. Vehicle 2 was "
              "traveling west in the same lane ahead of Vehicle 1 and slowed for congestion. The front of Vehicle 1 "
              "struck the rear of Vehicle 2.")
    assert (s.road_network.number_of_ways, s.road_network.number_of_lanes) == (1, 3)
    assert s.actors["npc1"].behavior.value == "decelerate"
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_21703", "ego")]


def test_motorcycle_losing_control_on_a_curve():
    s = _text("The motorcycle (V1), a 2012 Harley-Davidson, was traveling east on a two-lane rural road negotiating a "
              "right curve at night. The rider lost control and the motorcycle departed the left side of the roadway "
              "and struck a fence.")
    assert (s.actors["ego"].type.value, s.actors["ego"].behavior.value) == ("motorcycle", "lose_control")
    assert (s.road_network.road_type.value, s.road_network.curve_direction.value) == ("curve", "right")


def test_stated_failure_to_yield_wins_at_an_uncontrolled_junction():
    s = _text("V1 was traveling east on a two-lane, two-way road approaching a 4-leg intersection without traffic "
              "controls. V2 was traveling north on the intersecting road. The driver of V2 failed to yield and the "
              "front of V1 struck the left side of V2.")
    assert s.actors["npc1"].position.heading.value == "from_right"
    assert [(o.code, o.actor) for o in s.oracle] == [("CVC_21800", "npc1")]
