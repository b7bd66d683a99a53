"""CVC 21453 (red light) and CVC 22450 (stop sign) on hand-built approaches."""
from __future__ import annotations

import numpy as np
import pytest

from tests.monitor.builders import DT, tables, track

STEPS = 80
LINE_X = 40.0  # [m] stop line position on the ego's eastbound approach


def approach(speed, red_from: float | None, maneuver: str = "straight", control: str = "signal") -> dict:
    """Eastbound ego crossing the stop line at x = LINE_X; the signal turns red at `red_from` [s]."""
    ego = track(STEPS, x0=0.0, speed=speed)
    t = np.arange(STEPS) * DT
    signal = np.where((red_from is not None) & (t >= (red_from if red_from is not None else 0)), "red", "green")
    ego.update(stop_line_dist=LINE_X - (ego["x"] + 2.25), control=control, maneuver=maneuver,
               signal=signal.astype(object) if control == "signal" else "none")
    return ego


def crossing_time(ego: dict) -> float:
    d = ego["stop_line_dist"]
    k = int(np.nonzero((d[:-1] > 0) & (d[1:] <= 0))[0][0]) + 1
    return k * DT


def test_red_light_crossed_past_grace_is_violated(check):
    ego = approach(10.0, None)
    tc = crossing_time(ego)
    ego = approach(10.0, red_from=tc - 0.35)
    row = check(tables({"ego": ego}), "CVC_21453", "ego")
    assert row["verdict"] == "violated"
    assert row["measured"] > 0.2 and row["robustness"] < 0
    assert abs(row["first_violation_t"] - tc) < 1e-9


def test_red_light_just_inside_grace_is_satisfied(check):
    tc = crossing_time(approach(10.0, None))
    row = check(tables({"ego": approach(10.0, red_from=tc - 0.15)}), "CVC_21453", "ego")
    assert row["verdict"] == "satisfied"
    assert 0 < row["robustness"] <= 0.2


def test_green_crossing_is_satisfied_and_no_signal_not_applicable(check):
    assert check(tables({"ego": approach(10.0, None)}), "CVC_21453", "ego")["verdict"] == "satisfied"
    assert check(tables({"ego": track(STEPS)}), "CVC_21453", "ego")["verdict"] == "not_applicable"


def stop_then_go(min_speed: float) -> np.ndarray:
    """Speed profile slowing to `min_speed` [m/s] 5 m before the line, then accelerating."""
    speed = np.full(STEPS, 8.0)
    speed[20:35] = np.linspace(8.0, min_speed, 15)
    speed[35:45] = min_speed
    speed[45:60] = np.linspace(min_speed, 8.0, 15)
    return speed


def stopping_approach(min_speed: float, maneuver="straight", control="stop", red=False) -> dict:
    ego = track(STEPS, speed=stop_then_go(min_speed))
    # put the line 5 m past where the slowest point begins, so the slow part is within 10 m before it
    line = ego["x"][38] + 2.25 + 2.0
    ego.update(stop_line_dist=line - (ego["x"] + 2.25), control=control, maneuver=maneuver,
               signal="red" if red else "none")
    return ego


def test_stop_sign_rolling_stop_just_above_threshold_is_violated(check):
    row = check(tables({"ego": stopping_approach(0.35)}), "CVC_22450", "ego")
    assert row["verdict"] == "violated"
    assert abs(row["measured"] - 0.35) < 1e-6 and row["robustness"] < 0


def test_stop_sign_full_stop_just_below_threshold_is_satisfied(check):
    row = check(tables({"ego": stopping_approach(0.25)}), "CVC_22450", "ego")
    assert row["verdict"] == "satisfied"
    assert abs(row["robustness"] - 0.05) < 1e-6


def test_right_turn_on_red_after_full_stop_is_exempt(check):
    ego = stopping_approach(0.1, maneuver="right", control="signal", red=True)
    row = check(tables({"ego": ego}), "CVC_21453", "ego")
    assert row["verdict"] == "satisfied"
    assert "exempt" in row["note"]


def test_right_turn_on_red_without_stop_is_violated(check):
    ego = stopping_approach(2.0, maneuver="right", control="signal", red=True)
    assert check(tables({"ego": ego}), "CVC_21453", "ego")["verdict"] == "violated"


def test_straight_on_red_after_stop_is_violated(check):
    ego = stopping_approach(0.1, maneuver="straight", control="signal", red=True)
    assert check(tables({"ego": ego}), "CVC_21453", "ego")["verdict"] == "violated"


def test_yellow_crossing_robustness_is_the_time_left_before_red(check):
    tc = crossing_time(approach(10.0, None))
    row = check(tables({"ego": approach(10.0, red_from=tc + 0.75)}), "CVC_21453", "ego")
    assert row["verdict"] == "satisfied"
    assert row["measured"] == pytest.approx(-0.8, abs=0.11) and row["robustness"] == pytest.approx(1.0, abs=0.11)
