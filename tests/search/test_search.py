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
    state = np.random.get_state()
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
    after = np.random.get_state()   # numpy's global generator is the caller's: left as it was
    assert after[2:] == state[2:] and (after[1] == state[1]).all()


@pytest.mark.parametrize("name", ["ce", "bo", "cmaes"])
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
    (400, "annealing", "robustness", "--sampler 'annealing' is not allowed; allowed: random, halton, ce, bo, cmaes"),
    (5, "ce", "robustness", "--budget 5 is below the round size 8"),
    (400, "ce", "speed", "--objective 'speed' is not allowed; allowed: robustness, ttc"),
])
def test_bad_requests(budget, sampler, objective, message):
    with pytest.raises(SearchError, match=message.replace("(", r"\(").replace(")", r"\)")):
        check_request(budget, sampler, objective)


def test_cli_bad_sampler_names_file_and_allowed():
    result = CliRunner().invoke(app, ["search", str(CASES / "100237" / "golden.yaml"), "--sampler", "grid"])
    assert result.exit_code == 2
    assert "golden.yaml" in result.output and "allowed: random, halton, ce, bo, cmaes" in result.output


def test_no_sampled_parameters():
    from crashscene.search.space import space_of

    fixed = [{"name": "EGO_SPEED", "low": 10.0, "high": 10.0}, {"name": "EGO_INIT_DIST", "low": 15.0, "high": 15.0}]
    with pytest.raises(SearchError, match="fixed.scenic: no sampled parameters to search"):
        space_of(fixed, "fixed.scenic")
    space = space_of(fixed + [{"name": "npc1_SPEED", "low": 8.0, "high": 12.0}], "one.scenic")
    assert space.names == ("npc1_SPEED",) and space.constants == (("EGO_SPEED", 10.0), ("EGO_INIT_DIST", 15.0))


def test_a_program_without_its_sampling_plan_is_refused(tmp_path):
    from crashscene.search.space import parameter_space

    program = tmp_path / "hand.scenic"
    program.write_text("param SPEED = VerifaiRange(8, 12)\nego = new Object at 0 @ 0\n", encoding="utf-8")
    with pytest.raises(SearchError, match="no compiled sampling plan beside hand.scenic"):
        parameter_space(program)


@pytest.mark.slow
@pytest.mark.parametrize("sampler", ["ce", "cmaes"])
def test_search_pins_parameters_and_repeats(sampler, tmp_path):
    """A small real search: parameters reach the scenes, outputs are written, the same seed repeats."""
    runner = CliRunner()
    outs = []
    for k in range(2):
        out = tmp_path / f"run{k}"
        result = runner.invoke(app, ["search", str(CASES / "100237" / "golden.yaml"), "--budget", "16",
                                     "--sampler", sampler, "--seed", "3", "--out", str(out), "--json"])
        assert result.exit_code == 0, result.output
        summary = json.loads(result.output[result.output.index("{"):])
        assert tuple(summary) == SUMMARY_KEYS
        assert summary["evaluated"] == 16 and summary["sampler"] == sampler and summary["objective"] == "robustness"
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
    from crashscene.search.space import PinnedScenes, parameter_space

    space = parameter_space(tmp_path / "run0" / "scenario.scenic")
    assert list(space.names) == names
    values = np.array([table_a.column(n).to_pylist()[:2] for n in names]).T
    scenes = PinnedScenes(tmp_path / "run0" / "scenario.scenic", space)(values, 3, 0)
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
    from crashscene.search.space import PinnedScenes, parameter_space
    from crashscene.simulate.backend import SimulationRequest, SimulationSettings, create_simulator

    scenario = load_file(CASES / "119897" / "golden.yaml")
    rendered = render(scenario, tmp_path, search_ads="npc1")
    space = parameter_space(rendered.program)
    column = space.names.index("EGO_SKID_ROTATION")
    settings = SimulationSettings(mode="test", ego_role="npc1")
    final_yaw = []
    for rotation in (0.0, 1.0):
        unit = np.full((1, space.dimension), 0.5)
        unit[0, column] = rotation
        scenes = PinnedScenes(rendered.program, space)(space.values(unit), 0, 0)
        assert scenes[0].params["EGO_SKID_ROTATION"] == rotation
        request = SimulationRequest(scenario=scenario, scenes=scenes, map_file=rendered.map, settings=settings)
        traces = create_simulator("embedded", settings).simulate(request).tables["traces"].to_pandas()
        yaw = traces[traces.actor == "ego"].yaw.to_numpy()
        final_yaw.append(float(np.unwrap(yaw)[-1] - yaw[0]))
    assert abs(final_yaw[0] - final_yaw[1]) > 0.1


@pytest.mark.slow
def test_a_searched_model_index_picks_the_vehicle_model(tmp_path):
    """In a search's program V2's model is `npc1_MODEL_INDEX`'s integer part in the pool, smallest first: in Scenic's
    own sampler (the reference), in the compiled one, and in the pinned scenes of a search."""
    from crashscene.dsl import load_file
    from crashscene.render import render
    from crashscene.render.plan import BLUEPRINT_POOLS, model_pool
    from crashscene.render.sample import sample_scenes
    from crashscene.search.space import PinnedScenes, parameter_space

    rendered = render(load_file(CASES / "100237" / "golden.yaml"), tmp_path, search_ads="ego")
    pool = model_pool(list(BLUEPRINT_POOLS["car"]))
    assert pool[0] == "vehicle.audi.a2" and pool[-1] == "vehicle.nissan.patrol"
    for sampler in ("scenic", "compiled"):
        scenes = sample_scenes(rendered.program, 12, 0, sampler=sampler)
        picked = [(s.actors[1].blueprint, pool[int(s.params["npc1_MODEL_INDEX"])]) for s in scenes]
        assert all(a == b for a, b in picked), (sampler, picked)
        assert len({a for a, _ in picked}) > 1
    space = parameter_space(rendered.program)
    unit = np.full((len(pool), space.dimension), 0.5)
    unit[:, space.names.index("npc1_MODEL_INDEX")] = (np.arange(len(pool)) + 0.5) / len(pool)
    scenes = PinnedScenes(rendered.program, space)(space.values(unit), 0, 0)
    assert [s.actors[1].blueprint for s in scenes] == pool
    areas = [s.actors[1].length * s.actors[1].width for s in scenes]
    assert areas == sorted(areas)
