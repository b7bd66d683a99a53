"""The `newtonian` backend (crashscene.simulate.newtonian) and the Scenic trace helpers (scenic_trace).

Fast tests check the geometry and the error paths; `slow` ones run Scenic's
Newtonian simulator on a hand-written program over a generated straight road.
"""
from __future__ import annotations

import json
import math
import random
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from crashscene.dsl import load_file
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate import recorder, scenic_trace
from crashscene.simulate.backend import (
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    create_simulator,
)
from crashscene.simulate.newtonian import (
    NewtonianSimulator,
    compile_program,
    generate_scenic_scene,
    newtonian_timing,
    seeded_globals,
    simulate_program,
    time_newtonian_runs,
)
from crashscene.traces import TABLES

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "ciren"
STRAIGHT_CASE = EXAMPLES / "100343" / "golden.yaml"  # ego + npc1, both labelled; roles are all we need here

# Two cars in the right lane of a straight two-lane road; npc1 ahead and slower, so ego runs into it.
REAR_END_PROGRAM = """
param map = localPath('straight.xodr')
model scenic.simulators.newtonian.driving_model
lane = Uniform(*network.lanes)
ego = new Car on lane.centerline, with speed Range(9, 11), with role 'ego',
    with behavior FollowLaneBehavior(target_speed=10)
npc1 = new Car following roadDirection from ego for Range(20, 30), with speed 4, with role 'npc1',
    with behavior FollowLaneBehavior(target_speed=4)
require (distance from ego to npc1) < 60
"""


def make_straight_map(path: Path, length: float = 500.0) -> Path:
    """A straight two-way road, one 3.5 m lane per direction, along +x from the origin."""
    from scenariogeneration import xodr

    road = xodr.create_road(xodr.Line(length), id=1, left_lanes=1, right_lanes=1, lane_width=3.5)
    odr = xodr.OpenDrive("straight")
    odr.add_road(road)
    odr.adjust_roads_and_lanes()
    odr.write_xml(str(path))
    return path


def scenes_from_program(program: str, map_file: Path, seed: int, indices: range) -> list[SampledScene]:
    """SampledScenes read off the Scenic scenes the backend itself will generate (a stand-in for sample)."""
    scenario = compile_program(program, map_file)
    scenes = []
    for i in indices:
        scene = generate_scenic_scene(scenario, seed, i)
        actors = [SampledActor(role=obj.role, type="car", blueprint="vehicle.lincoln.mkz_2017",
                               behavior="go_forward", x=float(obj.position[0]), y=float(obj.position[1]),
                               yaw=float(scenic_trace.yaw_from_heading(obj.heading)), speed=float(obj.speed),
                               length=float(obj.length), width=float(obj.width), lane_id=obj.lane.uid,
                               route_intent="straight", reference="road", relation="behind")
                  for obj in scene.objects]
        scenes.append(SampledScene(index=i, seed=seed, scenario_hash="test", map_file=str(map_file), actors=actors))
    return scenes


def table_bytes(table: pa.Table) -> bytes:
    """Arrow IPC serialisation of a table, to compare tables byte for byte."""
    sink = pa.BufferOutputStream()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table.combine_chunks())
    return sink.getvalue().to_pybytes()


@pytest.fixture(scope="module")
def straight_map(tmp_path_factory) -> Path:
    return make_straight_map(tmp_path_factory.mktemp("maps") / "straight.xodr")


@pytest.fixture(scope="module")
def scenario():
    return load_file(STRAIGHT_CASE)


# ------------------------------------------------------------------ fast: geometry, conventions, errors

def test_yaw_from_heading_turns_scenic_heading_into_opendrive_yaw():
    # Scenic 0 = +y (north) is yaw pi/2; Scenic -pi/2 (east) is yaw 0; results wrapped to [-pi, pi]
    assert scenic_trace.yaw_from_heading(0.0) == pytest.approx(math.pi / 2)
    assert scenic_trace.yaw_from_heading(-math.pi / 2) == pytest.approx(0.0)
    assert abs(scenic_trace.yaw_from_heading(math.pi / 2)) == pytest.approx(math.pi)
    assert scenic_trace.yaw_from_heading(3 * math.pi / 4) == pytest.approx(-3 * math.pi / 4)


def test_seeded_globals_is_reproducible_and_restores_global_state():
    random.seed(123)
    np.random.seed(123)
    before = (random.random(), np.random.random())
    random.seed(123)
    np.random.seed(123)
    with seeded_globals(7, 3):
        first = (random.random(), np.random.random())
    after = (random.random(), np.random.random())
    with seeded_globals(7, 3):
        again = (random.random(), np.random.random())
    with seeded_globals(7, 4):
        other = (random.random(), np.random.random())
    assert first == again != other
    assert after == before  # the caller's streams continue as if nothing happened


def test_registered_under_its_name():
    assert isinstance(create_simulator("newtonian"), NewtonianSimulator)


def test_missing_program_is_a_clear_error(scenario, tmp_path):
    request = SimulationRequest(scenario=scenario, scenes=[], map_file=tmp_path / "map.xodr", program=None)
    with pytest.raises(SimulationError, match="needs the rendered Scenic program"):
        NewtonianSimulator().simulate(request)


def test_user_ads_is_refused_with_the_alternatives(scenario, tmp_path):
    request = SimulationRequest(scenario=scenario, scenes=[], map_file=tmp_path / "map.xodr", program="x = 1")
    with pytest.raises(SimulationError, match="--backend embedded"):
        NewtonianSimulator(SimulationSettings(ads="mypkg.driver:Driver")).simulate(request)


def test_missing_map_names_the_file(tmp_path):
    with pytest.raises(SimulationError, match="nowhere.xodr: map not found"):
        compile_program(REAR_END_PROGRAM, tmp_path / "nowhere.xodr")


@pytest.mark.slow
def test_bad_program_names_the_model_and_the_error(straight_map):
    with pytest.raises(SimulationError, match="does not compile under scenic.simulators.newtonian"):
        compile_program("ego = new Car at (0, 0) with behavior NoSuchBehavior()\n", straight_map)


# ------------------------------------------------------------------ slow: real Newtonian runs

@pytest.fixture(scope="module")
def rear_end_run(straight_map, scenario):
    scenes = scenes_from_program(REAR_END_PROGRAM, straight_map, seed=11, indices=range(4))
    settings = SimulationSettings(mode="reproduce", horizon=8.0)
    with NewtonianSimulator(settings) as simulator:
        result = simulator.simulate(SimulationRequest(scenario=scenario, scenes=scenes, map_file=straight_map,
                                                      program=REAR_END_PROGRAM))
    return scenes, settings, result


@pytest.mark.slow
def test_run_yields_the_contract_tables(rear_end_run):
    scenes, settings, result = rear_end_run
    assert result.backend == "newtonian"
    for name, schema in TABLES.items():
        assert result.tables[name].schema.equals(schema), name
    traces = result.tables["traces"]
    assert traces.num_rows == len(scenes) * 2 * (settings.steps + 1)
    assert result.tables["variations"].column("valid").to_pylist() == [True] * len(scenes)
    assert any("traffic-light" in note for note in result.notes)


@pytest.mark.slow
def test_traces_start_at_the_sampled_poses(rear_end_run):
    scenes, _, result = rear_end_run
    rows = result.tables["traces"].filter(pa.compute.equal(result.tables["traces"]["step"], 0)).to_pylist()
    for scene in scenes:
        for actor in scene.actors:
            row = next(r for r in rows if r["variation"] == scene.index and r["actor"] == actor.role)
            assert (row["x"], row["y"], row["speed"]) == pytest.approx((actor.x, actor.y, actor.speed))
            assert row["yaw"] == pytest.approx(actor.yaw, abs=1e-9)


@pytest.mark.slow
def test_rear_end_contact_is_detected_and_both_cars_come_to_rest(rear_end_run):
    scenes, settings, result = rear_end_run
    collisions = result.tables["collisions"].to_pylist()
    assert sorted(c["variation"] for c in collisions) == [s.index for s in scenes]
    traces = result.tables["traces"].to_pylist()
    for hit in collisions:
        assert (hit["actor_a"], hit["actor_b"]) == ("ego", "npc1")
        assert hit["speed_a"] > hit["speed_b"] == pytest.approx(4.0, abs=0.2)  # ego from behind, at speed
        assert abs(abs(hit["y"]) - 1.75) < 0.5  # on a lane centre line
        step = math.ceil(hit["t"] / settings.dt - 1e-9)  # the first recorded step at or after the contact
        ego = [r for r in traces if r["variation"] == hit["variation"] and r["actor"] == "ego"]
        npc = [r for r in traces if r["variation"] == hit["variation"] and r["actor"] == "npc1"]
        length = scenes[hit["variation"]].actors[0].length
        gap = [math.hypot(npc[k]["x"] - ego[k]["x"], npc[k]["y"] - ego[k]["y"]) for k in (step - 1, step)]
        # aligned cars touch when their centres are one length apart; both are moved back to that
        # moment rather than left where the 10 Hz step carried them (up to a metre into each other)
        assert gap[0] > length
        assert gap[1] == pytest.approx(length, abs=0.02)
        assert (step - 1) * settings.dt < hit["t"] <= step * settings.dt
        assert all(r["speed"] == 0.0 for r in ego[step + 1:] + npc[step + 1:])
        assert ego[-1]["x"] == ego[step + 1]["x"]


@pytest.mark.slow
def test_same_scenes_give_identical_tables_whatever_the_chunking(rear_end_run, straight_map, scenario):
    scenes, settings, result = rear_end_run
    with NewtonianSimulator(settings) as simulator:
        chunk = simulator.simulate(SimulationRequest(scenario=scenario, scenes=scenes[2:], map_file=straight_map,
                                                     program=REAR_END_PROGRAM))
    whole = result.tables["traces"].filter(pa.compute.greater_equal(result.tables["traces"]["variation"], 2))
    assert table_bytes(chunk.tables["traces"]) == table_bytes(whole)  # byte for byte (NaN == NaN here)
    assert chunk.tables["collisions"].to_pylist() == [
        row for row in result.tables["collisions"].to_pylist() if row["variation"] >= 2]


@pytest.mark.slow
def test_benchmark_hook_times_k_runs(rear_end_run, straight_map, scenario):
    scenes, settings, _ = rear_end_run
    request = SimulationRequest(scenario=scenario, scenes=scenes, map_file=straight_map,
                                settings=settings, program=REAR_END_PROGRAM)
    timing = newtonian_timing(request, k=2)
    assert timing.runs == 2 and timing.compile_seconds > 0 and timing.run_seconds > 0
    assert timing.extrapolate(2000) == pytest.approx(timing.compile_seconds + 1000 * timing.run_seconds)
    assert time_newtonian_runs(request, k=1) > 0


@pytest.mark.slow
def test_recorded_tables_flag_spawn_overlap_like_the_embedded_backend(rear_end_run, straight_map, scenario):
    scenes, settings, _ = rear_end_run
    scene = scenes[0].model_copy(deep=True)
    ego, npc = scene.actors
    npc.x, npc.y, npc.yaw = ego.x + 2.0, ego.y, ego.yaw  # 2 m apart, 4.5 m long: overlapping
    run = recorder.SceneRun({a.role: recorder.still_track(a, settings.steps + 1) for a in scene.actors})
    tables = recorder.record_tables(scenario, [scene], [run], settings, straight_map)
    variation = tables["variations"].to_pylist()[0]
    assert not variation["valid"] and variation["invalid_reason"].startswith("spawn overlap: ego and npc1")
    assert tables["collisions"].num_rows == 0  # not a crash


# A car that steers off the road while its behaviour keeps asking for its lane: Scenic rejects the run.
OFF_ROAD_PROGRAM = """
param map = localPath('straight.xodr')
model scenic.simulators.newtonian.driving_model
behavior SteerOff():
    while True:
        lane = self.lane
        take SetThrottleAction(0.3), SetSteerAction(0.4)
ego = new Car on Uniform(*network.lanes).centerline, with speed 8, with role 'ego', with behavior SteerOff()
"""


@pytest.mark.slow
def test_a_run_scenic_rejects_is_invalid_with_its_reason_and_partial_trace(straight_map, scenario):
    scenes = scenes_from_program(OFF_ROAD_PROGRAM, straight_map, seed=5, indices=range(1))
    with NewtonianSimulator(SimulationSettings(mode="reproduce", horizon=6.0)) as simulator:
        result = simulator.simulate(SimulationRequest(scenario=scenario, scenes=scenes, map_file=straight_map,
                                                      program=OFF_ROAD_PROGRAM))
    variation = result.tables["variations"].to_pylist()[0]
    assert not variation["valid"]
    assert variation["invalid_reason"].startswith("scenic rejected the run at t=")
    assert "not in a lane" in variation["invalid_reason"]
    xs = result.tables["traces"].column("x").to_pylist()
    assert len(xs) == 61 and xs[10] != xs[0]  # what ran before the rejection is kept, then held


# Hand-written: no crashscene tags at all; the DSL scenario of case 109176 (V2 ahead, V1 runs into it).
HAND_WRITTEN_PROGRAM = """
param map = localPath('straight.xodr')
model scenic.simulators.newtonian.driving_model
param GAP = Range(25, 35)
lane = Uniform(*network.lanes)
ego = new Car on lane.centerline, with speed 12, with behavior FollowLaneBehavior(target_speed=12)
other = new Car following roadDirection from ego for globalParameters.GAP, with speed 6,
    with behavior FollowLaneBehavior(target_speed=6)
"""


@pytest.mark.slow
def test_hand_written_program_runs_against_the_dsl_scenario(straight_map):
    scenario = load_file(EXAMPLES / "109176" / "golden.yaml")
    settings = SimulationSettings(mode="reproduce", horizon=8.0)
    result = simulate_program(scenario, HAND_WRITTEN_PROGRAM, straight_map, n=2, seed=4, settings=settings)
    assert result.tables["variations"].column("valid").to_pylist() == [True, True]
    params = [json.loads(v) for v in result.tables["variations"].column("params").to_pylist()]
    assert [set(p) for p in params] == [{"GAP"}] * 2 and params[0] != params[1]  # sampled values, not settings
    actors = result.tables["actors"].to_pylist()
    assert [(a["actor"], a["behavior"]) for a in actors[:2]] == [("ego", "go_forward"), ("npc1", "decelerate")]
    hits = result.tables["collisions"].to_pylist()
    assert [(h["actor_a"], h["actor_b"]) for h in hits] == [("ego", "npc1")] * 2  # the faster ego runs into V2
    # with a 25-35 m gap closing at 6 m/s, contact (one car length, 4.5 m, apart) comes after 3.4-5.1 s
    assert all(3.4 < h["t"] < 5.1 for h in hits)


@pytest.mark.slow
def test_hand_written_program_needs_one_object_per_actor(straight_map):
    scenario = load_file(EXAMPLES / "3-C1-2017-006" / "golden.yaml")  # a single actor
    with pytest.raises(SimulationError, match=r"places 2 objects but the scenario has 1 actors \(ego\)"):
        simulate_program(scenario, HAND_WRITTEN_PROGRAM, straight_map, n=1, seed=4)


# ------------------------------------------------------------------ slow: rendered CIREN cases

# One case per topology; each its own test. Two scenes each keep the set within the time budget.
REAL_CASES = ["100237", "119489", "109176", "3-C1-2017-010"]


@pytest.fixture(scope="module")
def case_runs(tmp_path_factory):
    """case -> (scenario, scenes, result) of two reproduce-mode variations, run once per module."""
    cache: dict[str, tuple] = {}
    map_cache = tmp_path_factory.mktemp("map-cache")

    def run(case: str):
        """(scenario, scenes, result, rendered) of the case, simulated once."""
        if case not in cache:
            from crashscene import render
            from crashscene.render import sample
            scenario = load_file(EXAMPLES / case / "golden.yaml")
            rendered = render.render(scenario, tmp_path_factory.mktemp(case), cache_dir=map_cache)
            scenes = sample.sample_scenes(rendered.program, 2, seed=3, sampler="scenic")
            with NewtonianSimulator(SimulationSettings(mode="reproduce")) as simulator:
                result = simulator.simulate(SimulationRequest(
                    scenario=scenario, scenes=scenes, map_file=Path(rendered.map),
                    program=Path(rendered.program).read_text()))
            cache[case] = (scenario, scenes, result, rendered)
        return cache[case]

    return run


@pytest.mark.slow
@pytest.mark.parametrize("case", REAL_CASES)
def test_rendered_case_runs_from_the_sampled_scenes(case, case_runs):
    scenario, scenes, result, _ = case_runs(case)
    variations = result.tables["variations"].to_pylist()
    assert [v["invalid_reason"] for v in variations] == [None] * len(scenes)
    traces = result.tables["traces"]
    assert traces.num_rows == len(scenes) * len(scenario.actors) * (SimulationSettings().steps + 1)
    rows = traces.to_pylist()
    for scene in scenes:
        for actor in scene.actors:
            track = [r for r in rows if r["variation"] == scene.index and r["actor"] == actor.role]
            assert (track[0]["x"], track[0]["y"]) == pytest.approx((actor.x, actor.y))
            assert track[0]["lane_id"] == actor.lane_id
            if actor.behavior != "static":
                assert math.dist((track[0]["x"], track[0]["y"]), (track[-1]["x"], track[-1]["y"])) > 5.0
            assert all(r["control"] in ("none", "signal", "stop", "yield") for r in track)


@pytest.mark.slow
def test_junction_columns_on_a_yield_controlled_crossing(case_runs):
    # 100237: V1 (ego) straight through a 4-leg junction, V2 (npc1) from the right on a yield-controlled arm
    _, scenes, result, _ = case_runs("100237")
    rows = result.tables["traces"].to_pylist()
    for scene in scenes:
        npc = [r for r in rows if r["variation"] == scene.index and r["actor"] == "npc1"]
        ego = [r for r in rows if r["variation"] == scene.index and r["actor"] == "ego"]
        approach_npc = [r for r in npc if not r["in_junction"] and r["route_s"] < 10.0]
        approach_ego = [r for r in ego if not r["in_junction"] and r["route_s"] < 10.0]
        assert approach_npc and approach_ego
        assert {r["control"] for r in approach_npc} == {"yield"} and {r["control"] for r in ego} == {"none"}
        assert {r["maneuver"] for r in approach_npc + approach_ego} == {"straight"}
        assert {r["junction_id"] for r in approach_npc + approach_ego} == {npc[0]["junction_id"]} != {None}
        before = [r["stop_line_dist"] for r in approach_npc]
        assert all(d > 0 for d in before) and before == sorted(before, reverse=True)  # the yield line comes closer
        assert all(math.isnan(r["stop_line_dist"]) for r in ego)  # no device on the ego's approach
        assert npc[0]["route_s"] == ego[0]["route_s"] == 0.0  # stations count from each actor's start
        assert all(r["signal"] == "none" for r in npc + ego)


@pytest.mark.slow
def test_rendered_case_same_seed_same_bytes(case_runs):
    scenario, scenes, result, rendered = case_runs("100237")
    with NewtonianSimulator(SimulationSettings(mode="reproduce")) as simulator:
        again = simulator.simulate(SimulationRequest(scenario=scenario, scenes=scenes, map_file=Path(rendered.map),
                                                     program=Path(rendered.program).read_text()))
    for name in ("traces", "collisions", "variations", "actors"):
        assert table_bytes(again.tables[name]) == table_bytes(result.tables[name]), name
