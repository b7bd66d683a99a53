"""Exported files read back: replays equal the simulated trace, the logical scenario follows its parameters."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

import numpy as np
import pyarrow.parquet as pq
import pytest

from tests.conftest import CASES
from tests.export.conftest import RUN_SEED, RUN_VARIATIONS

pytestmark = pytest.mark.slow


def vertices(path) -> dict[str, list[tuple[float, float, float, float]]]:
    """Entity -> [(time, x, y, h)] of its FollowTrajectoryAction polyline, parsed with scenariogeneration."""
    from scenariogeneration import xosc

    scenario = xosc.ParseOpenScenario(str(path))
    root = ET.parse(path).getroot()
    out = {}
    for group in root.iter("ManeuverGroup"):
        (actor,) = [ref.get("entityRef") for ref in group.iter("EntityRef")]
        (poly,) = list(group.iter("Polyline"))
        out[actor] = [(float(v.get("time")), float(v.find("Position/WorldPosition").get("x")),
                       float(v.find("Position/WorldPosition").get("y")), float(v.find("Position/WorldPosition").get("h")))
                      for v in poly.iter("Vertex")]
    assert isinstance(scenario, xosc.Scenario)
    return out


@pytest.mark.parametrize("case", CASES)
def test_replay_vertices_equal_the_simulated_trace(case_export, case):
    export = case_export(case)
    traces = pq.read_table(export.run_dir / "traces.parquet").to_pandas()
    for v, path in export.result.variations.items():
        got = vertices(path)
        rows = traces[traces["variation"] == v]
        assert set(got) == set(rows["actor"]), f"variation {v}: actors differ"
        for actor, verts in got.items():
            trace = rows[rows["actor"] == actor].sort_values("step")
            expected = list(zip(trace["t"], trace["x"], trace["y"], trace["yaw"]))
            assert len(verts) == len(expected), f"variation {v} {actor}: {len(verts)} vertices, {len(expected)} samples"
            assert verts == [tuple(map(float, e)) for e in expected], f"variation {v} {actor}: vertices differ"


_PARAM = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


def evaluate(expr: str, values: dict[str, float]) -> float:
    """An OpenSCENARIO `${...}` expression (arithmetic only) with the given parameter values."""
    if not expr.startswith("${"):
        return float(values[expr[1:]]) if expr.startswith("$") else float(expr)
    body = _PARAM.sub(lambda m: repr(float(values[m.group(1)])), expr[2:-1])
    assert re.fullmatch(r"[-+*/(). 0-9e]+", body), body
    return float(eval(body))  # noqa: S307  (digits and operators only, checked above)


@pytest.mark.parametrize("case", CASES)
def test_logical_start_follows_the_sampled_parameters(case_export, case):
    """For every simulated variation, the logical scenario's start (its s expression evaluated with that variation's
    parameters) lies where Scenic placed the actor: the expression encodes the program's placement."""
    from crashscene.export.roadframe import RoadFrame

    export = case_export(case)
    root = ET.parse(export.result.scenario).getroot()
    frame = RoadFrame(export.result.map)
    starts = {}
    for private in root.find("Storyboard/Init/Actions").iter("Private"):
        lane = private.find("PrivateAction/TeleportAction/Position/LanePosition")
        starts[private.get("entityRef")] = (lane.get("roadId"), int(lane.get("laneId")), lane.get("s"))
    scenes = [json.loads(line) for line in (export.run_dir / "scenes.jsonl").read_text().splitlines()]
    compared = 0
    reference = {a["role"]: frame.locate(a["x"], a["y"]).s for a in scenes[0]["actors"]}
    for scene in scenes:
        here = {a["role"]: frame.locate(a["x"], a["y"]) for a in scene["actors"]}
        if any((here[role].road, here[role].lane) != start[:2] for role, start in starts.items()):
            continue  # another placement candidate (lanes) was drawn: positions are not comparable
        for role, (road, lane, expr) in starts.items():
            # 0.1 m + 2 % of the move: Scenic's lane centrelines are polylines, and the expression is first order
            # on bends (a start that moves across a line/arc joint); a wrong sign or term is off by the whole move
            moved = abs(here[role].s - reference[role])
            assert evaluate(expr, scene["params"]) == pytest.approx(here[role].s, abs=0.1 + 0.02 * moved), (
                scene["index"], role, expr)
        compared += 1
    assert compared, "the reference scene itself must match"


def test_distribution_matches_the_program_ranges(case_export):
    from crashscene.export.program import read_program

    export = case_export("100237")
    sampling = read_program(export.run_dir / "scenario.scenic")
    root = ET.parse(export.result.distribution).getroot()
    ranges = {d.get("parameterName"): (float(d.find("UniformDistribution/Range").get("lowerLimit")),
                                       float(d.find("UniformDistribution/Range").get("upperLimit")))
              for d in root.iter("StochasticDistribution") if d.find("UniformDistribution") is not None}
    assert ranges == {p.name: (p.low, p.high) for p in sampling.parameters if p.sampled}
    pools = {d.get("parameterName"): [e.get("value") for e in d.iter("Element")]
             for d in root.iter("StochasticDistribution") if d.find("ProbabilityDistributionSet") is not None}
    assert pools == {"npc1_MODEL": sampling.blueprint_pools["npc1"]}
    scenario = ET.parse(export.result.scenario).getroot()
    declared = {p.get("name") for p in scenario.iter("ParameterDeclaration")}
    assert set(ranges) | set(pools) <= declared
    assert root.find("ParameterValueDistribution/ScenarioFile").get("filepath") == "scenario.xosc"
    stochastic = root.find("ParameterValueDistribution/Stochastic")
    assert int(stochastic.get("numberOfTestRuns")) == RUN_VARIATIONS and float(stochastic.get("randomSeed")) == RUN_SEED
