"""Session 7's rules (issue 11), each on synthetic narratives written for the test in NHTSA's formulaic style,
none copied from a bundled case: places along one lane that a chain of rear-end contacts entails, no lane change
charged into a vehicle out of control, the drawn centre line between the road's edges and along a curve, a move into
another lane of the vehicle's own direction (rule_sources.SESSION_7_DEDUCTIONS; their citations are checked against
the specs with the other sessions' in tests/extract/test_opposite_lane_and_lane_counts.py).
"""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.extract.case_input import Report
from crashscene.extract.rule_sources import (
    DEDUCED_FROM_THE_SPECS,
    FROM_CONVENTIONS,
    RULE_SOURCES,
    SESSION_7_DEDUCTIONS,
)
from crashscene.extract.rules import extract_rules

IN_ORDER = "rules_positions.struck_in_the_order_of_their_positions"


def _relations(narrative: str, off: list[str] = ()) -> dict[str, str]:
    scenario = extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [], off=off)
    return {role: actor.position.relation.value for role, actor in scenario.actors.items() if role != "ego"}


def test_a_deduction_records_the_cases_it_was_written_for():
    for rule, (_, cases) in SESSION_7_DEDUCTIONS.items():
        assert RULE_SOURCES[rule] == cases and cases and rule in DEDUCED_FROM_THE_SPECS
        assert rule not in FROM_CONVENTIONS  # held out on its cases like a case-written rule


# V3 strikes V2 and then V1, all keeping the right lane: V2, struck first, is behind V1
THREE = ("The crash occurred on a straight, three-lane, one-way road. V1, V2 and V3 were traveling north in the right "
         "lane. V1 and V2 slowed for traffic. V3 did not slow and struck the rear of V2 with its front (Event 1). V3 "
         "continued north and struck the rear of V1 with its front (Event 2).")
# other labels, four vehicles: V4 strikes V3, V2, then V1
FOUR = ("The crash occurred on a straight, two-lane, one-way road. V1, V2, V3 and V4 were traveling east in the left "
        "lane. V1, V2 and V3 slowed for traffic. V4 did not slow and its front struck the rear of V3 (Event 1). V4 "
        "then struck the rear of V2 (Event 2). V4 then struck the rear of V1 (Event 3).")
# V2 strikes V1 first, then V3: V3 is ahead of V1 (the default, kept)
AHEAD = ("The crash occurred on a straight, two-lane, one-way road. V1, V2 and V3 were traveling south in the right "
         "lane. V1 and V3 slowed for traffic. V2 did not slow and struck the rear of V1 (Event 1). V2 then struck "
         "the rear of V3 (Event 2).")


@pytest.mark.parametrize("narrative, expected, without_the_rule", [
    (THREE, {"npc1": "behind", "npc2": "behind"}, {"npc1": "front", "npc2": "behind"}),
    (FOUR, {"npc1": "behind", "npc2": "behind", "npc3": "behind"},
     {"npc1": "front", "npc2": "front", "npc3": "behind"}),
    (AHEAD, {"npc1": "behind", "npc2": "front"}, {"npc1": "behind", "npc2": "front"}),
])
def test_a_striker_keeping_its_lane_meets_the_vehicles_in_the_order_of_their_positions(narrative, expected,
                                                                                       without_the_rule):
    assert _relations(narrative) == expected
    assert _relations(narrative, off=[IN_ORDER]) == without_the_rule


def test_the_order_a_striker_meets_the_vehicles_in_places_them():
    from crashscene.extract.rules_positions import order_along_one_lane, struck_in_turn

    chain = [("V4", "V3"), ("V4", "V3"), ("V4", "V2"), ("V1", "V5"), ("V4", "V1")]
    assert struck_in_turn(chain) == {"V4": ["V3", "V2", "V1"], "V1": ["V5"]}
    closure = order_along_one_lane(chain)
    assert {("V4", "V3"), ("V3", "V2"), ("V2", "V1"), ("V3", "V1"), ("V4", "V5"), ("V2", "V5")} <= closure
    # struck again after another one: behind and ahead of it at once
    assert struck_in_turn([("V3", "V2"), ("V3", "V1"), ("V3", "V2")]) == {"V3": ["V2", "V1", "V2"]}
    assert order_along_one_lane([("V3", "V2"), ("V3", "V1"), ("V3", "V2")]) is None


def test_a_position_the_text_states_is_kept():
    stated = THREE.replace("V1 and V2 slowed for traffic.", "V1 and V2 slowed for traffic; V2 was ahead of V1.")
    assert stated != THREE and _relations(stated)["npc1"] == "front"


@pytest.mark.parametrize("change", [
    # the striker changes lanes between the contacts: it does not keep one lane
    ("V3 did not slow and struck", "V3 changed lanes to the left and struck"),
    # the vehicles struck are in stated different lanes
    ("V1, V2 and V3 were traveling north in the right lane.",
     "V1 was traveling north in the left northbound lane. V2 was traveling north in the right northbound lane. V3 "
     "was traveling north in the right northbound lane."),
])
def test_no_place_is_deduced_off_one_lane(change):
    narrative = THREE.replace(*change)
    assert narrative != THREE
    assert _relations(narrative)["npc1"] != "behind"
    assert _relations(narrative) == _relations(narrative, off=[IN_ORDER])


OUT_OF_CONTROL = "rules_oracle.no_lane_change_into_a_vehicle_out_of_control"
MERGE = ("The crash occurred on a four-lane divided highway. V1 was traveling north in the right northbound lane. V2 "
         "was traveling north on the entrance ramp and changed lanes to the left to merge onto the highway. ")
SPUN_INTO_THE_RAMP = "The roadway was wet and V1 lost control, rotated clockwise and entered the acceleration lane. "
V2_STRUCK_V1 = "The front of V2 struck the left side of V1."


def _oracle(narrative: str, off: list[str] = ()) -> set[tuple[str, str]]:
    scenario = extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [], off=off)
    return {(entry.code, entry.actor) for entry in scenario.oracle}


def test_a_lane_changer_met_only_by_a_vehicle_out_of_control_is_not_charged():
    narrative = MERGE + SPUN_INTO_THE_RAMP + V2_STRUCK_V1
    assert _oracle(narrative) == {("CVC_22350", "ego")}
    assert _oracle(narrative, off=[OUT_OF_CONTROL]) == {("CVC_22350", "ego"), ("CVC_22107", "npc1")}


@pytest.mark.parametrize("narrative", [
    MERGE + V2_STRUCK_V1,  # V1 under control: V2 merged into it
    # V2 also strikes V3, under control, in the lane it moved into
    MERGE.replace("V2 was", "V3 was traveling north in the right northbound lane ahead of V1. V2 was")
    + SPUN_INTO_THE_RAMP + V2_STRUCK_V1 + " V2 then struck the rear of V3.",
    MERGE + SPUN_INTO_THE_RAMP,  # no contact stated: the convention's code stays
])
def test_a_lane_changer_meeting_a_vehicle_under_control_is_charged(narrative):
    assert ("CVC_22107", "npc1") in _oracle(narrative)


BETWEEN_THE_EDGES = "rules_road.a_centre_line_lies_between_the_edges"
TWO_WAY = ("V1 was traveling east in the eastbound lane of a two-lane, two-way road. V2 was traveling west in the "
           "westbound lane. V1 crossed the centerline and the front of V1 struck the front of V2.")


def test_a_double_line_drawn_only_at_a_road_edge_is_no_centre_line():
    from crashscene.extract.sketch import EDGE_ONLY, SketchFact

    facts = [SketchFact(text="double solid line drawn", source="sketch:lines"),
             SketchFact(text=EDGE_ONLY, source="sketch:lines")]
    report = Report(case_id="t", narrative=TWO_WAY, source=Path("t.txt"))
    on, off = extract_rules(report, facts), extract_rules(report, facts, off=[BETWEEN_THE_EDGES])
    assert on.road_network.road_marker.value == "not_mentioned"
    assert {e.code for e in on.oracle} == {"CVC_21650"}
    assert off.road_network.road_marker.value == "double_solid_line"
    assert {e.code for e in off.oracle} == {"CVC_21650", "CVC_21460"}
    # a double line with drawn road on both sides stays the centre line
    assert extract_rules(report, facts[:1]).road_network.road_marker.value == "double_solid_line"


OWN_DIRECTION = "rules_behavior.into_another_lane_of_its_direction"
VEERING = "rules_behavior.veering_into_a_lane"  # the reports' verbs, off: the lane decides, not the verb
THREE_LANES_EAST = ("The crash occurred on a six-lane divided freeway. V1 was traveling east in the middle eastbound "
                    "lane. V2 was traveling east in the right eastbound lane. ")


@pytest.mark.parametrize("sentence, behavior", [
    ("V1 swung into the right eastbound lane and the front of V2 struck the right side of V1.", "change_lane_right"),
    ("V1 entered the left eastbound lane and struck the guardrail.", "change_lane_left"),
    ("V1 went into the rightmost eastbound travel lane, where the front of V2 struck V1.", "change_lane_right"),
])
def test_going_into_another_lane_of_its_direction_is_a_lane_change(sentence, behavior):
    narrative = THREE_LANES_EAST + sentence
    scenario = extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [], off=[VEERING])
    assert scenario.actors["ego"].behavior.value == behavior
    off = extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [],
                        off=[VEERING, OWN_DIRECTION])
    assert off.actors["ego"].behavior.value == "go_forward"


@pytest.mark.parametrize("narrative", [
    THREE_LANES_EAST + "V1 stayed in the middle eastbound lane and V2 struck the right side of V1.",  # its own lane
    # its own lane is not stated
    "V1 was traveling east on a divided freeway. V1 moved into the left eastbound lane and struck V2.",
])
def test_no_lane_change_without_two_stated_lanes_of_one_direction(narrative):
    scenario = extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [], off=[VEERING])
    assert not scenario.actors["ego"].behavior.value.startswith("change_lane")


CURVED = "rules_road.a_curved_centre_line_in_short_runs"


def test_a_double_line_drawn_along_a_curve_is_the_centre_line():
    from crashscene.extract.sketch import CURVED_DOUBLE, EDGE_ONLY, SketchFact

    report = Report(case_id="t", narrative=TWO_WAY, source=Path("t.txt"))
    curved = [SketchFact(text=CURVED_DOUBLE, source="sketch:lines")]
    assert extract_rules(report, curved).road_network.road_marker.value == "double_solid_line"
    assert {e.code for e in extract_rules(report, curved).oracle} == {"CVC_21650", "CVC_21460"}
    assert extract_rules(report, curved, off=[CURVED]).road_network.road_marker.value == "not_mentioned"
    # drawn only at a road edge: no centre line
    edge = curved + [SketchFact(text=EDGE_ONLY, source="sketch:lines")]
    assert extract_rules(report, edge).road_network.road_marker.value == "not_mentioned"


def test_the_llm_review_flags_places_the_crash_sequence_contradicts():
    from crashscene.dsl.tokens import Relation
    from crashscene.extract.revise import review

    scenario = extract_rules(Report(case_id="t", narrative=THREE, source=Path("t.txt")), [])
    assert not [f for f in review(scenario, THREE) if f.path.endswith("position.relation")]
    npc1 = scenario.actors["npc1"]
    ahead = npc1.model_copy(update={"position": npc1.position.model_copy(update={"relation": Relation.FRONT})})
    draft = scenario.model_copy(update={"actors": {**scenario.actors, "npc1": ahead}})
    found = [f for f in review(draft, THREE) if f.path == "actors.npc1.position.relation"]
    assert len(found) == 1 and "place it behind" in found[0].message
