"""CVC 21460 (double line), CVC 21650 (wrong side, permitted overtake) and CVC 22107 (lane change)."""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

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


def test_a_pass_that_leaves_the_far_edge_and_comes_back_is_one_stay(check):
    # ego in the opposing lane 1.0 s (steps 20-29) while it is clear, off the road beyond it 0.5 s (30-34), back
    # in it 0.3 s (35-37) with an oncoming car within the clear distance from step 33: one pass, not clear
    lane, off = opposing(10), opposing(5, start=30)
    lane[35:38] = True
    ego = track(STEPS, opposing_lane=lane, off_road=off, in_junction=False, centerline_marker="broken_line")
    oncoming = track(STEPS, x0=125.0, yaw=np.pi, speed=10.0)
    row = check(tables({"ego": ego, "npc1": oncoming}), "CVC_21650", "ego")
    assert row["verdict"] == "violated" and abs(row["measured"] - 1.8) < 1e-9
    # off the road on the way back to its own side (own lane after it) ends the stay: a clear, permitted pass
    back = opposing(10)
    row = check(tables({"ego": track(STEPS, opposing_lane=back, off_road=off, in_junction=False,
                                     centerline_marker="broken_line"), "npc1": oncoming}), "CVC_21650", "ego")
    assert row["verdict"] == "satisfied" and "overtake" in row["note"]


def move_left(steps: int, start: int) -> tuple[np.ndarray, np.ndarray]:
    """(y [m], lane-change flag) of a move from y=0 to the next lane (y=3.5) over the 20 steps from `start`."""
    y = np.zeros(steps)
    y[start:start + 20] = np.linspace(0, 3.5, 20)
    y[start + 20:] = 3.5
    changing = np.zeros(steps, dtype=bool)
    changing[start:start + 20] = True
    return y, changing


def lane_change(gap: float) -> dict:
    """Ego moves from lane A (y=0) to lane B (y=3.5) over steps 20-40; npc1 in lane B `gap` [m] behind."""
    ego = track(STEPS, speed=15.0)
    y, changing = move_left(STEPS, 20)
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


def lane_change_into_the_car_ahead(changes: dict[str, str] | None = None) -> dict:
    """Ego (15 m/s) follows npc1 (10 m/s) in lane A (y=0) and pulls out left to pass from step 45; its right
    front strikes npc1's left rear at step 51 (footprints overlap from there on); the target lane B is empty.
    Every role in `changes` (default: ego) is flagged as changing lanes, into the lane given, over steps 45-65."""
    steps = 80
    ego = track(steps, speed=15.0)
    y, changing = move_left(steps, 45)
    ego.update(y=y, lane_id=np.where(np.arange(steps) < 55, "A", "B").astype(object))
    npc = track(steps, x0=30.0, speed=10.0, lane_id="A")
    actors = {"ego": ego, "npc1": npc}
    for role, target in (changes or {"ego": "B"}).items():
        actors[role].update(lane_change=changing, target_lane_id=np.where(changing, target, None).astype(object))
    return actors


def test_lane_change_striking_the_car_it_pulls_out_from_is_violated(check):
    # the target lane is empty, so rules.md's target-lane check alone never fires; the strike does
    row = check(tables(lane_change_into_the_car_ahead()), "CVC_22107", "ego")
    assert row["verdict"] == "violated" and row["first_violation_t"] == pytest.approx(5.1)
    assert row["threshold"] == 0.0 and row["measured"] <= 0.0 and row["robustness"] <= 0.0


def test_lane_change_strike_does_not_charge_the_struck_vehicle(check):
    # npc1 is changing lanes too (right, into the empty lane C) when ego's front strikes it: the struck party is
    # not charged by the clause
    actors = lane_change_into_the_car_ahead(changes={"ego": "B", "npc1": "C"})
    assert check(tables(actors), "CVC_22107", "npc1")["verdict"] == "satisfied"
    assert check(tables(actors), "CVC_22107", "ego")["verdict"] == "violated"


def test_strike_after_the_lane_change_is_not_this_clause(check):
    # the same contact when an earlier lane change was over (flag off from step 29, its after-window of the
    # target-lane check over at step 49) is not charged
    actors = lane_change_into_the_car_ahead()
    changing = np.zeros(80, dtype=bool)
    changing[20:29] = True
    actors["ego"].update(lane_change=changing, target_lane_id=np.where(changing, "B", None).astype(object))
    assert check(tables(actors), "CVC_22107", "ego")["verdict"] == "satisfied"


def _swerve_then_upset(lateral_speed: float, marker: str = "double_solid_line", oncoming: bool = False,
                       start: int = 23) -> dict:
    """Ego at 20 m/s moves left at `lateral_speed` [m/s] (centerline_intrusion rising with it) until an
    upsetting contact at step 20 (a simulator contact: its speed drops to 15 m/s); its centre is in the
    opposing lane from step `start` to 49 (2.6 s from 23). `oncoming`: npc2 comes the other way in that lane."""
    steps = 80
    speed = np.where(np.arange(steps) < 20, 20.0, 15.0)
    y = np.minimum(np.arange(steps), 20) * lateral_speed * 0.1
    opposing = np.zeros(steps, dtype=bool)
    opposing[start:50] = True
    ego = track(steps, speed=speed, opposing_lane=opposing, in_junction=False, centerline_marker=marker,
                centerline_intrusion=y - 2.0)
    ego["y"] = y
    npc = track(steps, y0=-3.0, x0=5.0, speed=18.0)  # beside it to the right, footprints clear
    contact = {"variation": 0, "t": 2.0, "actor_a": "ego", "actor_b": "npc1", "speed_a": 20.0, "speed_b": 18.0,
               "yaw_a": 0.0, "yaw_b": 0.0, "x": 40.0, "y": -1.0}
    actors = {"ego": ego, "npc1": npc}
    if oncoming:
        actors["npc2"] = track(steps, x0=160.0, y0=3.5, yaw=np.pi, speed=15.0)
    return tables(actors, collisions=[contact])


def test_stay_begun_just_after_an_upsetting_contact_counts_whole(check):
    # moving left by itself at 1 m/s before the impact: the stay it begins 0.3 s after is its own, 2.7 s long,
    # though judging ends at step 25
    row = check(_swerve_then_upset(1.0), "CVC_21650", "ego")
    assert row["verdict"] == "violated" and row["measured"] == pytest.approx(2.7)
    assert row["first_violation_t"] == pytest.approx(2.7)


def test_a_vehicle_pushed_over_from_its_lane_is_not_charged(check):
    # the same stay after the same impact, but it kept its lane before it: the impact put it there
    assert check(_swerve_then_upset(0.0), "CVC_21650", "ego")["verdict"] == "satisfied"
    assert check(_swerve_then_upset(0.2), "CVC_21650", "ego")["verdict"] == "satisfied"


def test_stay_begun_after_the_grace_is_not_judged(check):
    assert check(_swerve_then_upset(1.0, start=27), "CVC_21650", "ego")["verdict"] == "satisfied"


def test_own_stay_after_an_impact_can_be_a_permitted_overtake(check):
    # broken line and no oncoming traffic: rules.md's permitted overtake, still exempt
    row = check(_swerve_then_upset(1.0, marker="broken_line"), "CVC_21650", "ego")
    assert row["verdict"] == "satisfied" and "overtake" in row["note"]
    assert check(_swerve_then_upset(1.0, marker="broken_line", oncoming=True), "CVC_21650", "ego")["verdict"] == \
        "violated"


def test_oncoming_vehicle_seen_from_its_own_lane(check):
    # ego turned 60 deg across the road in the opposing lane: the oncoming car 40 m ahead in that lane is not
    # within a lane's width of ego's axis, but ego is ahead of it in its lane: the lane is not clear
    ego = track(STEPS, speed=5.0, yaw=np.radians(-60), opposing_lane=opposing(30), in_junction=False,
                centerline_marker="broken_line")
    ego["x"] = np.full(STEPS, 0.0) + np.arange(STEPS) * 0.1  # sliding along the road while turned
    ego["y"] = np.full(STEPS, 3.5)
    oncoming = track(STEPS, x0=45.0, y0=3.5, yaw=np.pi, speed=0.5)
    assert check(tables({"ego": ego, "npc1": oncoming}), "CVC_21650", "ego")["verdict"] == "violated"


def test_a_stay_it_was_already_in_is_not_extended(check):
    # on the wrong side from step 5 until the impact at step 20 (1.5 s), knocked out of that lane and back into it
    # at step 22: the new stay does not begin from its own side of the road, so only what is judged counts
    opposing_steps = np.zeros(80, dtype=bool)
    opposing_steps[5:20] = True
    opposing_steps[22:50] = True
    t = _swerve_then_upset(1.0)
    traces = t["traces"].to_pydict()
    for k, (role, step) in enumerate(zip(traces["actor"], traces["step"])):
        if role == "ego":
            traces["opposing_lane"][k] = bool(opposing_steps[step])
    t["traces"] = pa.Table.from_pydict(traces, schema=t["traces"].schema)
    row = check(t, "CVC_21650", "ego")
    assert row["verdict"] == "violated" and row["measured"] == pytest.approx(1.5)
