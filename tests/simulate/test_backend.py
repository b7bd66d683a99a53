"""The backend interface: registry, the default one-scene-at-a-time loop, shared table layout."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.dsl import load_file
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import (
    SceneResult,
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    Simulator,
    backend_names,
    get_simulator_class,
)
from crashscene.traces import TABLES

EXAMPLE = Path(__file__).parents[2] / "examples" / "ciren" / "100237" / "golden.yaml"
STRAIGHT = Path(__file__).parents[1] / "monitor" / "scenarios" / "speeding.yaml"  # a straight road, ego + npc1


def _actor(role: str, dispositions: list[str], x: float = 50.0) -> SampledActor:
    return SampledActor(role=role, type="car", blueprint="vehicle.lincoln.mkz_2017", behavior="go_forward",
                        x=x, y=-1.75, yaw=0.0, speed=10.0, length=4.5, width=1.9, route_intent="straight",
                        reference="road", relation="behind", dispositions=dispositions)


class RawColumnsSimulator(Simulator):
    """Moves every actor straight ahead at its speed, as raw trace columns (`simulate_scene`)."""

    name = "raw"

    def simulate_scene(self, request, scene):
        steps = self.settings.steps + 1
        cols: dict[str, list] = {"actor": [], "step": [], "t": [], "x": [], "y": []}
        for actor in scene.actors:
            for k in range(steps):
                cols["actor"].append(actor.role)
                cols["step"].append(k)
                cols["t"].append(k * self.settings.dt)
                cols["x"].append(actor.x + actor.speed * k * self.settings.dt)
                cols["y"].append(actor.y)
        return SceneResult(traces=cols, valid=scene.index != 1, invalid_reason="ego never moved")


def test_registry_names_and_unknown_backend():
    assert {"embedded", "newtonian", "carla"} <= set(backend_names())
    with pytest.raises(SimulationError, match="unknown backend 'nope'"):
        get_simulator_class("nope")


def test_default_loop_builds_contract_tables(straight_map):
    scenario = load_file(STRAIGHT)
    scenes = [SampledScene(index=i, seed=7, scenario_hash="h", map_file=str(straight_map),
                           actors=[_actor("ego", ["CVC_21453"]), _actor("npc1", ["CVC_21803"], x=90.0)])
              for i in range(3)]
    settings = SimulationSettings(horizon=1.0, mode="test")
    done = []
    result = RawColumnsSimulator(settings).simulate(SimulationRequest(scenario, scenes, straight_map, settings,
                                                                      progress=done.append))
    assert sum(done) == 3
    for name, schema in TABLES.items():
        assert result.tables[name].schema.equals(schema), name
    assert result.tables["traces"].num_rows == 3 * 2 * 11
    actors = result.tables["actors"].to_pylist()
    ego = next(a for a in actors if a["actor"] == "ego")
    npc = next(a for a in actors if a["actor"] == "npc1")
    assert ego["is_ads"] and ego["dispositions"] == []  # the ADS under test carries no injected violation
    assert not npc["is_ads"] and npc["dispositions"] == ["CVC_21803"]
    variations = result.tables["variations"].to_pylist()
    assert [v["valid"] for v in variations] == [True, False, True]
    assert variations[1]["invalid_reason"] == "ego never moved" and variations[0]["invalid_reason"] is None
    # the pose went through the shared recorder: map columns filled, the columns the backend gave kept
    traces = result.tables["traces"].to_pylist()
    assert all(r["lane_id"] == "road1_lane0" and r["route_s"] is not None and r["speed_limit"] == r["speed_limit"]
               for r in traces)
    assert [r["x"] for r in traces if r["variation"] == 0 and r["actor"] == "ego"][:3] == [50.0, 51.0, 52.0]
    assert all(r["speed"] == pytest.approx(10.0) and r["yaw"] == 0.0 for r in traces if r["step"] > 0)


def test_unknown_ego_role_is_a_clear_error():
    scenario = load_file(EXAMPLE)
    settings = SimulationSettings(ego_role="npc7")
    with pytest.raises(SimulationError, match="npc7.*allowed: ego, npc1"):
        RawColumnsSimulator(settings).simulate(SimulationRequest(scenario, [], Path("m.xodr"), settings))
