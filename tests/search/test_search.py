"""crashscene search: samplers, failure-region rules, bad input, and a small real search."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.search import SearchError
from crashscene.search.region import failure_rules
from crashscene.search.run import SUMMARY_KEYS, check_request
from crashscene.search.samplers import SAMPLERS, create_sampler

CASES = Path(__file__).resolve().parents[2] / "examples" / "ciren"


def _bowl(points: np.ndarray) -> np.ndarray:
    return np.sum((points - 0.8) ** 2, axis=1)


@pytest.mark.parametrize("name", SAMPLERS)
def test_sampler_same_seed_same_points(name):
    runs = []
    for _ in range(2):
        sampler = create_sampler(name, 3, seed=7, round_size=16)
        asked = []
        for _ in range(3):
            points = sampler.ask(16)
            assert points.shape == (16, 3) and (points >= 0).all() and (points <= 1).all()
            sampler.tell(points, _bowl(points))
            asked.append(points)
        runs.append(np.concatenate(asked))
    np.testing.assert_array_equal(runs[0], runs[1])


@pytest.mark.parametrize("name", ["ce", "bo"])
def test_adaptive_samplers_concentrate_on_low_values(name):
    sampler = create_sampler(name, 3, seed=1, round_size=25)
    rounds = []
    for _ in range(8):
        points = sampler.ask(25)
        values = _bowl(points)
        sampler.tell(points, values)
        rounds.append(values.mean())
    assert rounds[-1] < 0.5 * rounds[0]  # uniform points average 0.52 on this bowl


def test_failure_rules_recover_a_box():
    rng = np.random.default_rng(0)
    values = rng.uniform(0, 20, size=(400, 2))
    verdicts = ["collision" if (a > 11.2 and b < 5.0) else "pass" for a, b in values]
    rules = failure_rules(["npc1_SPEED", "npc1_ARRIVAL_OFFSET"], values, verdicts)
    assert rules, "a failure region must be found"
    top = rules[0]
    assert top.kind == "collision" and top.failure_rate > 0.8
    bounds = {c.rsplit(" ", 1)[0]: float(c.rsplit(" ", 1)[1]) for c in top.conditions}
    assert 10.5 < bounds["npc1_SPEED >"] < 11.5
    assert 4.5 < bounds["npc1_ARRIVAL_OFFSET <="] < 5.3
    assert top.text().endswith(f"% collision (n={top.support})")
    assert failure_rules(["a", "b"], values, ["pass"] * 400) == []


@pytest.mark.parametrize("budget, sampler, objective, message", [
    (400, "annealing", "robustness", "--sampler 'annealing' is not allowed; allowed: random, halton, ce, bo"),
    (5, "ce", "robustness", "--budget 5 is below the round size 8"),
    (400, "ce", "speed", "--objective 'speed' is not allowed; allowed: robustness, ttc"),
])
def test_bad_requests(budget, sampler, objective, message):
    with pytest.raises(SearchError, match=message.replace("(", r"\(").replace(")", r"\)")):
        check_request(budget, sampler, objective)


def test_cli_bad_sampler_names_file_and_allowed():
    result = CliRunner().invoke(app, ["search", str(CASES / "100237" / "golden.yaml"), "--sampler", "grid"])
    assert result.exit_code == 2
    assert "golden.yaml" in result.output and "allowed: random, halton, ce, bo" in result.output


def test_no_sampled_parameters(tmp_path):
    import scenic

    from crashscene.search.space import parameter_space

    program = tmp_path / "fixed.scenic"
    program.write_text("param SPEED = 10.0\nego = new Object at 0 @ 0\n", encoding="utf-8")
    compiled = scenic.scenarioFromFile(str(program), mode2D=True)
    with pytest.raises(SearchError, match="no sampled parameters to search"):
        parameter_space(compiled, program)


@pytest.mark.slow
def test_search_pins_parameters_and_repeats(tmp_path):
    """A small real search: parameters reach the scenes, outputs are written, the same seed repeats."""
    runner = CliRunner()
    outs = []
    for k in range(2):
        out = tmp_path / f"run{k}"
        result = runner.invoke(app, ["search", str(CASES / "100237" / "golden.yaml"), "--budget", "16",
                                     "--sampler", "ce", "--seed", "3", "--out", str(out), "--json"])
        assert result.exit_code == 0, result.output
        summary = json.loads(result.output[result.output.index("{"):])
        assert tuple(summary) == SUMMARY_KEYS
        assert summary["evaluated"] == 16 and summary["sampler"] == "ce" and summary["objective"] == "robustness"
        outs.append((summary, pq.read_table(out / "evaluations.parquet")))
    (first, table_a), (second, table_b) = outs
    assert {k: v for k, v in first.items() if k != "seconds"} == {k: v for k, v in second.items() if k != "seconds"}
    import pandas.testing as pdt

    pdt.assert_frame_equal(table_a.to_pandas(), table_b.to_pandas())   # NaN (no TTC) equals NaN here
    report = json.loads((tmp_path / "run0" / "search.json").read_text())
    assert [r["round"] for r in report["rounds"]] == [0, 1] and report["ego_role"] == "ego"
    names = [p["name"] for p in report["parameters"]]
    # the pinned values are what the simulator saw: compare with the scenes' sampled parameters
    from crashscene.dsl import load_file
    from crashscene.render.sample import compile_program
    from crashscene.search.space import parameter_space, pinned_scenes

    compiled = compile_program(tmp_path / "run0" / "scenario.scenic")
    space = parameter_space(compiled, tmp_path / "run0" / "scenario.scenic")
    assert list(space.names) == names
    values = np.array([table_a.column(n).to_pylist()[:2] for n in names]).T
    scenes = pinned_scenes(compiled, tmp_path / "run0" / "scenario.scenic", values, 3, 0)
    for scene, row in zip(scenes, values):
        assert [scene.params[n] for n in names] == pytest.approx(list(row))
    assert load_file(tmp_path / "run0" / "scenario.yaml").actors["ego"]


def test_ttc_objective_orders_every_outcome():
    """A harder impact < a softer one < a collision course < a near miss < a wide berth; invalid is NaN."""
    import pyarrow as pa

    from crashscene.monitor.criticality import CRITICALITY_SCHEMA
    from crashscene.search.objective import FULL_BRAKING, TTC_CAP, objective_values, worst_value

    nan = float("nan")
    rows = [  # variation, min_ttc, min_gap, impact_speed
        (0, 0.0, 0.0, 12.0), (1, 0.0, 0.0, 4.0), (2, 1.5, 0.8, nan), (3, nan, 0.5, nan), (4, nan, 30.0, nan),
        (5, nan, 1.0, nan)]
    crit = pa.table({name: pa.nulls(len(rows), field.type) for name, field in
                     zip(CRITICALITY_SCHEMA.names, CRITICALITY_SCHEMA)}, schema=CRITICALITY_SCHEMA)
    crit = crit.set_column(0, "variation", pa.array([r[0] for r in rows], pa.int32()))
    for name, k in (("min_ttc", 1), ("min_gap", 2), ("impact_speed", 3)):
        crit = crit.set_column(crit.schema.get_field_index(name), name, pa.array([r[k] for r in rows], pa.float64()))
    crit = crit.set_column(crit.schema.get_field_index("involves_ads"), "involves_ads", pa.array([True] * len(rows)))
    verdicts = pa.table({"variation": pa.array(range(6), pa.int32()),
                         "verdict": ["collision", "collision", "pass", "pass", "pass", "invalid"]})
    values = objective_values("ttc", np.arange(6), verdicts, None, None, crit)
    assert values[0] == pytest.approx(-12.0 / FULL_BRAKING)
    assert values[1] == pytest.approx(-4.0 / FULL_BRAKING)
    assert values[2] == pytest.approx(1.5)
    assert values[0] < values[1] < values[2] < TTC_CAP < values[3] < values[4] <= worst_value("ttc")
    assert np.isnan(values[5])


@pytest.mark.slow
def test_a_searched_skid_rotation_reaches_the_plan(tmp_path):
    """119897 with the ADS in V2's seat: V1 loses control into it. Two scenes equal but for the sampled
    `EGO_SKID_ROTATION` give V1 different skids (its heading at the end differs)."""
    from crashscene.dsl import load_file
    from crashscene.render import render
    from crashscene.render.sample import compile_program
    from crashscene.search.space import parameter_space, pinned_scenes
    from crashscene.simulate.backend import SimulationRequest, SimulationSettings, create_simulator

    scenario = load_file(CASES / "119897" / "golden.yaml")
    rendered = render(scenario, tmp_path, search_ads="npc1")
    compiled = compile_program(rendered.program)
    space = parameter_space(compiled, rendered.program)
    column = space.names.index("EGO_SKID_ROTATION")
    settings = SimulationSettings(mode="test", ego_role="npc1")
    final_yaw = []
    for rotation in (0.0, 1.0):
        unit = np.full((1, space.dimension), 0.5)
        unit[0, column] = rotation
        scenes = pinned_scenes(compiled, rendered.program, space.values(unit), 0, 0)
        assert scenes[0].params["EGO_SKID_ROTATION"] == rotation
        request = SimulationRequest(scenario=scenario, scenes=scenes, map_file=rendered.map, settings=settings)
        traces = create_simulator("embedded", settings).simulate(request).tables["traces"].to_pandas()
        yaw = traces[traces.actor == "ego"].yaw.to_numpy()
        final_yaw.append(float(np.unwrap(yaw)[-1] - yaw[0]))
    assert abs(final_yaw[0] - final_yaw[1]) > 0.1
