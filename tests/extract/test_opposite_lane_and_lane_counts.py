"""Session 6's rules that pass `rule_sources.THE_TEST`: the lane of the opposite direction however it is qualified
or named (rules.md CVC_21650), a count of through lanes per direction of travel (dsl.md section 3), lanes separated
by a barrier (dsl.md convention 3), 'rear-ended' as the class token rear_end, a lane change into a named vehicle
(dsl.md convention 9), and the noun 'impact' read only with the verbs it came with. Each cites
the specs verbatim (checked against the copy in `tests/data/spec/`) and decides its field on a synthetic narrative
written for the test in NHTSA's formulaic style; none is copied from a bundled case.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from crashscene.extract.case_input import Report
from crashscene.extract.rule_sources import (
    FROM_CONVENTIONS,
    RULE_SOURCES,
    SESSION_6_CONVENTIONS,
    SESSION_6_DECISIONS,
    SESSION_7_DEDUCTIONS,
    SPEC_QUOTED_FROM_CASES,
)
from crashscene.extract.rules import extract_rules

SPEC = Path(__file__).resolve().parents[1] / "data" / "spec"  # copies of ../shared/spec/{dsl,rules}.md
OPPOSITE = "rules_behavior.lane_of_the_opposite_direction"
PER_DIRECTION = "rules_lanes.through_lanes_per_direction"
CASE_WRITTEN = ["rules_behavior.veering_into_a_lane", "rules_lanes.lanes_per_direction_phrases"]


def _squash(text: str) -> str:
    return " ".join(text.replace("`", "").split())


def _extract(narrative: str, off: list[str] = ()):
    return extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [],
                         off=[*CASE_WRITTEN, *off])


def _oracle(scenario) -> set[tuple[str, str]]:
    return {(entry.code, entry.actor) for entry in scenario.oracle}


# session 7's deductions (tests/extract/test_session_7_rules.py) cite the specs the same way
CITATIONS = {**{rule: quote for rule, (quote, _) in {**SPEC_QUOTED_FROM_CASES, **SESSION_7_DEDUCTIONS}.items()},
             **SESSION_6_CONVENTIONS}


@pytest.mark.parametrize("rule", sorted(CITATIONS))
def test_each_rule_cites_words_the_specs_hold(rule):
    specs = {name: _squash((SPEC / name).read_text(encoding="utf-8")) for name in ("dsl.md", "rules.md")}
    quotes = [(f"{m.group(1)}.md", q) for segment in CITATIONS[rule].split(";")
              for m in [re.match(r"\s*(dsl|rules)\.md\b", segment)] if m for q in re.findall(r'"([^"]+)"', segment)]
    assert quotes, rule
    for spec, quote in quotes:
        assert _squash(quote) in specs[spec], (rule, quote)


def test_the_record_names_the_cases_read_and_the_split_rests_on_none():
    for rule, (_, cases) in SPEC_QUOTED_FROM_CASES.items():
        assert RULE_SOURCES[rule] == cases and len(cases) >= 2 and rule not in FROM_CONVENTIONS
    for rule in SESSION_6_CONVENTIONS:
        assert RULE_SOURCES[rule] == () and rule in FROM_CONVENTIONS
    for rule, decision in SESSION_6_DECISIONS.items():
        assert rule in RULE_SOURCES and RULE_SOURCES[rule], rule  # the case-written rule keeps its sources
        for moved in re.findall(r"rules_\w+\.\w+", decision):
            assert moved in CITATIONS, moved


SOUTH_NORTH = ("The roadway had two southbound lanes, two northbound lanes and a two-way left turn lane. V1 was "
               "traveling south in the left southbound lane. V2 was traveling north in the left northbound lane. ")
EAST_WEST = ("V1 was traveling east in the eastbound lane of a two-lane, two-way road. V2 was traveling west in the "
             "westbound lane. ")

INTO_THE_OPPOSITE_LANE = [
    (SOUTH_NORTH + "As V1 accelerated, it drifted left across the turn lane and into the adjacent northbound travel "
                   "lane where it struck V2 head-on.", "ego"),
    (SOUTH_NORTH + "V1 moved left into the far-left northbound lane and struck V2 head-on.", "ego"),
    (EAST_WEST + "V2 encroached into V1's lane and struck V1 head-on.", "npc1"),
    (EAST_WEST + "V2 was in V1's travel lane when the front of V2 struck the front of V1.", "npc1"),
]


@pytest.mark.parametrize("narrative,role", INTO_THE_OPPOSITE_LANE)
def test_a_lane_of_the_opposite_direction_is_the_opposing_lane(narrative, role):
    s = _extract(narrative)
    assert s.actors[role].behavior.value == "cross_centerline"
    assert ("CVC_21650", role) in _oracle(s)
    off = _extract(narrative, off=[OPPOSITE])
    assert off.actors[role].behavior.value != "cross_centerline" and ("CVC_21650", role) not in _oracle(off)


def test_the_lane_of_a_vehicle_going_the_same_way_is_no_crossing():
    same = ("V1 was traveling east in the right eastbound lane of a four-lane divided highway. V2 was traveling "
            "east in the left eastbound lane. V2 moved into V1's lane and struck the left side of V1.")
    s = _extract(same)
    assert s.actors["npc1"].behavior.value != "cross_centerline" and not any(c == "CVC_21650" for c, _ in _oracle(s))
    own = SOUTH_NORTH + "V2 was traveling in the far-left northbound lane when V1 struck V2 head-on."
    assert _extract(own).actors["npc1"].behavior.value != "cross_centerline"


@pytest.mark.parametrize("sentence,lanes", [
    ("The road had three northbound lanes and four southbound lanes.", 7),
    ("The road had two lanes northbound and two lanes southbound.", 4),
    ("The road had two northbound through lanes and two southbound through lanes.", 4),
])
def test_a_count_of_lanes_per_direction_sums_both_directions(sentence, lanes):
    narrative = sentence + " V1 was traveling north. V2 was traveling south. The front of V2 struck the front of V1."
    assert _extract(narrative).road_network.number_of_lanes == lanes
    assert _extract(narrative, off=[PER_DIRECTION]).road_network.number_of_lanes != lanes


def test_a_divided_roadway_counts_v1_s_direction_alone():
    narrative = ("The divided highway had three northbound lanes and three southbound lanes separated by a median. "
                 "V1 was traveling north. V2 was traveling north ahead of V1. The front of V1 struck the rear of V2.")
    s = _extract(narrative)
    assert (s.road_network.number_of_ways, s.road_network.number_of_lanes) == (1, 3)


def test_lanes_separated_by_a_qualified_barrier_are_a_divided_roadway():
    narrative = ("The interstate had four northbound lanes separated from the southbound traffic-way by a positive "
                 "concrete traffic barrier. V1 was traveling north. V2 was traveling north ahead of V1. The front of "
                 "V1 struck the rear of V2.")
    off = ["rules_road.freeway_is_divided"]
    s = _extract(narrative, off=off)
    assert (s.road_network.number_of_ways, s.road_network.road_marker.value) == (1, "none")
    assert _extract(narrative, off=[*off, "rules_road.separated_by_a_barrier"]).road_network.number_of_ways == 2


def test_the_noun_impact_comes_back_only_with_the_verbs_it_was_read_with():
    # a summary sentence names the pair with the noun; the impact sentence states the contact with the formula
    narrative = ("V1 was involved in a frontal impact with the rear of V2. V1 was traveling east. V2 was traveling "
                 "east ahead of V1 and slowed. The front of V1 struck the rear of V2.")
    noun_off = ["rules_collisions.noun_impact_is_not_a_contact"]
    spec_only = _extract(narrative, off=[*noun_off, "rules_collisions.impact_formula"])
    assert [(c.striking, c.struck, c.class_.value) for c in spec_only.collisions] == [("ego", "npc1", "rear_end")]
    assert "struck" in spec_only.evidence["collisions[0]"]
    with_verbs = _extract(narrative, off=noun_off)  # the first round's reading: the noun states the contact first
    assert "frontal impact" in with_verbs.evidence["collisions[0]"]


REAR_END = "rules_collisions.rear_end_as_a_verb"
SAME_WAY = ("V1 was traveling east on a two-lane, two-way road. V2 was traveling east ahead of V1 and slowed for "
            "traffic. ")


@pytest.mark.parametrize("sentence", ["V1 rear-ended V2.", "V2 was rear-ended by V1.", "V1 rear ended V2 in the lane."])
def test_rear_ended_is_the_class_token_as_a_verb(sentence):
    off = ["rules_collisions.impact_formula"]  # the reports' other verbs, 'rear-ended' among them before the split
    s = _extract(SAME_WAY + sentence, off=off)
    assert [(c.striking, c.struck, c.striking_area.value, c.struck_area.value, c.class_.value)
            for c in s.collisions] == [("ego", "npc1", "front", "rear", "rear_end")]
    assert ("CVC_21703", "ego") in _oracle(s)  # convention 9: striking a moving vehicle ahead
    assert _extract(SAME_WAY + sentence, off=[*off, REAR_END]).collisions == []


INTO_A_VEHICLE = "rules_behavior.lane_change_into_a_vehicle"
TWO_LANES_NORTH = ("The crash occurred on a four-lane divided highway. V1 was traveling north in the right northbound "
                   "lane. V2 was traveling north in the left northbound lane. ")


@pytest.mark.parametrize("sentence", [
    "V2 changed lanes into the path of V1 and the front of V1 struck the left side of V2.",
    "V2 made an unsafe lane change into V1's lane and the right side of V2 struck the left side of V1.",
    "V2 merged into the lane of V1 and the right side of V2 struck the left side of V1.",
])
def test_a_lane_change_into_a_named_vehicle_takes_the_side_of_that_vehicle_s_lane(sentence):
    s = _extract(TWO_LANES_NORTH + sentence)
    assert s.actors["npc1"].behavior.value == "change_lane_right"
    assert s.actors["npc1"].position.relation.value == "left"
    assert ("CVC_22107", "npc1") in _oracle(s)  # convention 9: a lane change into another vehicle
    off = _extract(TWO_LANES_NORTH + sentence, off=[INTO_A_VEHICLE])
    assert off.actors["npc1"].behavior.value == "go_forward" and ("CVC_22107", "npc1") not in _oracle(off)


def test_no_side_is_guessed_when_the_lanes_are_not_stated():
    narrative = ("V1 was traveling north. V2 was traveling north. V2 changed lanes into the path of V1 and the front "
                 "of V1 struck V2.")
    assert _extract(narrative).actors["npc1"].behavior.value == "go_forward"


@pytest.mark.parametrize("sentence,expected", [
    ("V1's left side plane struck V2's right side plane.", ("ego", "npc1", "left", "right", "sideswipe")),
    ("V1's left side plane struck the back plane of V2.", ("ego", "npc1", "left", "rear", "angle")),
    ("V2's right side plane was struck by V1's left side plane.", ("ego", "npc1", "left", "right", "sideswipe")),
])
def test_the_genitive_is_the_impact_formula(sentence, expected):
    off = ["rules_collisions.possessive_and_with_its"]  # its 'with its frontal plane' stays case-written
    s = _extract(SAME_WAY + sentence, off=off)
    got = [(c.striking, c.struck, c.striking_area.value, c.struck_area.value, c.class_.value) for c in s.collisions]
    assert got == [expected]
    without = _extract(SAME_WAY + sentence, off=[*off, "rules_collisions.genitive_impact_formula"])
    assert [(c.striking, c.struck, c.striking_area.value, c.struck_area.value, c.class_.value)
            for c in without.collisions] != [expected]
