"""The embedded backend on hand-made scenes: kinematics, rules the drivers follow, collisions, determinism."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest

from crashscene.dsl import load_file
from crashscene.geometry import classify_contact, heading_difference
from crashscene.scene import SampledScene
from crashscene.simulate.backend import (
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    create_simulator,
)
from crashscene.traces import TABLES

from .conftest import EXAMPLES, LANE, actor, crossing_scenes

YIELD_CASE = EXAMPLES / "100237" / "golden.yaml"  # V2 from the right fails to yield (CVC_21803)


def run(scenario_file: Path, scenes, map_file, **settings):
    cfg = SimulationSettings(**settings)
    sim = create_simulator("embedded", cfg)
    return sim.simulate(SimulationRequest(load_file(scenario_file), scenes, Path(map_file), cfg)).tables


def table_bytes(table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def actor_trace(tables, variation: int, role: str) -> dict[str, np.ndarray]:
    t = tables["traces"]
    mask = pc.and_(pc.equal(t["variation"], variation), pc.equal(t["actor"], role))
    rows = t.filter(mask).to_pydict()
    return {k: np.array(v) for k, v in rows.items()}


def test_tables_follow_the_contract_and_straight_driving_is_exact(straight_map):
    scenes = [SampledScene(index=i, seed=3, scenario_hash="h", map_file=str(straight_map),
                           actors=[actor("ego", 50.0 + i, -LANE / 2, 0.0, 12.0)]) for i in range(4)]
    tables = run(YIELD_CASE.parent.parent / "120013" / "golden.yaml", scenes, straight_map, mode="reproduce",
                 horizon=10.0)
    for name, schema in TABLES.items():
        assert tables[name].schema.equals(schema), name
    ego = actor_trace(tables, 2, "ego")
    assert len(ego["t"]) == 101
    # keeps its lane centre and its speed: x = x0 + v t
    assert np.allclose(ego["y"], -LANE / 2, atol=0.05)
    assert ego["x"][-1] == pytest.approx(52.0 + 12.0 * 10.0, abs=0.5)
    assert set(ego["lane_id"]) == {"road1_lane0"} and not ego["opposing_lane"].any()
    assert ego["centerline_marker"][0] == "double_solid_line"
    assert ego["centerline_intrusion"][0] == pytest.approx(-(LANE / 2 - 1.9 / 2), abs=0.05)


def test_same_seed_same_bytes_and_chunks_equal_one_run(four_way_map):
    scenes = crossing_scenes(four_way_map, 12)
    whole = run(YIELD_CASE, scenes, four_way_map, mode="reproduce")
    again = run(YIELD_CASE, scenes, four_way_map, mode="reproduce")
    parts = [run(YIELD_CASE, scenes[:5], four_way_map, mode="reproduce"),
             run(YIELD_CASE, scenes[5:], four_way_map, mode="reproduce")]
    for name in TABLES:
        assert table_bytes(whole[name]) == table_bytes(again[name]), name
        joined = pa.concat_tables([parts[0][name], parts[1][name]])
        assert table_bytes(whole[name]) == table_bytes(joined), name


def test_chunks_equal_one_run_when_layouts_differ_between_variations(four_way_map):
    """Control tables come from each variation's own layout, never from the first scene of the chunk."""
    scenes = crossing_scenes(four_way_map, 6, npc_dispositions=())
    for scene in scenes:
        scene.actors[1].reference = "stop_sign"  # the stop sign controls npc1's approach, wherever it is
    for scene in scenes[1::2]:  # npc1 from the ego's left (southbound) in odd variations
        npc = scene.actors[1]
        npc.x, npc.y, npc.yaw = 160.25, 60.0, -math.pi / 2
    stop_case = EXAMPLES / "117021" / "golden.yaml"
    whole = run(stop_case, scenes, four_way_map, mode="test")
    controls = {(r["variation"], r["control"]) for r in whole["traces"].to_pylist()
                if r["actor"] == "npc1" and r["step"] == 0}
    assert controls == {(v, "stop") for v in range(6)}
    parts = [run(stop_case, scenes[:1], four_way_map, mode="test"), run(stop_case, scenes[1:], four_way_map,
                                                                          mode="test")]
    for name in TABLES:
        assert table_bytes(whole[name]) == table_bytes(pa.concat_tables([parts[0][name], parts[1][name]])), name


def test_reproduce_collides_and_the_reference_ads_yields(four_way_map):
    scenes = crossing_scenes(four_way_map, 40)
    reproduce = run(YIELD_CASE, scenes, four_way_map, mode="reproduce")
    test = run(YIELD_CASE, scenes, four_way_map, mode="test")
    crashed = set(reproduce["collisions"]["variation"].to_pylist())
    assert len(crashed) >= 20  # the timing plan makes the paths meet
    row = reproduce["collisions"].to_pylist()[0]
    assert {row["actor_a"], row["actor_b"]} == {"ego", "npc1"}
    assert classify_contact(heading_difference(row["yaw_a"], row["yaw_b"])) == "angle"
    # the reference ADS watches crossing traffic that is not slowing for its yield line and lets it pass
    assert len(set(test["collisions"]["variation"].to_pylist())) < len(crashed) / 2
    ads = test["actors"].filter(pc.equal(test["actors"]["actor"], "ego")).to_pylist()[0]
    assert ads["is_ads"] and ads["dispositions"] == []
    # the NPC pulls out when the ADS is ~2 s away; where the ADS was already inside its reaction + braking
    # distance when the NPC reached its line the variation is no test (unavoidable), never a crash it is blamed for
    rows = test["variations"].to_pylist()
    assert all(r["valid"] or r["invalid_reason"].startswith("unavoidable") for r in rows)
    assert sum(r["valid"] for r in rows) >= len(rows) / 2


def test_a_sampled_pull_out_time_moves_the_pull_out(four_way_map):
    """A search samples `npc1_PULL_OUT_TTA`: the NPC pulls out when the ADS is that far in time from the
    conflict point (the default is 2 s), so a longer time lets it go earlier and a shorter one holds it longer."""
    def crossing_time(tta: float | None) -> np.ndarray:
        scenes = crossing_scenes(four_way_map, 6)
        for scene in scenes:
            if tta is not None:
                scene.params["npc1_PULL_OUT_TTA"] = tta
        tables = run(YIELD_CASE, scenes, four_way_map, mode="test")
        out = []
        for v in range(len(scenes)):
            npc = actor_trace(tables, v, "npc1")
            out.append(float(npc["t"][np.argmax(npc["y"] > -8.0)]))  # its front is past its line
        return np.array(out)

    early, default, late = crossing_time(4.0), crossing_time(None), crossing_time(0.5)
    assert (early <= default + 1e-9).all() and (default <= late + 1e-9).all()
    assert (early < default).sum() >= 3 and (default < late).sum() >= 3


def test_npc_without_disposition_yields_to_the_ego(four_way_map):
    scenes = crossing_scenes(four_way_map, 30, npc_dispositions=())
    tables = run(YIELD_CASE, scenes, four_way_map, mode="reproduce")
    assert tables["collisions"].num_rows <= 3  # the yield-controlled NPC waits for its gap
    npc = actor_trace(tables, 0, "npc1")
    assert set(npc["control"][:10]) == {"yield"} and np.isfinite(npc["stop_line_dist"][0])


def test_reference_ads_stops_for_red_light(four_way_map):
    scenes = crossing_scenes(four_way_map, 6, npc_dispositions=())
    for scene in scenes:
        scene.params["SIGNAL_GREEN_REMAINING"] = -5.0  # red when the ego arrives
    signal_case = EXAMPLES / "121520" / "golden.yaml"  # traffic_light
    tables = run(signal_case, scenes, four_way_map, mode="test")
    for v in range(6):
        ego = actor_trace(tables, v, "ego")
        red = ego["signal"] == "red"
        assert red.any()
        crossed_on_red = red & (ego["stop_line_dist"] < 0) & (np.roll(ego["stop_line_dist"], 1) >= 0)
        assert not crossed_on_red[1:].any()
        assert ego["speed"].min() < 0.3


def test_reference_ads_stops_at_stop_sign(four_way_map):
    stop_case = EXAMPLES / "117021" / "golden.yaml"  # ego: stop_sign/behind
    scenes = crossing_scenes(four_way_map, 4, npc_dispositions=())
    for scene in scenes:
        scene.actors[0].reference = "stop_sign"
        scene.actors[1].reference = "intersection"
    tables = run(stop_case, scenes, four_way_map, mode="test")
    ego = actor_trace(tables, 0, "ego")
    assert ego["control"][0] == "stop"
    before = (ego["stop_line_dist"] > 0) & (ego["stop_line_dist"] < 10)
    assert ego["speed"][before].min() < 0.3  # a full stop within 10 m of the line (rules.md rule 2)
    assert ego["x"][-1] > 170  # then proceeds through the junction


def test_following_too_closely_rear_ends_and_the_ads_does_not(straight_map):
    case = EXAMPLES / "109176" / "golden.yaml"  # npc1 decelerates in front; ego CVC_21703
    scenes = []
    for i in range(10):
        scenes.append(SampledScene(index=i, seed=5, scenario_hash="h", map_file=str(straight_map), params={
            "npc1_TRIGGER_TIME": 2.0}, actors=[
            actor("ego", 40.0, -LANE / 2, 0.0, 20.0, dispositions=["CVC_21703"]),
            actor("npc1", 40.0 + 22.0 + i, -LANE / 2, 0.0, 20.0, behavior="decelerate",
                  reference="ego", relation="front", heading="same_direction")]))
    reproduce = run(case, scenes, straight_map, mode="reproduce")
    test = run(case, scenes, straight_map, mode="test")
    assert len(set(reproduce["collisions"]["variation"].to_pylist())) >= 7
    assert test["collisions"].num_rows == 0


def test_head_on_when_the_npc_crosses_the_centre_line(straight_map):
    case = EXAMPLES / "3-C1-2018-010" / "golden.yaml"  # npc1 crosses the centre line into the ego
    scenes = [SampledScene(index=i, seed=9, scenario_hash="h", map_file=str(straight_map), actors=[
        actor("ego", 50.0, -LANE / 2, 0.0, 15.0),
        actor("npc1", 250.0 + 5 * i, LANE / 2, math.pi, 15.0, behavior="cross_centerline",
              dispositions=["CVC_21650"], reference="ego", relation="front", heading="opposite_direction")])
        for i in range(10)]
    tables = run(case, scenes, straight_map, mode="reproduce")
    rows = tables["collisions"].to_pylist()
    first = {}
    for r in rows:  # ordered by (variation, t): every contact onset, the first one per variation first
        first.setdefault(r["variation"], r)
    assert len(first) >= 7
    assert all(classify_contact(heading_difference(r["yaw_a"], r["yaw_b"])) in ("head_on", "sideswipe")
               for r in first.values())
    npc = actor_trace(tables, 0, "npc1")
    assert npc["opposing_lane"].any() and np.nanmax(npc["centerline_intrusion"]) > 0.1


def test_spawn_overlap_is_flagged_invalid(straight_map):
    scenes = [SampledScene(index=0, seed=1, scenario_hash="h", map_file=str(straight_map), actors=[
        actor("ego", 50.0, -LANE / 2, 0.0, 10.0), actor("npc1", 52.0, -LANE / 2, 0.0, 10.0)])]
    tables = run(EXAMPLES / "109176" / "golden.yaml", scenes, straight_map, mode="reproduce")
    row = tables["variations"].to_pylist()[0]
    assert not row["valid"] and "spawn overlap" in row["invalid_reason"]


def test_an_ego_that_never_moves_is_invalid(four_way_map):
    scenes = crossing_scenes(four_way_map, 2)
    for scene in scenes:
        scene.actors[0].speed = 0.0  # starts at rest and its driver never accelerates
    tables = run(YIELD_CASE, scenes, four_way_map, mode="test", ads="tests.simulate.user_ads:Parked")
    rows = tables["variations"].to_pylist()
    assert [r["invalid_reason"] for r in rows] == ["ego never moved"] * 2


def test_user_ads_plugs_in_and_bad_spec_is_clear(four_way_map):
    scenes = crossing_scenes(four_way_map, 3)
    tables = run(YIELD_CASE, scenes, four_way_map, mode="test", ads="tests.simulate.user_ads:ConstantSpeed",
                 ads_params={"gain": 0.5})
    ego = actor_trace(tables, 0, "ego")
    assert ego["speed"][-1] == pytest.approx(0.5 * ego["speed"][0] / 1.0, rel=0.3) or ego["speed"][-1] < 8
    with pytest.raises(SimulationError, match="no attribute 'Nope'"):
        run(YIELD_CASE, scenes, four_way_map, mode="test", ads="tests.simulate.user_ads:Nope")
    with pytest.raises(SimulationError, match="reaction_time"):
        run(YIELD_CASE, scenes, four_way_map, mode="test", ads_params={"reaction_time": -1})


def test_the_default_pull_out_time_lies_in_the_range_a_search_samples():
    from crashscene.render.plan import PULL_OUT_TTA_RANGE
    from crashscene.simulate.embedded.pullout import PULL_OUT_TTA

    assert PULL_OUT_TTA_RANGE[0] <= PULL_OUT_TTA <= PULL_OUT_TTA_RANGE[1]
