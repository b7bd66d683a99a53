"""Who keeps control after an impact (crashscene.upset.upsets): a vehicle the impulse barely changes drives on
(in its lane's centre), one it upsets slides out of its driver's control."""
from __future__ import annotations

import numpy as np

from crashscene import upset
from crashscene.dsl import load_file
from crashscene.scene import SampledScene
from crashscene.simulate.backend import SimulationSettings
from crashscene.simulate.embedded import setup
from crashscene.simulate.embedded.record import Recorder
from crashscene.simulate.embedded.simulator import run_batch
from crashscene.simulate.roads import RoadMap

from .conftest import EXAMPLES, LANE, actor
from .test_embedded import actor_trace, run


def test_upsets_at_the_declared_delta_v_and_yaw_rate():
    dv = np.array([0.0, upset.CONTROL_DELTA_V - 0.01, upset.CONTROL_DELTA_V, 1.0, 1.0])
    dw = np.array([0.0, 0.0, 0.0, upset.CONTROL_YAW_RATE, -upset.CONTROL_YAW_RATE])
    assert upset.upsets(dv, dw).tolist() == [False, False, True, True, True]


def test_a_heavy_striker_barely_upset_by_the_impact_drives_on_and_the_car_it_hits_slides(straight_map):
    # a heavy truck follows a braking car too closely and rear-ends it: the truck's own delta-v is about a tenth
    # of the car's, so its driver keeps control (it accelerates back to its speed), while the car slides out of
    # control (it never accelerates again)
    case = EXAMPLES / "109176" / "golden.yaml"  # npc1 decelerates in front; ego CVC_21703
    truck = {"type": "truck", "blueprint": "vehicle.carlamotors.european_hgv", "length": 7.94, "width": 2.89}
    scenes = [SampledScene(index=i, seed=5, scenario_hash="h", map_file=str(straight_map), params={
        "npc1_TRIGGER_TIME": 2.0}, actors=[
        actor("ego", 40.0, -LANE / 2, 0.0, 20.0, dispositions=["CVC_21703"]).model_copy(update=truck),
        actor("npc1", 40.0 + 26.0 + i, -LANE / 2, 0.0, 20.0, behavior="decelerate",
              reference="ego", relation="front", heading="same_direction")]) for i in range(6)]
    tables = run(case, scenes, straight_map, mode="reproduce")
    first = {}
    for r in tables["collisions"].to_pylist():
        first.setdefault(r["variation"], r)
    assert len(first) >= 4
    for v, contact in first.items():
        assert contact["delta_v_a"] < upset.CONTROL_DELTA_V < contact["delta_v_b"]
        truck_trace, car = actor_trace(tables, v, "ego"), actor_trace(tables, v, "npc1")
        assert (truck_trace["accel"][truck_trace["t"] > contact["t"] + 0.05] > 0.1).any()
        assert (car["accel"][car["t"] > contact["t"] + 0.05] <= 1e-9).all()


def test_a_driver_still_in_control_after_a_contact_holds_its_lanes_centre(straight_map):
    # the same truck told by its plan to drive 0.8 m left of its lane's centre: after the rear-end it keeps control
    # and steers back to the centre (a truck that knocked a car aside from its corner drives on in its lane)
    case = EXAMPLES / "109176" / "golden.yaml"
    truck = {"type": "truck", "blueprint": "vehicle.carlamotors.european_hgv", "length": 7.94, "width": 2.89}
    scenes = [SampledScene(index=i, seed=5, scenario_hash="h", map_file=str(straight_map), params={
        "npc1_TRIGGER_TIME": 2.0}, actors=[
        actor("ego", 40.0, -LANE / 2, 0.0, 20.0, dispositions=["CVC_21703"]).model_copy(update=truck),
        actor("npc1", 40.0 + 40.0 + i, -LANE / 2, 0.0, 20.0, behavior="decelerate",
              reference="ego", relation="front", heading="same_direction")]) for i in range(4)]
    settings = SimulationSettings(mode="reproduce")
    roadmap = RoadMap.load(straight_map)
    batch = setup.build(load_file(case), scenes, roadmap, settings)
    batch.lateral_target[:, 0] = 0.8  # [m] left of the lane's centre (the drivers hold views of this column)
    recorder = Recorder(roadmap, settings)
    run_batch(batch, recorder)
    tables = recorder.tables(scenes)
    first = {}
    for r in tables["collisions"].to_pylist():
        first.setdefault(r["variation"], r)
    assert len(first) >= 3
    for v, contact in first.items():
        trace = actor_trace(tables, v, "ego")
        before = (trace["t"] > contact["t"] - 0.5) & (trace["t"] < contact["t"])
        later = trace["t"] > contact["t"] + 3.0
        d = trace["y"] + LANE / 2  # [m] left of the lane's centre (the straight map runs along x)
        assert np.all(d[before] > 0.5) and np.all(np.abs(d[later]) < 0.25)



def test_a_driver_to_leave_the_road_holds_the_offset_it_starts_at_until_its_trigger(straight_map):
    # a plan that starts a drifting driver partway across (cascade_plan._drift_into: into the corner of a
    # parked car) has it drift from its trigger on, as its prediction of the impact (cascade.Push.approach) has it:
    # before the trigger it holds that offset, it does not steer back to its lane's centre
    from crashscene.dsl import loads

    from .test_swerve import DRIFT

    scenes = [SampledScene(index=i, seed=5, scenario_hash="h", map_file=str(straight_map), params={},
                           actors=[actor("ego", 40.0 + i, -LANE / 2 + 1.0, 0.0, 20.0, behavior="leave_road")])
              for i in range(3)]
    settings = SimulationSettings(mode="reproduce", horizon=4.0)
    roadmap = RoadMap.load(straight_map)
    batch = setup.build(loads(DRIFT.replace("cross_centerline", "leave_road")), scenes, roadmap, settings)
    batch.d0[:, 0], batch.trigger_time[:, 0], batch.lateral_target[:, 0] = 1.0, 2.0, -6.0
    recorder = Recorder(roadmap, settings)
    run_batch(batch, recorder)
    tables = recorder.tables(scenes)
    for v in range(3):
        trace = actor_trace(tables, v, "ego")
        d = trace["y"] + LANE / 2  # [m] left of the lane's centre (the straight map runs along x)
        before, later = trace["t"] <= 2.0, trace["t"] >= 3.5
        assert np.all(np.abs(d[before] - 1.0) < 0.05) and np.all(d[later] < 0.5)
