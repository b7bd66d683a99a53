"""A run folder is written atomically and its traces carry the scenario they came from."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.dsl import dump_file, load_file
from crashscene.monitor import MonitorError, monitor_run
from crashscene.pipeline.simulate import simulate_scenario
from crashscene.simulate.backend import AdsError, SimulationError
from crashscene.traces import stored_digest

from .conftest import EXAMPLES

CASE = EXAMPLES / "120013" / "golden.yaml"
OTHER = EXAMPLES / "100237" / "golden.yaml"
runner = CliRunner()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("runs") / "run"
    simulate_scenario(load_file(CASE), out, n=2, seed=3, mode="reproduce")
    return out


def test_a_failed_run_leaves_the_previous_folder_untouched(run_dir):
    before = {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()}
    with pytest.raises(AdsError):
        simulate_scenario(load_file(OTHER), run_dir, n=2, seed=3, mode="test",
                          ads="tests.simulate.user_ads:BadAction", ads_params={"kind": "raise", "at": 3})
    after = {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()}
    assert after == before
    assert sorted(p.name for p in run_dir.parent.iterdir()) == ["run"]  # no temporary folder left behind
    scenes = [json.loads(line) for line in (run_dir / "scenes.jsonl").read_text().splitlines()]
    assert {s["map_file"] for s in scenes} == {str(run_dir / "map.xodr")}  # the final folder, not the temporary one


def test_monitor_refuses_a_scenario_that_is_not_the_one_simulated(run_dir, tmp_path):
    assert stored_digest(run_dir) is not None
    monitor_run(run_dir)  # the matching scenario is scored
    copy = tmp_path / "mixed"
    copy.mkdir()
    for path in run_dir.iterdir():
        if path.is_file():
            (copy / path.name).write_bytes(path.read_bytes())
    dump_file(load_file(OTHER), copy / "scenario.yaml")
    with pytest.raises(MonitorError, match="is not the scenario the traces .* were simulated from"):
        monitor_run(copy)
    result = runner.invoke(app, ["monitor", str(copy)])
    assert result.exit_code == 2 and "scenario.yaml" in result.output


def test_out_pointing_at_a_file_is_a_clear_error(tmp_path):
    target = tmp_path / "taken.txt"
    target.write_text("x")
    with pytest.raises(SimulationError, match="is a file; give a folder"):
        simulate_scenario(load_file(CASE), target, n=1, seed=0)
    result = runner.invoke(app, ["simulate", str(CASE), "-n", "1", "--out", str(target)])
    assert result.exit_code == 2 and "is a file" in result.output and "Errno" not in result.output
    result = runner.invoke(app, ["render", str(CASE), "-o", str(target)])
    assert result.exit_code == 2 and "is a file" in result.output and "Errno" not in result.output
    assert target.read_text() == "x"


def test_a_failing_ads_is_reported_as_the_ads_not_the_scenario_file(tmp_path):
    result = runner.invoke(app, ["simulate", str(CASE), "-n", "1", "--out", str(tmp_path / "r"),
                                 "--ads", "tests.simulate.user_ads:BadAction", "--ads-param", "kind=shape"])
    assert result.exit_code == 2
    assert "ADS BadAction driving 'ego'" in result.output and "Action.accel" in result.output
    assert str(CASE) not in result.output
