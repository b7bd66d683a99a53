"""Timing plans and signal phases of the embedded backend (pure functions)."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.embedded import signals, timing
from crashscene.simulate.embedded.setup import variation_rng


def test_arrival_time_cruise_rest_and_stop():
    assert timing.arrival_time(100.0, 10.0, 3.0) == pytest.approx(10.0)
    # from rest: 10 m/s reached after 16.7 m, then cruise
    assert timing.arrival_time(100.0, 10.0, 3.0, from_rest=True) == pytest.approx(10 / 3 + (100 - 100 / 6) / 10)
    with_stop = timing.arrival_time(60.0, 10.0, 3.0, stop_dist=30.0)
    assert with_stop > timing.arrival_time(60.0, 10.0, 3.0) + timing.STOP_DWELL


def test_junction_plan_scales_then_holds():
    scale, hold = timing.junction_plan(t_target=10.0, dist=100.0, speed=10.0, accel=3.0)
    assert hold == 0.0 and scale == pytest.approx(1.0)
    scale, hold = timing.junction_plan(t_target=12.0, dist=100.0, speed=10.0, accel=3.0)
    assert hold == 0.0 and scale == pytest.approx(10 / 12, rel=1e-6)
    scale, hold = timing.junction_plan(t_target=40.0, dist=100.0, speed=10.0, accel=3.0)
    assert scale == timing.SPEED_SCALE[0] and hold > 0


def test_lateral_trigger_meets_the_oncoming_car():
    # 200 m apart, 15 m/s each: they meet after 6.67 s; a 3.5 m swerve at 2 m/s takes 1.75 s
    t = timing.lateral_trigger(200.0, 15.0, 15.0, True, 3.5, 1.0, rate=2.0)
    assert t == pytest.approx(200 / 30 - 1.75 - 1.0)
    assert timing.lateral_trigger(20.0, 15.0, 15.0, True, 3.5, 1.0, rate=2.0) < 0  # already too close


def test_signal_phase_gives_green_at_arrival_or_red_to_a_red_runner():
    arrival = np.array([4.0, 9.0])
    phase = signals.phase_for(arrival, np.array([5.0, 5.0]), anchor_runs_red=False)
    assert signals.signal_state(np.zeros(2, dtype=int), 4.0, phase)[0] == 1
    assert signals.signal_state(np.zeros(2, dtype=int), 9.0, phase)[1] == 1
    assert signals.signal_state(np.ones(2, dtype=int), 9.0, phase)[1] == 3  # the cross axis is red
    red = signals.phase_for(arrival, np.array([5.0, 5.0]), anchor_runs_red=True)
    assert signals.signal_state(np.zeros(2, dtype=int), 4.0, red)[0] == 3


def test_variation_generator_depends_only_on_seed_and_index():
    a = variation_rng(7, 12).uniform(size=3)
    assert np.array_equal(a, variation_rng(7, 12).uniform(size=3))
    assert not np.array_equal(a, variation_rng(7, 13).uniform(size=3))
    assert not np.array_equal(a, variation_rng(8, 12).uniform(size=3))
