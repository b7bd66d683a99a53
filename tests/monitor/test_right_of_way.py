"""Junction right of way: CVC 21800, 21801, 21802, 21803, on a 4-leg junction at the origin.

Lanes are 3.5 m wide, right-hand traffic; the junction box is |x|, |y| < 7 m.
"""
from __future__ import annotations

import numpy as np

from tests.monitor.builders import tables, track, turn

STEPS = 120
BOX = 7.0  # [m]


def junction_columns(d: dict, control: str, maneuver: str = "straight", axis: str = "x", sign: float = 1.0) -> dict:
    """Add in_junction, control, maneuver, stop_line_dist (along `axis`, travelling towards +/-)."""
    x, y = d["x"], d["y"]
    pos = x if axis == "x" else y
    d.update(in_junction=(np.abs(x) < BOX) & (np.abs(y) < BOX), control=control, maneuver=maneuver,
             junction_id="j1", stop_line_dist=(-BOX - (sign * pos + 2.25)))
    return d


def eastbound(x0: float, speed, control="none") -> dict:
    return junction_columns(track(STEPS, x0=-x0, y0=-1.75, yaw=0.0, speed=speed), control)


def northbound(y0: float, speed, control="none") -> dict:
    return junction_columns(track(STEPS, x0=1.75, y0=-y0, yaw=np.pi / 2, speed=speed), control, axis="y")


def test_yield_sign_entered_when_through_vehicle_is_close_is_violated(check):
    actors = {"ego": eastbound(47.0, 10.0), "npc1": northbound(23.5, 10.0, control="yield")}
    row = check(tables(actors), "CVC_21803", "npc1")
    assert row["verdict"] == "violated"
    assert 2.5 < row["measured"] < 3.0 and 1.7 <= row["first_violation_t"] <= 2.0


def test_yield_sign_entered_with_enough_time_is_satisfied(check):
    actors = {"ego": eastbound(52.0, 10.0), "npc1": northbound(23.5, 10.0, control="yield")}
    row = check(tables(actors), "CVC_21803", "npc1")
    assert row["verdict"] == "satisfied" and 3.0 < row["measured"] < 3.5


def test_yield_rules_do_not_apply_to_the_through_vehicle(check):
    actors = {"ego": eastbound(47.0, 10.0), "npc1": northbound(23.5, 10.0, control="yield")}
    assert check(tables(actors), "CVC_21803", "ego")["verdict"] == "not_applicable"
    assert check(tables(actors), "CVC_21802", "npc1")["verdict"] == "not_applicable"


def test_stop_sign_yield_violated_and_satisfied(check):
    close = {"ego": eastbound(47.0, 10.0), "npc1": northbound(23.5, 10.0, control="stop")}
    far = {"ego": eastbound(52.0, 10.0), "npc1": northbound(23.5, 10.0, control="stop")}
    assert check(tables(close), "CVC_21802", "npc1")["verdict"] == "violated"
    assert check(tables(far), "CVC_21802", "npc1")["verdict"] == "satisfied"


def test_through_vehicle_that_already_passed_is_no_hazard(check):
    actors = {"ego": eastbound(5.0, 10.0), "npc1": northbound(33.5, 10.0, control="stop")}
    row = check(tables(actors), "CVC_21802", "npc1")
    assert row["verdict"] == "satisfied"


def test_through_vehicle_braking_to_a_stop_short_of_the_crossing_still_counts(check):
    speed = np.full(STEPS, 10.0)
    speed[25:] = np.maximum(10.0 - 6.0 * 0.1 * np.arange(1, STEPS - 24), 0.0)  # hard stop from step 25
    ego = eastbound(30.0, speed)
    actors = {"ego": ego, "npc1": northbound(23.5, 10.0, control="stop")}
    assert check(tables(actors), "CVC_21802", "npc1")["verdict"] == "violated"


def left_turner(start_x: float, turn_step: int) -> dict:
    """Westbound at y = +1.75, turning left (to the south) into the junction."""
    d = turn(STEPS, x0=start_x, y0=1.75, yaw0=np.pi, speed=8.0, radius=6.0, left=True, start=turn_step)
    return junction_columns(d, "signal", maneuver="left", sign=-1.0)


def test_left_turn_across_close_oncoming_is_violated(check):
    npc = left_turner(30.0, 30)
    actors = {"ego": eastbound(42.0, 10.0), "npc1": npc}
    row = check(tables(actors), "CVC_21801", "npc1")
    assert row["verdict"] == "violated" and row["measured"] < 3.0


def test_left_turn_with_distant_oncoming_is_satisfied(check):
    actors = {"ego": eastbound(80.0, 10.0), "npc1": left_turner(30.0, 30)}
    row = check(tables(actors), "CVC_21801", "npc1")
    assert row["verdict"] == "satisfied" and row["measured"] > 3.0


def test_going_straight_is_not_a_left_turn(check):
    actors = {"ego": eastbound(42.0, 10.0), "npc1": northbound(23.5, 10.0, control="signal")}
    assert check(tables(actors), "CVC_21801", "npc1")["verdict"] == "not_applicable"


def uncontrolled(npc_speed: float) -> dict:
    """Ego enters first-ish; npc1 from its right arrives within the tie window, at `npc_speed`."""
    ego = eastbound(17.0, 10.0)                  # enters the box at t = 1.0 s
    npc_y0 = BOX + 0.8 * npc_speed + npc_speed * 1.0  # enters the box at t = 1.8 s
    return {"ego": ego, "npc1": northbound(npc_y0, npc_speed)}


def test_uncontrolled_entering_ahead_of_vehicle_on_right_with_short_pet_is_violated(check):
    row = check(tables(uncontrolled(0.8)), "CVC_21800", "ego")
    assert row["verdict"] == "violated" and row["measured"] < 1.5


def test_uncontrolled_with_pet_above_threshold_is_satisfied(check):
    row = check(tables(uncontrolled(0.45)), "CVC_21800", "ego")
    assert row["verdict"] == "satisfied" and row["measured"] > 1.5


def test_uncontrolled_vehicle_with_priority_is_satisfied(check):
    assert check(tables(uncontrolled(0.8)), "CVC_21800", "npc1")["verdict"] == "satisfied"


def test_uncontrolled_forcing_priority_vehicle_to_brake_is_violated(check):
    actors = uncontrolled(0.45)
    accel = np.zeros(STEPS)
    accel[15:20] = -3.0
    actors["npc1"]["accel"] = accel
    assert check(tables(actors), "CVC_21800", "ego")["verdict"] == "violated"


def test_all_way_stop_the_first_to_arrive_goes_first(check):
    # both stop-controlled; npc1 is at its line from the start, the ego arrives later and goes first
    actors = uncontrolled(0.8)
    for d, axis in ((actors["ego"], "x"), (actors["npc1"], "y")):
        junction_columns(d, "stop", axis=axis)
    row = check(tables(actors), "CVC_21800", "ego")
    assert row["verdict"] == "violated"
    # with a signal, 21800 does not apply at all
    for d, axis in ((actors["ego"], "x"), (actors["npc1"], "y")):
        junction_columns(d, "signal", axis=axis)
    assert check(tables(actors), "CVC_21800", "ego")["verdict"] == "not_applicable"


def test_all_way_stop_vehicle_without_stop_sign_is_not_all_way(check):
    actors = uncontrolled(0.8)
    junction_columns(actors["ego"], "stop", axis="x")   # only the ego has a stop sign: 21802's business
    row = check(tables(actors), "CVC_21800", "ego")
    assert row["verdict"] == "satisfied"
