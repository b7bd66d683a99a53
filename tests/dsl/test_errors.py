"""Bad input: every case is a DslError naming file, field path, line, value and allowed values."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.dsl import DslError, load_file, loads, validate_file, validate_text
from tests.conftest import CASES, EXAMPLES

GOLDEN = (EXAMPLES / "120013" / "golden.yaml").read_text(encoding="utf-8")


def _error(text: str, tmp_path: Path) -> DslError:
    path = tmp_path / "scenario.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DslError) as info:
        validate_file(path)
    return info.value


def test_bad_enum_names_path_line_value_and_allowed(tmp_path: Path) -> None:
    err = _error(GOLDEN.replace("heading: same_direction", "heading: sideways"), tmp_path)
    [diag] = err.diagnostics
    assert diag.path == "actors.npc1.position.heading"
    assert diag.file.endswith("scenario.yaml")
    assert diag.line == GOLDEN.splitlines().index(
        "    position: {reference: ego, relation: front, heading: same_direction}") + 1
    assert diag.value == "sideways"
    assert "opposite_direction" in diag.allowed
    assert "actors.npc1.position.heading" in str(err) and "sideways" in str(err)


def test_unknown_field_lists_allowed_fields(tmp_path: Path) -> None:
    err = _error(GOLDEN.replace("  road_surface: dry", "  road_surface: dry\n  visibility: poor"), tmp_path)
    [diag] = err.diagnostics
    assert diag.path == "environment.visibility"
    assert diag.line == 8
    assert set(diag.allowed) == {"weather", "time_of_day", "road_surface"}


def test_not_yaml(tmp_path: Path) -> None:
    err = _error("environment: [unclosed\n  weather: : :\n", tmp_path)
    assert "not valid YAML" in str(err) and err.diagnostics[0].line is not None


def test_empty_file(tmp_path: Path) -> None:
    assert "empty" in str(_error("", tmp_path))
    assert "empty" in str(_error("# only a comment\n", tmp_path))


def test_binary_file(tmp_path: Path) -> None:
    path = tmp_path / "sketch.yaml"
    path.write_bytes((EXAMPLES / CASES[0] / "sketch.jpg").read_bytes()[:4096]
                     if (EXAMPLES / CASES[0] / "sketch.jpg").exists() else b"\xff\xd8\xff\x00\x01")
    with pytest.raises(DslError) as info:
        load_file(path)
    assert str(path) in str(info.value)


def test_huge_file_is_refused_without_reading(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    with path.open("wb") as handle:
        handle.truncate(50 * 1024 * 1024)
    with pytest.raises(DslError) as info:
        load_file(path)
    assert "at most" in str(info.value)


def test_yaml_bomb(tmp_path: Path) -> None:
    bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n"
    for i in range(1, 9):
        bomb += f"l{i}: &l{i} [{', '.join(['*' + ('a' if i == 1 else f'l{i - 1}')] * 10)}]\n"
    err = _error(bomb, tmp_path)
    assert "expands" in str(err)


def test_list_where_mapping_belongs(tmp_path: Path) -> None:
    block = "environment:\n  weather: clear\n  time_of_day: daytime\n  road_surface: dry\n"
    assert block in GOLDEN
    err = _error(GOLDEN.replace(block, "environment:\n  - clear\n  - daytime\n"), tmp_path)
    assert any(d.path == "environment" and "mapping" in d.message for d in err.diagnostics)


def test_top_level_list(tmp_path: Path) -> None:
    assert "mapping" in str(_error("- a\n- b\n", tmp_path))


def test_missing_file() -> None:
    with pytest.raises(DslError) as info:
        load_file("/nonexistent/scenario.yaml")
    assert "/nonexistent/scenario.yaml" in str(info.value)


def test_python_tags_are_refused(tmp_path: Path) -> None:
    err = _error("!!python/object/apply:os.system ['echo hacked']\n", tmp_path)
    assert "not valid YAML" in str(err)


@pytest.mark.parametrize(("old", "new", "path", "needle"), [
    ("position: {reference: ego, relation: front", "position: {reference: npc7, relation: front",
     "actors.npc1.position.reference", "does not exist"),
    ("    actor: ego\n", "    actor: npc4\n", "oracle[0].actor", "does not exist"),
    ("position: {reference: road, relation: behind}", "position: {reference: road, relation: behind, heading: same_direction}",
     "actors.ego.position.heading", "ego's heading"),
    ("  speed_limit_mph: 55\n", "  speed_limit_mph: 55\n  curve_direction: left\n",
     "road_network.curve_direction", "only meaningful on a curve"),
    ("  number_of_lanes: 2\n", "  number_of_lanes: 1\n", "road_network.number_of_lanes", "smaller than number_of_ways"),
    ("violation: unsafe_speed", "violation: speeding", "oracle[0].violation", "unsafe_speed"),
    ("position: {reference: road, relation: behind}", "position: {reference: stop_sign, relation: behind}",
     "actors.ego.position.reference", "traffic_signs does not list"),
])
def test_semantic_errors(old: str, new: str, path: str, needle: str) -> None:
    assert old in GOLDEN
    with pytest.raises(DslError) as info:
        validate_text(GOLDEN.replace(old, new, 1), source="case.yaml")
    matching = [d for d in info.value.diagnostics if d.path == path]
    assert matching, info.value
    assert needle in str(matching[0])
    assert matching[0].line is not None and matching[0].file == "case.yaml"


def test_semantic_warnings_do_not_fail() -> None:
    text = GOLDEN.replace("traffic_signs: [speed_limit_sign]", "traffic_signs: [stop_sign, speed_limit_sign]")
    _, warnings = validate_text(text)
    assert any("stop_sign" in str(w) and "controls nothing" in str(w) for w in warnings)


def test_missing_ego_and_bad_actor_name() -> None:
    with pytest.raises(DslError) as info:
        loads(GOLDEN.replace("  ego:\n", "  car1:\n"))
    assert any(d.path == "actors" for d in info.value.diagnostics)


@pytest.mark.parametrize("old, new, path, lines", [
    ("  npc1:\n", "  ego:\n    label: V9\n    type: car\n    behavior: go_forward\n"
                  "    position: {reference: road, relation: behind}\n  npc1:\n", "actors.ego", (16, 21)),
    ("  road_type: straight\n", "  road_type: straight\n  road_type: curve\n", "road_network.road_type", (9, 10)),
    ("  road_type: straight\n", "  road_type: straight\n  Road type: curve\n", "road_network.road_type", (9, 10)),
])
def test_duplicate_keys_are_refused_with_both_lines(tmp_path: Path, old: str, new: str, path: str, lines) -> None:
    err = _error(GOLDEN.replace(old, new, 1), tmp_path)
    [diag] = err.diagnostics
    assert diag.path == path
    assert f"lines {lines[0]} and {lines[1]}" in diag.message
    assert diag.line == lines[1]


@pytest.mark.parametrize("old, new, path", [
    ("number_of_lanes: 2", "number_of_lanes: true", "road_network.number_of_lanes"),
    ("number_of_ways: 2", "number_of_ways: false", "road_network.number_of_ways"),
    ("speed_limit_mph: 55", "speed_limit_mph: yes", "road_network.speed_limit_mph"),
    ("    behavior: stop\n", "    behavior: stop\n    speed_mph: true\n", "actors.npc1.speed_mph"),
])
def test_booleans_are_refused_in_number_fields(tmp_path: Path, old: str, new: str, path: str) -> None:
    err = _error(GOLDEN.replace(old, new, 1), tmp_path)
    [diag] = err.diagnostics
    assert diag.path == path and "boolean" in diag.message


def test_oracle_is_required_so_a_truncated_file_does_not_validate(tmp_path: Path) -> None:
    err = _error(GOLDEN[: GOLDEN.index("  npc1:")], tmp_path)
    assert [d.path for d in err.diagnostics] == ["oracle"]
    assert "required" in err.diagnostics[0].message


def test_actors_placed_relative_to_each_other_are_refused_naming_both_fields(tmp_path: Path) -> None:
    three = (EXAMPLES / "105203" / "golden.yaml").read_text(encoding="utf-8")
    text = three.replace("position: {reference: ego, relation: front, heading: same_direction}",
                         "position: {reference: npc2, relation: front, heading: same_direction}")
    text = text.replace("position: {reference: ego, relation: front, heading: opposite_direction}",
                        "position: {reference: npc1, relation: front, heading: opposite_direction}")
    err = _error(text, tmp_path)
    [diag] = [d for d in err.diagnostics if "cycle" in d.message]
    assert diag.path == "actors.npc1.position.reference" and "actors.npc2.position.reference" in diag.message
    assert "npc1 -> npc2, npc2 -> npc1" in diag.message and diag.line is not None


def test_more_actors_than_a_map_can_place_are_refused(tmp_path: Path) -> None:
    npc = "\n  npc{i}:\n    type: car\n    behavior: go_forward\n" \
          "    position: {{reference: ego, relation: behind, heading: same_direction}}"
    extra = "".join(npc.format(i=i) for i in range(2, 51))
    text = GOLDEN.replace("    position: {reference: ego, relation: front, heading: same_direction}\n",
                          "    position: {reference: ego, relation: front, heading: same_direction}" + extra + "\n")
    err = _error(text, tmp_path)
    [diag] = err.diagnostics
    assert diag.path == "actors" and diag.value == 51 and "at most 6" in str(diag)
