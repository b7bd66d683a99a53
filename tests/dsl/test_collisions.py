"""The crash sequence (`collisions`, dsl.md sections 2-5): reading, writing, schema and validation."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.dsl import DslError, dumps, loads, validate_file
from crashscene.dsl.schema import json_schema
from crashscene.dsl.tokens import CollisionClass, ImpactArea, areas_fit_class
from tests.conftest import EXAMPLES

GOLDEN = (EXAMPLES / "100237" / "golden.yaml").read_text(encoding="utf-8")
CONTACT = "  - {striking: npc1, struck: ego, striking_area: front, struck_area: right, class: angle}"


def _with_collisions(block: str) -> str:
    head, _, tail = GOLDEN.partition("collisions:\n" + CONTACT + "\n")
    assert tail, "the 100237 golden file carries one contact"
    return head + block + tail


def _validate(text: str, tmp_path: Path):
    path = tmp_path / "scenario.yaml"
    path.write_text(text, encoding="utf-8")
    return validate_file(path)


def test_golden_contact_is_read_as_tokens() -> None:
    [contact] = loads(GOLDEN).collisions
    assert (contact.striking, contact.struck) == ("npc1", "ego")
    assert (contact.striking_area, contact.struck_area) == (ImpactArea.FRONT, ImpactArea.RIGHT)
    assert contact.class_ == CollisionClass.ANGLE


def test_absent_empty_and_written_stay_distinct_through_a_round_trip() -> None:
    absent = loads(_with_collisions(""))
    empty = loads(_with_collisions("collisions: []\n"))
    assert absent.collisions is None and "\ncollisions:" not in dumps(absent)
    assert empty.collisions == [] and "collisions: []\n" in dumps(empty)
    assert dumps(loads(GOLDEN)) == GOLDEN


def test_human_spellings_are_normalised() -> None:
    text = _with_collisions("Crash sequence:\n  - {Striking actor: Other actor 1, struck: Ego vehicle, "
                            "striking_area: Frontal plane, struck_area: right side, class: T-bone}\n")
    [contact] = loads(text).collisions
    assert (contact.striking, contact.struck, contact.striking_area, contact.struck_area, contact.class_) == (
        "npc1", "ego", "front", "right", "angle")


def test_bad_area_names_path_line_and_allowed(tmp_path: Path) -> None:
    text = GOLDEN.replace("struck_area: right", "struck_area: roof")
    with pytest.raises(DslError) as info:
        _validate(text, tmp_path)
    [diag] = info.value.diagnostics
    assert diag.path == "collisions[0].struck_area"
    assert diag.line == text.splitlines().index(CONTACT.replace("right", "roof")) + 1
    assert diag.value == "roof" and set(diag.allowed) == {"front", "rear", "left", "right"}


def test_unknown_contact_field_lists_the_contact_fields(tmp_path: Path) -> None:
    with pytest.raises(DslError) as info:
        _validate(GOLDEN.replace("class: angle}", "class: angle, speed: 3}"), tmp_path)
    [diag] = info.value.diagnostics
    assert diag.path == "collisions[0].speed"
    assert {"striking", "struck", "striking_area", "struck_area", "class"} <= set(diag.allowed)


@pytest.mark.parametrize(("replace", "path", "value"), [
    ("striking: npc1", "collisions[0].striking", "npc7"),
    ("struck: ego", "collisions[0].struck", "npc1"),
])
def test_contact_actors_must_exist_and_differ(tmp_path: Path, replace: str, path: str, value: str) -> None:
    with pytest.raises(DslError) as info:
        _validate(GOLDEN.replace(replace, replace.split(":")[0] + ": " + value), tmp_path)
    [diag] = [d for d in info.value.diagnostics if d.severity == "error"]
    assert (diag.path, diag.value) == (path, value)
    assert diag.line == GOLDEN.splitlines().index(CONTACT) + 1


def test_class_contradicting_areas_is_a_warning_with_the_path(tmp_path: Path) -> None:
    _, warnings = _validate(GOLDEN.replace("class: angle", "class: head_on"), tmp_path)
    [diag] = [w for w in warnings if w.path.startswith("collisions")]
    assert diag.path == "collisions[0].class" and diag.value == "head_on"
    assert diag.allowed == ["front/front"]


@pytest.mark.parametrize(("klass", "a", "b", "fits"), [
    ("rear_end", "front", "rear", True), ("rear_end", "rear", "front", True), ("rear_end", "front", "left", False),
    ("head_on", "front", "front", True), ("head_on", "front", "rear", False),
    ("angle", "front", "right", True), ("angle", "left", "front", True), ("angle", "left", "right", False),
    ("sideswipe", "left", "right", True), ("sideswipe", "front", "left", True), ("sideswipe", "front", "rear", False),
])
def test_class_area_table(klass: str, a: str, b: str, fits: bool) -> None:
    assert areas_fit_class(klass, a, b) is fits


def test_every_golden_contact_fits_its_class() -> None:
    for path in sorted(EXAMPLES.glob("*/golden.yaml")):
        for contact in loads(path.read_text(encoding="utf-8")).collisions or []:
            assert areas_fit_class(contact.class_, contact.striking_area, contact.struck_area), path


def test_schema_describes_contacts_with_the_file_key_class() -> None:
    schema = json_schema()
    contact = schema["$defs"]["Contact"]
    assert set(contact["required"]) == {"striking", "struck", "striking_area", "struck_area", "class"}
    assert contact["additionalProperties"] is False
