"""CVC 21460 (double line), CVC 21650 (wrong side, permitted overtake) and CVC 22107 (lane change)."""
from __future__ import annotations

import numpy as np

from tests.monitor.builders import tables, track

STEPS = 60


def intrusion(peak: float) -> np.ndarray:
    out = np.full(STEPS, -1.0)
    out[20:30] = peak
    return out


def test_double_line_just_past_is_violated(check):
    ego = track(STEPS, centerline_marker="double_solid_line", centerline_intrusion=intrusion(0.11))
    row = check(tables({"ego": ego}), "CVC_21460", "ego")
    assert row["verdict"] == "violated" and abs(row["first_violation_t"] - 2.0) < 1e-9


def test_double_line_just_inside_is_satisfied(check):
    ego = track(STEPS, centerline_marker="double_solid_line", centerline_intrusion=intrusion(0.09))
    row = check(tables({"ego": ego}), "CVC_21460", "ego")
    assert row["verdict"] == "satisfied" and abs(row["robustness"] - 0.01) < 1e-9


def test_broken_line_is_not_applicable(check):
    ego = track(STEPS, centerline_marker="broken_line", centerline_intrusion=intrusion(1.5))
    assert check(tables({"ego": ego}), "CVC_21460", "ego")["verdict"] == "not_applicable"


def test_left_turn_across_double_line_at_intersection_is_exempt(check):
    in_junction = np.zeros(STEPS, dtype=bool)
    in_junction[18:35] = True
    ego = track(STEPS, centerline_marker="double_solid_line", centerline_intrusion=intrusion(1.2),
                maneuver="left", in_junction=in_junction)
    row = check(tables({"ego": ego}), "CVC_21460", "ego")
    assert row["verdict"] == "satisfied" and "exempt" in row["note"]


def opposing(steps_in: int, start: int = 20) -> np.ndarray:
    out = np.zeros(STEPS, dtype=bool)
    out[start:start + steps_in] = True
    return out


def test_wrong_side_just_past_duration_is_violated(check):
    ego = track(STEPS, opposing_lane=opposing(6), in_junction=False, centerline_marker="double_solid_line")
    row = check(tables({"ego": ego}), "CVC_21650", "ego")
    assert row["verdict"] == "violated" and abs(row["measured"] - 0.6) < 1e-9


def test_wrong_side_too_short_is_satisfied(check):
    ego = track(STEPS, opposing_lane=opposing(4), in_junction=False, centerline_marker="double_solid_line")
    assert check(tables({"ego": ego}), "CVC_21650", "ego")["verdict"] == "satisfied"


def test_wrong_side_inside_junction_does_not_count(check):
    ego = track(STEPS, opposing_lane=opposing(20), in_junction=opposing(20), centerline_marker="broken_line")
    assert check(tables({"ego": ego}), "CVC_21650", "ego")["verdict"] == "satisfied"


def test_permitted_overtake_on_clear_road(check):
    ego = track(STEPS, opposing_lane=opposing(30), in_junction=False, centerline_marker="broken_line")
    row = check(tables({"ego": ego}), "CVC_21650", "ego")
    assert row["verdict"] == "satisfied" and "overtake" in row["note"]


def test_overtake_with_oncoming_traffic_is_violated(check):
    ego = track(STEPS, opposing_lane=opposing(30), in_junction=False, centerline_marker="broken_line")
    oncoming = track(STEPS, x0=120.0, yaw=np.pi, speed=15.0)
    assert check(tables({"ego": ego, "npc1": oncoming}), "CVC_21650", "ego")["verdict"] == "violated"


def test_overtake_across_double_line_is_violated(check):
    ego = track(STEPS, opposing_lane=opposing(30), in_junction=False, centerline_marker="double_solid_line")
    assert check(tables({"ego": ego}), "CVC_21650", "ego")["verdict"] == "violated"


def lane_change(gap: float) -> dict:
    """Ego moves from lane A (y=0) to lane B (y=3.5) over steps 20-40; npc1 in lane B `gap` [m] behind."""
    ego = track(STEPS, speed=15.0)
    y = np.zeros(STEPS)
    y[20:40] = np.linspace(0, 3.5, 20)
    y[40:] = 3.5
    changing = np.zeros(STEPS, dtype=bool)
    changing[20:40] = True
    ego.update(y=y, lane_change=changing, lane_id=np.where(np.arange(STEPS) < 30, "A", "B").astype(object),
               target_lane_id=np.where(changing, "B", None).astype(object))
    npc = track(STEPS, x0=-(gap + 4.5), y0=3.5, speed=15.0, lane_id="B")
    return {"ego": ego, "npc1": npc}


def test_lane_change_gap_just_below_safe_is_violated(check):
    row = check(tables(lane_change(14.5)), "CVC_22107", "ego")
    assert row["verdict"] == "violated" and abs(row["threshold"] - 15.0) < 1e-9
    assert abs(row["measured"] - 14.5) < 1e-6


def test_lane_change_gap_just_above_safe_is_satisfied(check):
    row = check(tables(lane_change(15.5)), "CVC_22107", "ego")
    assert row["verdict"] == "satisfied" and abs(row["robustness"] - 0.5) < 1e-6


def test_lane_change_forcing_hard_braking_is_violated(check):
    actors = lane_change(40.0)
    accel = np.zeros(STEPS)
    accel[35:45] = -2.5
    actors["npc1"]["accel"] = accel
    assert check(tables(actors), "CVC_22107", "ego")["verdict"] == "violated"


def test_no_lane_change_is_not_applicable(check):
    assert check(tables({"ego": track(STEPS)}), "CVC_22107", "ego")["verdict"] == "not_applicable"


def test_lane_change_into_a_vehicle_alongside_is_violated(check):
    actors = lane_change(0.0)
    actors["npc1"] = track(STEPS, x0=3.0, y0=3.5, speed=15.0, lane_id="B")  # slightly ahead, overlapping
    row = check(tables(actors), "CVC_22107", "ego")
    assert row["verdict"] == "violated" and row["measured"] < 0


def test_lane_change_behind_a_vehicle_clear_ahead_is_not_this_rules_business(check):
    actors = lane_change(0.0)
    actors["npc1"] = track(STEPS, x0=30.0, y0=3.5, speed=15.0, lane_id="B")
    assert check(tables(actors), "CVC_22107", "ego")["verdict"] == "satisfied"


def test_wrong_side_cut_short_by_a_crash_is_violated(check):
    ego = track(STEPS, opposing_lane=opposing(3), in_junction=False, centerline_marker="broken_line")
    oncoming = track(STEPS, x0=200.0, y0=0.0, yaw=np.pi, speed=10.0)
    contact = {"variation": 0, "t": 2.2, "actor_a": "ego", "actor_b": "npc1", "speed_a": 10.0, "speed_b": 10.0,
               "yaw_a": 0.0, "yaw_b": np.pi, "x": 22.0, "y": 0.0}
    row = check(tables({"ego": ego, "npc1": oncoming}, collisions=[contact]), "CVC_21650", "ego")
    assert row["verdict"] == "violated" and row["first_violation_t"] == 2.0
    # the same short stay without a crash is a momentary touch
    assert check(tables({"ego": ego, "npc1": oncoming}), "CVC_21650", "ego")["verdict"] == "satisfied"
