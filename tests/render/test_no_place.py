"""A scenario `validate` accepts but no place on the map fits fails before sampling, naming the DSL fields
(issue 14 point 6: "a t_intersection with a same-direction NPC gives 'no place on map fits', with no field
named"). Generated junctions turn left only from an approach's leftmost lane and right only from its rightmost,
so an ego turning towards the side where a same-direction NPC stands beside it has no start lane."""
from __future__ import annotations

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.dsl import loads
from crashscene.dsl.validate import validate
from crashscene.render import SampleError, render
from crashscene.render.sample import sample_scenes

from tests.conftest import EXAMPLES
from tests.render.test_render import CACHE

DRIVEWAY = (EXAMPLES / "119489" / "golden.yaml").read_text(encoding="utf-8")  # a t_intersection, ego turns left
NPC_POSITION = "position: {reference: intersection, relation: left, heading: from_left}"


def variant(ego_behavior: str, relation: str, road_type: str = "t_intersection") -> str:
    text = DRIVEWAY.replace(NPC_POSITION, f"position: {{reference: intersection, relation: {relation}, "
                                          f"heading: same_direction}}")
    text = text.replace("behavior: turn_left", f"behavior: {ego_behavior}", 1)
    return text.replace("road_type: t_intersection", f"road_type: {road_type}")


@pytest.mark.parametrize(("ego_behavior", "relation", "road_type", "side"), [
    ("turn_left", "left", "t_intersection", "left"),
    ("turn_right", "right", "t_intersection", "right"),
    ("turn_left", "left", "intersection", "left"),
])
def test_a_turn_towards_a_same_direction_npc_names_the_fields(tmp_path, ego_behavior, relation, road_type, side):
    text = variant(ego_behavior, relation, road_type)
    assert NPC_POSITION in DRIVEWAY and f"relation: {relation}, heading: same_direction" in text
    scenario = loads(text)
    validate(scenario)  # the DSL is valid (DslError otherwise): the generated map is the limit
    rendered = render(scenario, tmp_path, cache_dir=CACHE)
    with pytest.raises(SampleError) as info:
        sample_scenes(rendered.program, 2, seed=1)
    message = str(info.value)
    assert f"actors.ego.behavior ({ego_behavior})" in message
    assert f"same-direction lane(s) on its {side}" in message
    assert f"actors.npc1.position (beside ego on its {side})" in message


@pytest.mark.parametrize(("ego_behavior", "relation"), [("turn_left", "right"), ("turn_right", "left"),
                                                         ("go_forward", "left")])
def test_the_npc_on_the_other_side_still_runs(tmp_path, ego_behavior, relation):
    rendered = render(loads(variant(ego_behavior, relation)), tmp_path, cache_dir=CACHE)
    scenes = sample_scenes(rendered.program, 2, seed=1)
    npc = next(a for a in scenes[0].actors if a.role == "npc1")
    assert npc.relation == relation and npc.heading_relation == "same_direction"


def test_simulate_refuses_before_sampling_naming_the_file_and_fields(tmp_path):
    path = tmp_path / "same_direction.yaml"
    path.write_text(variant("turn_left", "left"), encoding="utf-8")
    result = CliRunner().invoke(app, ["simulate", str(path), "-n", "3", "--seed", "1", "--out", str(tmp_path / "run"),
                                      "--backend", "dummy"])
    assert result.exit_code != 0
    assert str(path) in result.output and "actors.ego.behavior (turn_left)" in result.output
    assert "actors.npc1.position" in result.output
    assert not (tmp_path / "run").exists()


BESIDE_NPC = """
dsl_version: 1
scenario_id: beside-npc
environment: {weather: clear, time_of_day: daytime, road_surface: dry}
road_network: {road_type: straight, number_of_ways: 2, number_of_lanes: 2, road_marker: double_solid_line,
               traffic_signs: [speed_limit_sign], speed_limit_mph: 45}
actors:
  ego: {label: V1, type: car, behavior: go_forward, position: {reference: road, relation: behind}}
  npc1: {label: V2, type: car, behavior: go_forward,
         position: {reference: ego, relation: front, heading: same_direction}}
  npc2: {label: V3, type: car, behavior: go_forward,
         position: {reference: npc1, relation: right, heading: same_direction}}
oracle: []
"""


def test_an_npc_beside_another_npc_with_no_lane_there_is_named(tmp_path):
    """The map is widened for actors beside the ego, not beside an NPC: npc2 on npc1's right has no lane."""
    scenario = loads(BESIDE_NPC)
    validate(scenario)
    rendered = render(scenario, tmp_path, cache_dir=CACHE)
    with pytest.raises(SampleError) as info:
        sample_scenes(rendered.program, 2, seed=1)
    assert "actors.npc2.position (beside npc1 on its right)" in str(info.value)
    assert "no place for npc2 once ego, npc1 are placed" in str(info.value)
