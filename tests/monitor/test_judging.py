"""How long the monitor judges an actor (monitor.judging): on after a light contact that leaves its driver in control,
up to a short grace after a contact that upsets it; the right-of-way conflict paths end at the upsetting contact."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.monitor import evaluate
from crashscene.monitor.arrays import build_arrays
from crashscene.monitor.conflicts import path_conflicts
from crashscene.monitor.judging import contact_change, contact_indices, contact_steps, upset_steps
from crashscene.upset import CONTROL_DELTA_V, CONTROL_YAW_RATE
from tests.monitor.builders import DT, tables, track
from tests.monitor.conftest import rule_row

STEPS = 80
CONTACT_STEP = 20


def _drift_after_contact(speed_after: float) -> dict:
    """The ego, 20 m/s, touched at step 20 (a simulator contact, no footprint overlap), its speed `speed_after`
    from then on; from step 30 to 50 its centre is in the opposing lane over a double solid line."""
    speed = np.full(STEPS, 20.0)
    speed[CONTACT_STEP:] = speed_after
    opposing = np.zeros(STEPS, dtype=bool)
    opposing[30:50] = True
    ego = track(STEPS, speed=speed, opposing_lane=opposing, centerline_marker="double_solid_line")
    npc = track(STEPS, y0=-2.2, x0=5.0, speed=18.0)  # alongside to the right, footprints clear
    contact = {"variation": 0, "t": CONTACT_STEP * DT, "actor_a": "ego", "actor_b": "npc1", "speed_a": 20.0,
               "speed_b": 18.0, "yaw_a": 0.0, "yaw_b": 0.0, "x": 0.0, "y": 0.0}
    return tables({"ego": ego, "npc1": npc}, collisions=[contact])


def test_a_light_contact_leaves_the_driver_judged():
    # the velocity changes by less than CONTROL_DELTA_V: the drift into the opposing lane afterwards is driving
    result = evaluate(_drift_after_contact(20.0 - (CONTROL_DELTA_V - 0.5)), None)
    row = rule_row(result, "CVC_21650", "ego")
    assert row["verdict"] == "violated" and row["first_violation_t"] == pytest.approx(3.4)


def test_an_upsetting_contact_ends_judging():
    # the same drift after an impact that changed the velocity by more than CONTROL_DELTA_V is not driving
    result = evaluate(_drift_after_contact(20.0 - (CONTROL_DELTA_V + 0.5)), None)
    assert rule_row(result, "CVC_21650", "ego")["verdict"] == "satisfied"


def test_vehicles_passing_through_each_other_are_not_driven():
    # no velocity change, but the footprints still overlap half a second after the onset: a backend without
    # contact physics let the follower drive through its leader; what follows is not judged
    actors = {"ego": track(STEPS, speed=15.0, lane_id="L"), "npc1": track(STEPS, x0=25.0, speed=7.0, lane_id="L")}
    result = evaluate(tables(actors), None)
    assert rule_row(result, "CVC_21703", "npc1")["verdict"] != "violated"


def test_contact_change_from_positions_and_headings():
    # before: 10 m/s straight; after the contact at step 20: 7 m/s at 30 deg and turning at 0.6 rad/s
    yaw = np.zeros(40)
    yaw[CONTACT_STEP:] = np.radians(30) + 0.6 * DT * np.arange(40 - CONTACT_STEP)
    speed = np.where(np.arange(40) < CONTACT_STEP, 10.0, 7.0)
    step = np.concatenate([[0.0], speed[:-1] * DT])
    heading = np.concatenate([[0.0], yaw[:-1]])
    x, y = np.cumsum(step * np.cos(heading)), np.cumsum(step * np.sin(heading))
    arrays = build_arrays(tables({"ego": {"x": x, "y": y, "yaw": yaw, "speed": speed}}))
    dv, dw = contact_change(arrays, np.array([0]), np.array([0]), np.array([CONTACT_STEP]))
    after = [np.radians(30) + 0.6 * DT * k for k in (0, 1)]  # the heading over each step after it
    change = [np.hypot(7.0 * np.cos(h) - 10.0, 7.0 * np.sin(h)) for h in after]
    assert dv[0] == pytest.approx(max(change), rel=1e-9)
    assert dw[0] == pytest.approx(0.6, rel=1e-6) and dw[0] > CONTROL_YAW_RATE


def test_a_vehicle_stopped_where_it_touched_is_upset():
    # a backend without contact physics stops both vehicles at the contact: the whole speed is the change
    speed = np.where(np.arange(STEPS) < CONTACT_STEP, 10.0, 0.0)
    actors = {"ego": track(STEPS, speed=speed), "npc1": track(STEPS, x0=60.0, speed=0.0, behavior="stop")}
    contact = {"variation": 0, "t": CONTACT_STEP * DT - 0.05, "actor_a": "ego", "actor_b": "npc1", "speed_a": 10.0,
               "speed_b": 0.0, "yaw_a": 0.0, "yaw_b": 0.0, "x": 0.0, "y": 0.0}
    t = tables(actors, collisions=[contact])
    arrays = build_arrays(t)
    from crashscene.monitor.collisions import classify_collisions
    collisions = classify_collisions(arrays, t["collisions"], arrays.is_ads & arrays.present)
    # the stopped npc1's velocity did not change: it keeps its driver; the ego is upset at the contact's step
    assert upset_steps(arrays, collisions, 5)[0].tolist() == [CONTACT_STEP, -1]
    assert contact_steps(np.array([1.95, 2.0]), DT).tolist() == [20, 20]


def test_contact_indices_map_each_contact_to_its_variation_actors_and_step():
    # a contact 0.3 steps after step 19: its state is recorded at step 20; the nearest step is 19
    actors = {"ego": track(STEPS, speed=10.0), "npc1": track(STEPS, x0=60.0, speed=0.0, behavior="stop")}
    contact = {"variation": 0, "t": (CONTACT_STEP - 0.7) * DT, "actor_a": "npc1", "actor_b": "ego",
               "speed_a": 0.0, "speed_b": 10.0, "yaw_a": 0.0, "yaw_b": 0.0, "x": 0.0, "y": 0.0}
    t = tables(actors, collisions=[contact])
    arrays = build_arrays(t)
    v, a, b, step = contact_indices(arrays, t["collisions"])
    assert (v.tolist(), a.tolist(), b.tolist(), step.tolist()) == ([0], [1], [0], [CONTACT_STEP])
    assert contact_indices(arrays, t["collisions"], rounded=True)[3].tolist() == [CONTACT_STEP - 1]


def test_a_conflict_path_ends_where_the_impact_upset_the_vehicle():
    # npc1 drives north toward the ego's lane (y = 0) and, at step 12, still 8 m short of it, is turned east by an
    # impact: its recorded path never crosses the ego's; the path it drove (and its straight extension) does
    n = 30
    yaw = np.where(np.arange(n) <= 12, np.pi / 2, 0.0)
    x = np.zeros(n)
    y = -20.0 + np.minimum(np.arange(n), 12) * 1.0
    x[13:] = np.arange(1, n - 12) * 1.0
    npc = {"x": x, "y": y, "yaw": yaw, "speed": np.full(n, 10.0), "in_junction": np.ones(n, dtype=bool)}
    ego = track(n, x0=-10.0, speed=1.0, in_junction=np.ones(n, dtype=bool))
    arrays = build_arrays(tables({"ego": ego, "npc1": npc}))
    free = path_conflicts(arrays)
    ended = path_conflicts(arrays, last_step=np.array([[-1, 12]]))
    assert not free.crossing[0, 1, 0]
    assert ended.crossing[0, 1, 0] and ended.s_enter[0, 1, 0] == pytest.approx(12.0 + 8.0 - 4.5 / 2, abs=2.1)


def test_a_conflict_path_keeps_its_last_step():
    # npc1's trace ends at step 17 (odd: between the stride's samples), when its front has just reached the ego's
    # path: that is where it entered it, not a point of the straight extension past it (which has no step)
    n = 18
    k = np.arange(n)
    npc = {"x": np.zeros(n), "y": -20.5 + k * 1.0, "yaw": np.full(n, np.pi / 2), "speed": np.full(n, 10.0),
           "in_junction": np.ones(n, dtype=bool)}
    ego = track(n, x0=-10.0, speed=1.0, in_junction=np.ones(n, dtype=bool))
    arrays = build_arrays(tables({"ego": ego, "npc1": npc}))
    conflicts = path_conflicts(arrays, stride=2)
    assert conflicts.crossing[0, 1, 0] and conflicts.enter[0, 1, 0] == 17
