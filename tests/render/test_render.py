"""Rendering: every golden file renders; only tokens and numbers reach code; hostile text stays in comments."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.dsl import load_file, loads
from crashscene.render import render, render_program
from crashscene.render.errors import RenderError
from crashscene.render.plan import convert
from crashscene.render.program import comment, py

from tests.conftest import CASES, EXAMPLES

CACHE = Path(__file__).resolve().parents[2] / ".crashscene-cache" / "maps"  # git-ignored, shared across runs

HOSTILE = '''
scenario_id: "x\\"); import os; os.system('echo pwned') #"
summary: "V2 said \\"hi\\"\\n__import__('os').system('rm -rf /')\\n{{ 7*7 }} {% raw %} {% for x in y %} \\u2028 end"
environment: {weather: clear, time_of_day: daytime}
road_network:
  road_type: straight
  number_of_ways: 2
  number_of_lanes: 2
  road_marker: broken_line
  traffic_signs: []
actors:
  ego: {label: "V1\\nimport os", type: car, behavior: go_forward, position: {reference: road, relation: behind}}
  npc1: {label: "{{ config }}", type: car, behavior: cross_centerline,
         position: {reference: ego, relation: front, heading: opposite_direction}}
oracle:
  - code: CVC_21650
    violation: wrong_side
    actor: npc1
    description: "\\"\\"\\"; import os\\n# {% endraw %} ''' + "'''" + '''"
evidence:
  summary: "x\\ny = 1\\r\\nimport subprocess"
'''

HOSTILE_MARKERS = ["import os", "__import__", "os.system", "{{", "{%", "subprocess", "rm -rf", "pwned"]


def code_lines(text: str) -> list[str]:
    """Program lines that are not comments."""
    return [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]


def hostile_scenario():
    return loads(HOSTILE)


@pytest.mark.parametrize("case", CASES)
def test_every_golden_file_renders(case, tmp_path):
    scenario = load_file(EXAMPLES / case / "golden.yaml")
    rendered = render(scenario, tmp_path, cache_dir=CACHE)
    assert rendered.program == tmp_path / "scenario.scenic" and rendered.map == tmp_path / "map.xodr"
    text = rendered.program.read_text()
    assert "param map = localPath('map.xodr')" in text
    assert "model scenic.simulators.carla.model" in text
    for role in scenario.actors:
        assert re.search(rf"^{role} = new Car at ", text, re.MULTILINE)
    assert (tmp_path / "render.json").exists() and rendered.map.stat().st_size > 0
    assert len(rendered.scenario_hash) == 16


def test_hostile_text_only_in_comments():
    scenario = hostile_scenario()
    text = render_program(convert(scenario), scenario_hash_value="0" * 16, summary=scenario.summary)
    for line in code_lines(text):
        for marker in HOSTILE_MARKERS:
            assert marker not in line, (marker, line)
    # every comment stays one physical line: no control characters survive
    assert all(ch == "\n" or 32 <= ord(ch) < 127 for ch in text)
    assert "'V1\\nimport os'" not in text and "cs_label None" in text


def test_program_text_is_deterministic(tmp_path):
    scenario = load_file(EXAMPLES / "100237" / "golden.yaml")
    a = render(scenario, tmp_path / "a", cache_dir=CACHE).program.read_text()
    b = render(scenario, tmp_path / "b", cache_dir=CACHE).program.read_text()
    assert a == b


def _declared(text: str) -> dict[str, str]:
    return dict(re.findall(r"^param (\w+) = (VerifaiRange\([^)]*\))", text, re.MULTILINE))


MODEL = {"npc1_MODEL_INDEX": "VerifaiRange(0.0, 6.0)"}   # V2, a car: the search picks its model of 6


@pytest.mark.parametrize(("case", "ads", "wanted"), [
    ("100237", "ego", {"npc1_PULL_OUT_TTA": "VerifaiRange(1.5, 4.0)", **MODEL}),   # V2 does not yield at its sign
    ("3-C4-2017-007", "ego", {"SIGNAL_GREEN_REMAINING": "VerifaiRange(3.0, 15.0)", **MODEL}),
    ("103378", "npc1", {"EGO_LEAD_TIME": "VerifaiRange(0.8, 2.0)", **MODEL}),     # V1 drifts over, the ADS drives V2
    ("103378", "ego", MODEL),                                               # the ADS's own manoeuvre: none
    ("119897", "npc1", {"EGO_LEAD_TIME": "VerifaiRange(0.8, 2.0)", "EGO_SKID_ROTATION": "VerifaiRange(0.0, 1.0)",
                        **MODEL}),
])
def test_a_search_program_declares_the_timings_the_simulator_would_draw(case, ads, wanted, tmp_path):
    scenario = load_file(EXAMPLES / case / "golden.yaml")
    plain = _declared(render(scenario, tmp_path / "plain", cache_dir=CACHE).program.read_text())
    searched = _declared(render(scenario, tmp_path / "search", cache_dir=CACHE, search_ads=ads).program.read_text())
    assert {k: v for k, v in searched.items() if k not in plain} == wanted
    assert {k: searched[k] for k in plain} == plain  # everything else as declared without a search
    assert not set(wanted) & set(plain)


@pytest.mark.parametrize("value", ["a'b", "x\ny", "import os; x", "{{ x }}", "a b", "é", 1e400])
def test_py_refuses_anything_but_tokens_and_finite_numbers(value):
    with pytest.raises(RenderError):
        py(value)


def test_py_literals_parse_back():
    value = {"role": "npc1", "needs": {"left": 1}, "heading": -1.5707963, "list": ["CVC_21650", None, True]}
    assert ast.literal_eval(py(value)) == value


def test_comment_escapes_newlines_and_unicode():
    out = comment("a\nb\r\nc\u2028d {{ x }} é")
    assert "\n" not in out and "\r" not in out and "\u2028" not in out
    assert out.isascii()


def test_render_cli_writes_program_and_map(tmp_path):
    result = CliRunner().invoke(app, ["render", str(EXAMPLES / "120013" / "golden.yaml"), "-o", str(tmp_path),
                                      "--cache-dir", str(CACHE), "--json"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "scenario.scenic").exists() and (tmp_path / "map.xodr").exists()


def test_render_cli_names_missing_town(tmp_path):
    result = CliRunner().invoke(app, ["render", str(EXAMPLES / "121520" / "golden.yaml"), "-o", str(tmp_path),
                                      "--map", "carla", "--carla-maps", str(tmp_path), "--cache-dir", str(CACHE)])
    assert result.exit_code == 1
    assert "Town05.xodr" in result.output and "Traceback" not in result.output


def test_render_cli_bad_file_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("road_network: {road_type: roundabout}\n")
    result = CliRunner().invoke(app, ["render", str(bad), "-o", str(tmp_path / "out")])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert "bad.yaml" in result.output
