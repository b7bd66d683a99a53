"""Fixtures for the simulate tests: small OpenDRIVE maps built with scenariogeneration, hand-made scenes."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scenariogeneration import xodr

from crashscene.scene import SampledActor, SampledScene

TOWN02 = Path(__file__).parents[1] / "data" / "maps" / "carla" / "Town02.xodr"
EXAMPLES = Path(__file__).parents[2] / "examples" / "ciren"
LANE = 3.5  # [m]


def write_four_way(path: Path, arm: float = 150.0) -> Path:
    """A 4-way junction of two-lane two-way roads, centred near (162, 0); road 1 arrives from the west along +x."""
    roads = [xodr.create_road(xodr.Line(arm), id=i + 1, left_lanes=1, right_lanes=1, lane_width=LANE)
             for i in range(4)]
    junction = xodr.CommonJunctionCreator(100, "junction", startnum=100)
    for i, road in enumerate(roads):
        junction.add_incoming_road_circular_geometry(road, 12, i * math.pi / 2, "successor")
    for i in range(4):
        for j in range(4):
            if i != j:
                junction.add_connection(road_one_id=i + 1, road_two_id=j + 1, lane_one_id=-1, lane_two_id=1)
    odr = xodr.OpenDrive("four_way")
    for road in roads:
        odr.add_road(road)
    odr.add_junction_creator(junction)
    odr.adjust_roads_and_lanes()
    odr.write_xml(str(path))
    return path


def write_straight(path: Path, length: float = 600.0, marker=xodr.std_roadmark_solid_solid) -> Path:
    """A straight two-lane two-way road along +x from x = 0, centre line on y = 0."""
    road = xodr.create_road(xodr.Line(length), id=1, left_lanes=1, right_lanes=1, lane_width=LANE,
                            center_road_mark=marker())
    odr = xodr.OpenDrive("straight")
    odr.add_road(road)
    odr.adjust_roads_and_lanes()
    odr.write_xml(str(path))
    return path


@pytest.fixture(scope="session")
def four_way_map(tmp_path_factory) -> Path:
    return write_four_way(tmp_path_factory.mktemp("maps") / "four_way.xodr")


@pytest.fixture(scope="session")
def straight_map(tmp_path_factory) -> Path:
    return write_straight(tmp_path_factory.mktemp("maps") / "straight.xodr")


def actor(role: str, x: float, y: float, yaw: float, speed: float, behavior: str = "go_forward",
          intent: str = "straight", dispositions=(), reference: str = "road", relation: str = "behind",
          heading: str | None = None) -> SampledActor:
    return SampledActor(role=role, type="car", blueprint="vehicle.lincoln.mkz_2017", behavior=behavior, x=x, y=y,
                        yaw=yaw, speed=speed, length=4.6, width=1.9, route_intent=intent, reference=reference,
                        relation=relation, heading_relation=heading, dispositions=list(dispositions))


def crossing_scenes(map_file: Path, n: int, seed: int = 1, npc_dispositions=("CVC_21803",)) -> list[SampledScene]:
    """Ego eastbound toward the 4-way junction, npc1 northbound from the ego's right."""
    rng = np.random.default_rng(seed)
    scenes = []
    for i in range(n):
        scenes.append(SampledScene(index=i, seed=seed, scenario_hash="test", map_file=str(map_file), actors=[
            actor("ego", 105 + rng.uniform(-10, 10), -LANE / 2, 0.0, rng.uniform(10, 12),
                  reference="intersection"),
            actor("npc1", 163.75, -60 + rng.uniform(-10, 10), math.pi / 2, rng.uniform(10, 12),
                  dispositions=npc_dispositions, reference="yield_sign", relation="right", heading="from_right"),
        ]))
    return scenes
