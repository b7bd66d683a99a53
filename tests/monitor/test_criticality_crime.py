"""Cross-check against CommonRoad-CriMe (commonroad-crime 0.4.5) where it computes the same measure.

CriMe is not a dependency: it pins protobuf 3.20 (onnxruntime, which extraction needs, wants a newer one),
so it cannot share crashscene's environment. This test runs where CriMe is installed (a separate venv:
`pip install commonroad-crime pyarrow pydantic pyyaml pytest`, then
`PYTHONPATH=src:. python -m pytest tests/monitor/test_criticality_crime.py`) and is skipped elsewhere.
Scene: a straight lane (heading 0.05 rad); ego 4 x 2 m at 20 m/s, a 4 x 2 m car stopped with its rear 40 m ahead of
the ego's front.
"""
from __future__ import annotations

import numpy as np
import pytest

crime = pytest.importorskip("commonroad_crime")

from crashscene.monitor.arrays import build_arrays  # noqa: E402
from crashscene.monitor.criticality import criticality_table  # noqa: E402
from tests.monitor.builders import tables, track  # noqa: E402

DT = 0.1  # [s]
STEPS = 40  # CriMe's headway follows the predicted trajectory until the ego reaches the other car
EGO_X, OTHER_X, SPEED = 20.0, 64.0, 20.0  # [m] along the lane, [m], [m/s]
ANGLE = 0.05  # [rad] lane direction (CriMe's required deceleration treats an orientation of exactly 0 as none)
U = np.array([np.cos(ANGLE), np.sin(ANGLE)])
N = np.array([-np.sin(ANGLE), np.cos(ANGLE)])


def _scenario():
    from commonroad.geometry.shape import Rectangle
    from commonroad.prediction.prediction import TrajectoryPrediction
    from commonroad.scenario.lanelet import Lanelet
    from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
    from commonroad.scenario.scenario import Scenario
    from commonroad.scenario.state import CustomState, InitialState
    from commonroad.scenario.trajectory import Trajectory

    xs = np.linspace(0.0, 300.0, 61)[:, None]
    lanelet = Lanelet(xs * U + 2.0 * N, xs * U, xs * U - 2.0 * N, 100)
    scenario = Scenario(dt=DT)
    scenario.add_objects(lanelet)
    for oid, x0, v in ((1, EGO_X, SPEED), (2, OTHER_X, 0.0)):
        def state(k, cls=CustomState):
            extra = {"velocity_y": 0.0, "acceleration_y": 0.0} if cls is CustomState else {}
            return cls(time_step=k, position=(x0 + v * k * DT) * U, orientation=ANGLE, velocity=v,
                       acceleration=0.0, yaw_rate=0.0, slip_angle=0.0, **extra)
        traj = Trajectory(1, [state(k) for k in range(1, STEPS)])
        shape = Rectangle(4.0, 2.0)
        scenario.add_objects(DynamicObstacle(oid, ObstacleType.CAR, shape, state(0, InitialState),
                                             TrajectoryPrediction(traj, shape, center_lanelet_assignment={
                                                 k: {100} for k in range(STEPS)}, shape_lanelet_assignment={
                                                 k: {100} for k in range(STEPS)})))
    return scenario


def _crime(measure_cls):
    from commonroad_crime.data_structure.configuration import CriMeConfiguration

    config = CriMeConfiguration()
    config.update(ego_id=1, sce=_scenario())
    return measure_cls(config).compute(2, 1, verbose=False)   # step 1: the first state with velocity_y


def _ours() -> dict:
    tabs = tables({"ego": track(steps=STEPS, x0=EGO_X * U[0], y0=EGO_X * U[1], yaw=ANGLE, speed=SPEED,
                                length=4.0, width=2.0),
                   "npc1": track(steps=STEPS, x0=OTHER_X * U[0], y0=OTHER_X * U[1], yaw=ANGLE, speed=0.0,
                                 length=4.0, width=2.0)})
    arrays = build_arrays(tabs)
    arrays.truncate(np.ones(arrays.shape[:2], dtype=int))   # steps 0 and 1: the metrics at step 1 are the extremes
    return criticality_table(arrays).to_pylist()[0]


def test_ttc_matches_crime():
    from commonroad_crime.measure.time.ttc import TTC

    # CriMe measures the gap along its curvilinear frame of the lanelet (1.89 s against 1.90 s)
    assert _ours()["min_ttc"] == pytest.approx(_crime(TTC), abs=0.05)


def test_headway_matches_crime():
    from commonroad_crime.measure.time.thw import THW

    # CriMe counts whole steps of the predicted trajectory until the ego is strictly past: up to one step more
    assert _ours()["min_thw"] == pytest.approx(_crime(THW), abs=DT + 1e-9)


def test_drac_matches_crime_required_deceleration():
    from commonroad_crime.measure.acceleration.a_long_req import ALongReq

    # the same v^2 / (2 gap), CriMe's gap from its curvilinear projection (5.28 against 5.26 m/s2)
    assert _ours()["max_drac"] == pytest.approx(abs(_crime(ALongReq)), abs=0.05)


def test_delta_v_matches_crime_equal_masses():
    from commonroad_crime.measure.velocity.delta_v import DeltaV
    from commonroad_crime.data_structure.configuration import CriMeConfiguration

    config = CriMeConfiguration()
    config.update(ego_id=1, sce=_scenario())
    theirs = DeltaV(config).compute(1, 2, verbose=False)   # step 1: the first state with velocity_y
    # ours at the contact of the same two cars (equal masses: each changes by half the closing speed)
    tabs = tables({"ego": track(steps=STEPS, x0=EGO_X * U[0], y0=EGO_X * U[1], yaw=ANGLE, speed=SPEED,
                                length=4.0, width=2.0),
                   "npc1": track(steps=STEPS, x0=OTHER_X * U[0], y0=OTHER_X * U[1], yaw=ANGLE, speed=0.0,
                                 length=4.0, width=2.0)})
    row = criticality_table(build_arrays(tabs)).to_pylist()[0]
    assert row["delta_v_a"] == pytest.approx(theirs, abs=0.01)
