"""The plan's model of a driver steering across (embedded.swerve.path) is the simulator's own pure pursuit: the
same path as the embedded simulator drives, step for step."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pyarrow.parquet as pq
import pytest

from crashscene.dsl import loads
from crashscene.pipeline.simulate import simulate_scenario
from crashscene.simulate.embedded import swerve, timing
from crashscene.simulate.embedded.vehicles import limits_for

DRIFT = """dsl_version: 1
environment: {weather: clear, time_of_day: daytime, road_surface: dry}
road_network:
  road_type: straight
  number_of_ways: 2
  number_of_lanes: 2
  road_marker: broken_line
  traffic_signs: [speed_limit_sign]
  speed_limit_mph: 45
actors:
  ego:
    type: car
    behavior: cross_centerline
    position: {reference: road, relation: behind}
  npc1:
    type: car
    behavior: go_forward
    position: {reference: ego, relation: behind, heading: same_direction}
oracle: []
collisions: []
"""


@pytest.mark.slow
def test_the_planned_path_of_a_drift_across_is_the_simulated_one(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate_scenario(loads(DRIFT), tmp_path, 2, 3, mode="reproduce")
    traces = pq.read_table(tmp_path / "traces.parquet", columns=["variation", "actor", "x", "y", "yaw", "speed"])
    rows = traces.to_pandas()
    length = pq.read_table(tmp_path / "actors.parquet").to_pandas().set_index(["variation", "actor"])["length"]
    limits = limits_for("car")
    checked = 0
    for v in range(2):
        ego = rows[(rows.variation == v) & (rows.actor == "ego")].reset_index(drop=True)
        moved = np.nonzero(np.abs(ego.y.to_numpy() - ego.y[0]) > 1e-9)[0]
        if not len(moved) or moved[0] < 1:
            continue
        k0 = moved[0] - 1  # the last step before it leaves its lane centre: the manoeuvre starts in the next
        # across to the oncoming lane's centre (a lane's width) at the drift's lateral rate
        x, y, yaw = swerve.path(float(ego.speed[k0]), 3.5, timing.lateral_rate("cross_centerline"),
                                float(length[(v, "ego")]) * limits.wheelbase_ratio,
                                limits.steer_rate, limits.steer_max, 0.1)
        n = min(30, len(ego) - k0 - 1)
        got = ego.iloc[k0 + 1:k0 + 1 + n]
        assert np.allclose(got.x - ego.x[k0], x[0, :n], atol=1e-6)
        assert np.allclose(got.y - ego.y[k0], y[0, :n], atol=1e-6)
        assert np.allclose(got.yaw, yaw[0, :n], atol=1e-9)
        checked += 1
    assert checked, "no drift started in the run"


def test_the_path_turns_toward_the_offset_and_settles_there():
    x, y, yaw = swerve.path(20.0, -3.5, 2.0, 2.8, math.radians(60), math.radians(35), 0.1)
    assert y[0, -1] == pytest.approx(-3.5, abs=0.05) and yaw.min() < -0.05 and abs(yaw[0, -1]) < 0.01
    assert np.all(np.diff(x[0]) > 0)


def test_bicycle_before_is_the_pose_one_bicycle_move_takes_to_the_given_one():
    """A car at 28 m/s turning at -0.055 rad/s (a driver drifting to the road's edge) reaches pose (10, -2, -0.02)
    0.06 s after the pose bicycle_before gives: less turned by 0.0033 rad, 1.68 m back along its mid heading."""
    from crashscene.simulate.embedded.swerve import bicycle_before, bicycle_move

    x0, y0, yaw0 = bicycle_before(10.0, -2.0, -0.02, 28.0, -0.055, 0.06)
    assert yaw0 == pytest.approx(-0.02 + 0.055 * 0.06)
    assert bicycle_move(x0, y0, yaw0, 28.0, -0.055, 0.06) == pytest.approx((10.0, -2.0, -0.02), abs=1e-12)
    assert math.hypot(10.0 - x0, -2.0 - y0) == pytest.approx(28.0 * 0.06)
