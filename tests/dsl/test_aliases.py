"""Readers accept the paper's and TARGET's human spellings and normalise them."""
from __future__ import annotations

import pytest

from crashscene.dsl import dumps, loads

TARGET_STYLE = """
Environment:
  Weather: sunny
  Time of day: daylight
Road network:
  Road type: T-intersection
  Number of ways: 2
  Number of lanes: 2
  Road marker: not mentioned
  Traffic signs: stop sign
Actors:
  Ego vehicle:
    Type: sedan
    Behavior: go forward
    Position: {Reference: stop sign, Relation: behind}
  Other actor 1:
    Type: tractor-trailer
    Behavior: turn left
    Position: {Reference: intersection, Relation: left, Heading: From left}
Oracle:
  - CVC_22450: stop_sign
    description: "V1 did not stop."
"""


def test_target_spelling_is_normalised() -> None:
    scenario = loads(TARGET_STYLE)
    assert scenario.environment.weather == "clear"
    assert scenario.environment.time_of_day == "daytime"
    assert scenario.road_network.road_type == "t_intersection"
    assert scenario.road_network.road_marker == "not_mentioned"
    assert scenario.road_network.traffic_signs == ["stop_sign"]
    assert list(scenario.actors) == ["ego", "npc1"]
    assert scenario.actors["ego"].type == "car"
    assert scenario.actors["npc1"].type == "truck"
    assert scenario.actors["npc1"].behavior == "turn_left"
    assert scenario.actors["npc1"].position.heading == "from_left"
    assert scenario.actors["ego"].position.reference == "stop_sign"


def test_compact_oracle_form() -> None:
    entry = loads(TARGET_STYLE).oracle[0]
    assert (entry.code, entry.violation, entry.actor, entry.description) == (
        "CVC_22450", "stop_sign", "ego", "V1 did not stop.")


def test_writer_emits_canonical_form() -> None:
    text = dumps(loads(TARGET_STYLE))
    assert "road_type: t_intersection" in text
    assert "position: {reference: intersection, relation: left, heading: from_left}" in text
    assert "  - code: CVC_22450\n    violation: stop_sign\n    actor: ego\n" in text
    assert loads(text) == loads(TARGET_STYLE)


@pytest.mark.parametrize(("field", "spelling", "token"), [
    ("weather", "fair", "clear"), ("weather", "Not mentioned", "not_mentioned"), ("weather", "None", "not_mentioned"),
    ("weather", "unknown", "not_mentioned"), ("time_of_day", "night", "nighttime"), ("time_of_day", "dark", "nighttime"),
    ("time_of_day", "day", "daytime"), ("road_type", "T intersection", "t_intersection"),
    ("road_type", "straight road", "straight"), ("road_type", "t-intersection", "t_intersection"),
])
def test_value_aliases(field: str, spelling: str, token: str) -> None:
    text = TARGET_STYLE.replace("Weather: sunny", f"Weather: {spelling}" if field == "weather" else "Weather: sunny")
    text = text.replace("Time of day: daylight", f"Time of day: {spelling}" if field == "time_of_day" else "Time of day: daylight")
    text = text.replace("Road type: T-intersection", f"Road type: {spelling}" if field == "road_type" else "Road type: T-intersection")
    scenario = loads(text)
    section = scenario.road_network if field == "road_type" else scenario.environment
    assert getattr(section, field) == token


@pytest.mark.parametrize(("spelling", "token"), [
    ("suv", "car"), ("pickup", "car"), ("van", "car"), ("minivan", "car"), ("utility vehicle", "car"),
    ("semi", "truck"), ("bus", "truck"), ("box truck", "truck"), ("Motorcycle", "motorcycle"),
])
def test_body_type_aliases(spelling: str, token: str) -> None:
    scenario = loads(TARGET_STYLE.replace("Type: sedan", f"Type: {spelling}"))
    assert scenario.actors["ego"].type == token
