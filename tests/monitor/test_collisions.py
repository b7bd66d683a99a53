"""Collision detection from footprints, merging with simulator contacts, and the four classes."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.monitor import evaluate
from tests.monitor.builders import tables, track

STEPS = 60


def only(result) -> dict:
    rows = result.collisions.to_pylist()
    assert len(rows) == 1, rows
    return rows[0]


def test_rear_end_striker_is_the_follower():
    actors = {"ego": track(STEPS, speed=15.0), "npc1": track(STEPS, x0=20.0, speed=5.0)}
    row = only(evaluate(tables(actors), None))
    assert row["class"] == "rear_end" and row["striking_actor"] == "ego"
    assert row["source"] == "footprint" and row["involves_ads"]
    # first contact: gap 20 - 4.5 closes at 10 m/s
    assert abs(row["t"] - 1.6) < 0.11


def test_head_on():
    actors = {"ego": track(STEPS, speed=10.0), "npc1": track(STEPS, x0=60.0, y0=0.3, yaw=np.pi, speed=10.0)}
    assert only(evaluate(tables(actors), None))["class"] == "head_on"


def test_angle_t_bone_striker():
    # npc1 northbound hits the ego's right side
    actors = {"ego": track(STEPS, x0=-20.0, speed=10.0), "npc1": track(STEPS, x0=0.0, y0=-21.0, yaw=np.pi / 2, speed=10.0)}
    row = only(evaluate(tables(actors), None))
    assert row["class"] == "angle" and 80 < row["relative_heading_deg"] < 100


def test_sideswipe_same_direction():
    y = np.full(STEPS, 3.5)
    y[10:] = np.maximum(3.5 - 0.1 * np.arange(STEPS - 10), 1.0)
    npc = track(STEPS, x0=0.0, speed=10.0)
    npc["y"] = y
    row = only(evaluate(tables({"ego": track(STEPS, speed=10.0), "npc1": npc}), None))
    assert row["class"] == "sideswipe" and row["striking_actor"] is None


def test_no_contact_no_row():
    actors = {"ego": track(STEPS, speed=10.0), "npc1": track(STEPS, y0=3.5, speed=10.0)}
    assert evaluate(tables(actors), None).collisions.num_rows == 0


def test_simulator_contact_only_is_kept_and_classified():
    # the footprints never overlap (a backend with coarser geometry reported contact)
    actors = {"ego": track(STEPS, speed=10.0), "npc1": track(STEPS, x0=6.0, speed=10.0)}
    contact = {"variation": 0, "t": 2.0, "actor_a": "npc1", "actor_b": "ego", "speed_a": 10.0, "speed_b": 10.0,
               "yaw_a": 0.0, "yaw_b": 0.0, "x": 5.0, "y": 0.0}
    row = only(evaluate(tables(actors, collisions=[contact]), None))
    assert row["source"] == "simulator" and row["actor_a"] == "ego" and row["class"] == "rear_end"
    assert row["t"] == 2.0 and row["x"] == 5.0


def test_both_sources_counted_once_per_pair_and_variation():
    actors = {"ego": track(STEPS, speed=15.0), "npc1": track(STEPS, x0=20.0, speed=5.0)}
    contact = {"variation": 0, "t": 1.7, "actor_a": "ego", "actor_b": "npc1", "speed_a": 15.0, "speed_b": 5.0,
               "yaw_a": 0.0, "yaw_b": 0.0, "x": 10.0, "y": 0.0}
    result = evaluate(tables(actors, collisions=[contact, {**contact, "t": 2.5}]), None)
    row = only(result)
    assert row["source"] == "both" and row["t"] == pytest.approx(1.6, abs=0.11)
    assert result.summary()["collisions"]["rear_end"] == 1
