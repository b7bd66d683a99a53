"""The deterministic review of an LLM draft: what it flags, and that golden files pass it."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.dsl import load_file
from crashscene.dsl.tokens import Behavior, TimeOfDay, Weather
from crashscene.extract.revise import oracle_conflict, prune_oracle, review, stated_speed_limits

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "ciren"
CASES = sorted(p.name for p in EXAMPLES.iterdir() if (p / "golden.yaml").is_file())


def golden(case: str):
    return load_file(EXAMPLES / case / "golden.yaml"), (EXAMPLES / case / "narrative.txt").read_text()


def paths(findings, revise_only: bool = True) -> list[str]:
    return [f.path for f in findings if f.revise or not revise_only]


@pytest.mark.parametrize("case", CASES)
def test_golden_files_raise_few_revision_findings(case: str) -> None:
    scenario, narrative = golden(case)
    worth_revising = [f for f in review(scenario, narrative) if f.revise and not f.path.startswith("evidence")]
    # the goldens themselves may trip a warning from dsl validation, never a made-up-value finding
    assert all(f.path.startswith("actors.") and "heading" in f.path or "speed_limit" in f.path
               for f in worth_revising), worth_revising


def test_unmentioned_weather_and_time_are_flagged() -> None:
    scenario, narrative = golden("100237")
    env = scenario.environment.model_copy(update={"weather": Weather.RAINY, "time_of_day": TimeOfDay.DUSK})
    found = review(scenario.model_copy(update={"environment": env}), narrative)
    assert {"environment.weather", "environment.time_of_day"} <= set(paths(found))


def test_speed_limit_must_match_the_stated_one() -> None:
    scenario, narrative = golden("3-C1-2017-001")  # "posted speed limit of 113 km/h (70 mph)"
    road = scenario.road_network.model_copy(update={"speed_limit_mph": 65})
    found = review(scenario.model_copy(update={"road_network": road}), narrative)
    assert any(f.path == "road_network.speed_limit_mph" and "70 mph" in f.message for f in found)


def test_sketch_speed_limit_counts_as_stated() -> None:
    scenario, narrative = golden("103378")  # the limit is on the sketch only
    road = scenario.road_network.model_copy(update={"speed_limit_mph": None})
    found = review(scenario.model_copy(update={"road_network": road}), narrative, ["speed limit 45 mph (sketch:ocr)"])
    assert any(f.path == "road_network.speed_limit_mph" and "sketch" in f.message for f in found)


def test_oracle_must_follow_the_behaviour() -> None:
    scenario, narrative = golden("103378")  # V1 crossed a double solid centre line
    found = review(scenario.model_copy(update={"oracle": []}), narrative)
    messages = " ".join(f.message for f in found if f.path == "oracle")
    assert "CVC_21650" in messages
    ego = scenario.actors["ego"].model_copy(update={"behavior": Behavior.U_TURN})
    found = review(scenario.model_copy(update={"actors": {**scenario.actors, "ego": ego}}), narrative)
    assert "actors.ego.behavior" in paths(found)


def test_invented_quote_is_a_note_not_a_revision() -> None:
    scenario, narrative = golden("103378")
    evidence = {"environment.weather": "the heavy rain had flooded the northbound lane near the bridge"}
    found = review(scenario.model_copy(update={"evidence": evidence}), narrative)
    quote = [f for f in found if f.path == "evidence.environment.weather"]
    assert quote and not quote[0].revise


@pytest.mark.parametrize("text, limits", [
    ("There is a posted speed limit of 113 km/h (70 mph).", [70]),
    ("The speed limit is 64 km/hr (40 mph)", [40]),
    ("speed limit 72 kmph", [45]),
    ("no speed limit stated", []),
])
def test_stated_speed_limits(text: str, limits: list[int]) -> None:
    assert stated_speed_limits(text) == limits


@pytest.mark.parametrize("case", CASES)
def test_golden_oracles_hold_in_their_scenarios(case: str) -> None:
    scenario, _ = golden(case)
    assert [oracle_conflict(scenario, entry) for entry in scenario.oracle] == [None] * len(scenario.oracle)


def test_impossible_oracle_entries_are_flagged_and_pruned() -> None:
    from crashscene.dsl import validate
    from crashscene.dsl.model import OracleEntry

    scenario, narrative = golden("103378")  # straight road, no signs but the speed limit, nobody turns
    spam = [OracleEntry(code=code, violation=token, actor="ego", description="")
            for code, token in (("CVC_21802", "stop_sign_yield"), ("CVC_21801", "left_turn_yield"))]
    noisy = scenario.model_copy(update={"oracle": spam + list(scenario.oracle),
                                        "evidence": {"oracle[2]": "V1 drifted across the centerline"}})
    found = [f for f in review(noisy, narrative) if f.path.startswith("oracle[")]
    assert [f.path for f in found] == ["oracle[0].code", "oracle[1].code"]
    assert "needs a stop_sign" in found[0].message and "junction" in found[1].message
    pruned, dropped = prune_oracle(noisy)
    assert [e.code for e in pruned.oracle] == ["CVC_21650", "CVC_21460"] and len(dropped) == 2
    assert pruned.evidence == {"oracle[0]": "V1 drifted across the centerline"}
    validate(pruned)


def test_missing_rear_end_code_is_derived_from_the_crash_sequence() -> None:
    scenario, narrative = golden("120013")  # V1 drove into the rear of the stopped V2
    found = review(scenario.model_copy(update={"oracle": []}), narrative)
    assert any(f.path == "oracle" and "CVC_22350" in f.message and "stopped" in f.message for f in found)


def test_missing_stop_sign_code_for_a_stop_controlled_actor_in_an_angle_contact() -> None:
    scenario, narrative = golden("117021")  # V1 from its stop sign, struck on the right by V2
    found = review(scenario.model_copy(update={"oracle": []}), narrative)
    assert any("CVC_21802" in f.message and f.message.startswith("ego") for f in found)


def test_crash_sequence_is_checked_against_the_impact_sentences() -> None:
    scenario, narrative = golden("100237")  # the front of V2 struck the right side of V1
    contact = scenario.collisions[0]
    swapped = contact.model_copy(update={"striking": contact.struck, "struck": contact.striking})
    found = review(scenario.model_copy(update={"collisions": [swapped]}), narrative)
    assert any(f.path == "collisions[0]" and "front of V2 struck the right side of V1" in f.message for f in found)
    found = review(scenario.model_copy(update={"collisions": []}), narrative)
    assert any(f.path == "collisions" and "describe 1" in f.message for f in found)


# ---------------------------------------------------------------- convention 9 beyond behaviours and rear ends

def _drop_oracle(scenario):
    evidence = {key: quote for key, quote in scenario.evidence.items() if not key.startswith("oracle")}
    return scenario.model_copy(update={"oracle": [], "evidence": evidence})


def _synthetic(narrative: str):
    from crashscene.extract.case_input import Report
    from crashscene.extract.rules import extract_rules

    return extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), [])


def test_an_overtake_into_a_contact_needs_the_wrong_side_code() -> None:
    scenario, narrative = golden("3-C2-2017-004")  # V1 passed through the opposing lane
    found = [f.message for f in review(_drop_oracle(scenario), narrative) if f.path == "oracle"]
    assert any("overtakes" in m and "CVC_21650" in m for m in found), found


def test_a_left_turn_into_an_oncoming_actor_needs_the_left_turn_code() -> None:
    scenario, narrative = golden("121520")
    assert any("turns left across the oncoming" in f.message and "CVC_21801" in f.message
               for f in review(_drop_oracle(scenario), narrative))
    assert not any("CVC_21801" in f.message for f in review(scenario, narrative))


UNCONTROLLED = ("V1 was traveling east on a two-lane, two-way road approaching a four-leg intersection without "
                "traffic controls. V2 was traveling north on the intersecting road. V2 failed to yield and entered "
                "the intersection. The front of V2 struck the left side of V1.")


def test_crossing_at_a_junction_without_devices_needs_the_right_of_way_code() -> None:
    scenario = _synthetic(UNCONTROLLED)
    assert {(e.code, e.actor) for e in scenario.oracle} == {("CVC_21800", "npc1")}
    assert not any("CVC_21800" in f.message for f in review(scenario, UNCONTROLLED))
    found = review(_drop_oracle(scenario), UNCONTROLLED)
    assert any(f.path == "oracle" and "CVC_21800" in f.message and "without devices" in f.message for f in found)


def test_a_stated_red_light_needs_its_code_for_the_actor_it_is_about() -> None:
    narrative = UNCONTROLLED.replace("without traffic controls", "controlled by traffic signals").replace(
        "V2 failed to yield and entered the intersection", "The driver of V2 ran the red light")
    scenario = _synthetic(narrative)
    assert ("CVC_21453", "npc1") in {(e.code, e.actor) for e in scenario.oracle}
    found = [f.message for f in review(_drop_oracle(scenario), narrative) if f.path == "oracle"]
    assert any("states red_light for npc1" in m and "CVC_21453" in m for m in found), found
