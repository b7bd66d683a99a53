"""CVC 22349 (posted limit) and CVC 22350 (conditions, loss of control)."""
from __future__ import annotations

import numpy as np

from crashscene.dsl import loads
from tests.monitor.builders import tables, track

LIMIT = 13.0  # [m/s] posted limit in the trace


def burst(base: float, peak: float, steps: int) -> np.ndarray:
    """Speed profile at `base` with `steps` samples at `peak` from step 20."""
    v = np.full(60, base)
    v[20:20 + steps] = peak
    return v


def scenario(weather="clear", surface="dry", time_of_day="daytime", limit_mph=None):
    limit = f"\n  speed_limit_mph: {limit_mph}" if limit_mph else ""
    return loads(f"""
environment: {{weather: {weather}, time_of_day: {time_of_day}, road_surface: {surface}}}
road_network:
  road_type: straight
  number_of_ways: 2
  number_of_lanes: 2
  road_marker: broken_line
  traffic_signs: []{limit}
actors:
  ego: {{type: car, behavior: go_forward, position: {{reference: road, relation: behind}}}}
oracle: []
""")


def test_speed_limit_just_past_for_long_enough_is_violated(check):
    ego = track(60, speed=burst(10.0, LIMIT + 1.05, 11), speed_limit=LIMIT)
    row = check(tables({"ego": ego}), "CVC_22349", "ego")
    assert row["verdict"] == "violated"
    assert row["threshold"] == LIMIT + 1.0 and row["robustness"] < 0


def test_speed_limit_just_inside_is_satisfied(check):
    ego = track(60, speed=burst(10.0, LIMIT + 0.95, 30), speed_limit=LIMIT)
    row = check(tables({"ego": ego}), "CVC_22349", "ego")
    assert row["verdict"] == "satisfied" and 0 < row["robustness"] < 0.1


def test_speed_limit_excess_too_short_is_satisfied(check):
    ego = track(60, speed=burst(10.0, LIMIT + 3, 8), speed_limit=LIMIT)
    assert check(tables({"ego": ego}), "CVC_22349", "ego")["verdict"] == "satisfied"


def test_scenario_limit_wins_and_defaults_apply(check):
    ego = track(60, speed=burst(10.0, 15.0, 15), speed_limit=30.0)
    row = check(tables({"ego": ego}), "CVC_22349", "ego", scenario(limit_mph=25))
    assert row["verdict"] == "violated" and abs(row["threshold"] - (25 * 0.44704 + 1)) < 1e-9
    # no limit anywhere: 55 mph on a two-lane two-way road
    row = check(tables({"ego": track(60, speed=20.0)}), "CVC_22349", "ego", scenario())
    assert abs(row["threshold"] - (55 * 0.44704 + 1)) < 1e-9


def test_unsafe_speed_applies_condition_factors(check):
    factor = 0.85 * 0.90  # rain, night
    ego = track(60, speed=burst(5.0, LIMIT * factor + 0.1, 12), speed_limit=LIMIT)
    row = check(tables({"ego": ego}), "CVC_22350", "ego", scenario("rainy", "wet", "nighttime"))
    assert row["verdict"] == "violated" and abs(row["threshold"] - LIMIT * factor) < 1e-9
    assert "condition factor" in row["note"]
    ego = track(60, speed=burst(5.0, LIMIT * factor - 0.1, 30), speed_limit=LIMIT)
    assert check(tables({"ego": ego}), "CVC_22350", "ego", scenario("rainy", "wet", "nighttime"))["verdict"] \
        == "satisfied"
    # the same speed is fine in clear daylight
    ego = track(60, speed=burst(5.0, LIMIT * factor + 0.1, 12), speed_limit=LIMIT)
    assert check(tables({"ego": ego}), "CVC_22350", "ego", scenario())["verdict"] == "satisfied"


def test_loss_of_control_is_unsafe_speed(check):
    lost = np.zeros(60, dtype=bool)
    lost[30:] = True
    row = check(tables({"ego": track(60, speed=8.0, speed_limit=LIMIT, lost_control=lost)}), "CVC_22350", "ego")
    assert row["verdict"] == "violated" and abs(row["first_violation_t"] - 3.0) < 1e-9
    assert "loss of control" in row["note"]


def test_lateral_acceleration_beyond_ice_friction(check):
    lat = np.zeros(60)
    lat[30:35] = 0.15 * 9.81 + 0.2
    ice = scenario("snowy", "icy")
    row = check(tables({"ego": track(60, speed=6.0, speed_limit=LIMIT, lat_accel=lat)}), "CVC_22350", "ego", ice)
    assert row["verdict"] == "violated"
    lat[30:35] = 0.15 * 9.81 - 0.2
    row = check(tables({"ego": track(60, speed=6.0, speed_limit=LIMIT, lat_accel=lat)}), "CVC_22350", "ego", ice)
    assert row["verdict"] == "satisfied" and row["robustness"] > 0


def test_scripted_lose_control_counts_when_backend_cannot_tell(check):
    npc = track(60, y0=10, speed=8.0, speed_limit=LIMIT, behavior="lose_control")
    row = check(tables({"ego": track(60, speed=8.0), "npc1": npc}), "CVC_22350", "npc1")
    assert row["verdict"] == "violated"


def test_rear_ending_a_stopped_vehicle_is_too_fast_for_traffic(check):
    actors = {"ego": track(60, speed=9.0, speed_limit=LIMIT), "npc1": track(60, x0=30.0, speed=0.0, behavior="static")}
    row = check(tables(actors), "CVC_22350", "ego")
    assert row["verdict"] == "violated" and "stopped vehicle" in row["note"]
    # a moving leader is the following rule's business, not this one
    actors = {"ego": track(60, speed=12.0, speed_limit=LIMIT), "npc1": track(60, x0=20.0, speed=5.0)}
    assert check(tables(actors), "CVC_22350", "ego")["verdict"] == "satisfied"


def test_initial_speed_above_limit_is_the_tests_condition_not_a_violation(check):
    speed = np.full(60, 10.0)
    speed[:18] = LIMIT + 3  # spawned fast, slowed within the start grace
    assert check(tables({"ego": track(60, speed=speed, speed_limit=LIMIT)}), "CVC_22349", "ego")["verdict"] \
        == "satisfied"
    speed[:35] = LIMIT + 3  # still too fast 1.5 s after the grace
    assert check(tables({"ego": track(60, speed=speed, speed_limit=LIMIT)}), "CVC_22349", "ego")["verdict"] \
        == "violated"


def test_a_car_shoved_by_an_impact_has_not_lost_control(check):
    """The leader is rear-ended at t ~ 1.6 s; its slide after the impact (lateral acceleration far beyond the
    tyres' grip, the simulator's skid flag) is not the driver losing control. The same slide before any contact is."""
    slide = np.zeros(60)
    slide[20:40] = 12.0  # [m/s2]
    skid = np.zeros(60, dtype=bool)
    skid[20:40] = True
    struck = track(60, x0=20.0, speed=5.0, speed_limit=LIMIT, lat_accel=slide, lost_control=skid)
    actors = {"ego": track(60, speed=15.0, speed_limit=LIMIT), "npc1": struck}
    assert check(tables(actors), "CVC_22350", "npc1")["verdict"] == "satisfied"
    alone = {"ego": track(60, y0=30.0, speed=5.0, speed_limit=LIMIT), "npc1": struck}
    assert check(tables(alone), "CVC_22350", "npc1")["verdict"] == "violated"
