"""The closed-loop meeting of reproduce mode (simulate.embedded.sync.Meeting): the follower aims at the leader's
arrival, and a leader braking for the curve of its turn is expected to brake on to the speed that curve allows."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.embedded.sync import Meeting, braking_time


def test_braking_time_brakes_to_the_end_speed_then_holds_it():
    # 12 -> 6 m/s at 2 m/s2 takes 3 s over 27 m; the last 3 m at 6 m/s
    assert braking_time(np.array([30.0]), np.array([12.0]), np.array([2.0]), np.array([6.0]))[0] == pytest.approx(3.5)
    # within the braking distance: 12 t - t^2 = 11 -> t = 1
    assert braking_time(np.array([11.0]), np.array([12.0]), np.array([2.0]), np.array([6.0]))[0] == pytest.approx(1.0)


def meeting(turn_speed: float) -> Meeting:
    m = Meeting.none(1)
    m.follower[0], m.leader[0] = 0, 1
    m.cs_follower[0], m.cs_leader[0] = 60.0, 30.0
    m.follower_strikes[0] = True
    m.leader_turn_speed[0] = turn_speed
    return m


@pytest.mark.parametrize("turn_speed, eta", [(6.0, 3.5), (np.inf, 2.5)])
def test_the_follower_aims_at_a_braking_leaders_arrival_at_its_turn_speed(turn_speed, eta):
    """The leader is 30 m from the conflict point at 12 m/s, braking at 2 m/s2 for a curve taken at 6 m/s: it
    arrives in 3.5 s, not the 2.5 s its present speed gives; the striking follower, 50 m from its conflict point,
    meets it there its reach plus the struck offset later."""
    s, v = np.array([[10.0, 0.0]]), np.array([[15.0, 12.0]])
    accel = np.array([[0.0, -2.0]])
    length, width = np.array([[4.5, 4.5]]), np.array([[1.8, 1.8]])
    planned = np.array([[15.0, 12.0]])
    idx, cruise = meeting(turn_speed).cruise(s, v, accel, length, width, planned, planned.copy())
    side_hit = (4.5 / 2 + 1.8 / 2) / 15.0
    assert list(idx) == [0] and cruise[0] == pytest.approx(50.0 / (eta + side_hit))
