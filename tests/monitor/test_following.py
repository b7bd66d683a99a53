"""CVC 21703: following too closely."""
from __future__ import annotations

import numpy as np

from tests.monitor.builders import tables, track

SPEED = 15.0  # [m/s]


def pair(headway: float, leader_speed: float = SPEED, lane_ids: bool = True) -> dict:
    gap = headway * SPEED
    lane = {"lane_id": "road1_lane-1"} if lane_ids else {}
    return {"ego": track(50, x0=0.0, speed=SPEED, **lane),
            "npc1": track(50, x0=gap + 4.5, speed=leader_speed, **lane)}


def test_headway_just_below_is_violated(check):
    row = check(tables(pair(1.9)), "CVC_21703", "ego")
    assert row["verdict"] == "violated" and abs(row["measured"] - 1.9) < 1e-6


def test_headway_just_above_is_satisfied_with_advisory(check):
    row = check(tables(pair(2.1)), "CVC_21703", "ego")
    assert row["verdict"] == "satisfied" and "advisory" in row["note"]


def test_slow_leader_is_not_applicable(check):
    assert check(tables(pair(1.0, leader_speed=4.0)), "CVC_21703", "ego")["verdict"] == "not_applicable"


def test_geometric_same_lane_without_lane_ids(check):
    assert check(tables(pair(1.5, lane_ids=False)), "CVC_21703", "ego")["verdict"] == "violated"


def test_leader_in_other_lane_is_not_followed(check):
    actors = {"ego": track(50, speed=SPEED, lane_id="a"), "npc1": track(50, x0=10, y0=3.5, speed=SPEED, lane_id="b")}
    assert check(tables(actors), "CVC_21703", "ego")["verdict"] == "not_applicable"


def test_spawned_close_then_opening_the_gap_is_satisfied(check):
    ego_speed = np.full(50, SPEED)
    ego_speed[5:30] = 8.0  # drops back from the spawned 1 s headway to over 2 s
    actors = {"ego": track(50, speed=ego_speed, lane_id="L"), "npc1": track(50, x0=15 + 4.5, speed=SPEED, lane_id="L")}
    row = check(tables(actors), "CVC_21703", "ego")
    assert row["verdict"] == "satisfied" and row["measured"] > 2.0


def test_start_grace_is_for_the_ads_only(check):
    # the same close spawn: the ADS gets the grace, a scripted NPC does not
    actors = {"ego": track(25, speed=SPEED, lane_id="L"),
              "npc1": track(25, x0=15 + 4.5, speed=SPEED, lane_id="L")}
    assert check(tables(actors, ads=()), "CVC_21703", "ego")["verdict"] == "violated"
    assert check(tables(actors, ads=("ego",)), "CVC_21703", "ego")["verdict"] == "satisfied"
