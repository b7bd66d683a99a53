"""Invariants of every rule on random traces from a backend that fills any subset of the columns."""
from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from crashscene.monitor import evaluate, registered_rules
from crashscene.traces import CENTERLINE_MARKERS, CONTROLS, MANEUVERS, SIGNAL_STATES
from tests.monitor.builders import tables

STEPS = 40
OPTIONAL = ("speed", "yaw", "accel", "lat_accel", "lane_id", "opposing_lane", "centerline_marker",
            "centerline_intrusion", "in_junction", "maneuver", "control", "signal", "stop_line_dist", "speed_limit",
            "lane_change", "target_lane_id", "lost_control")


def random_track(rng: np.random.Generator, filled: set[str]) -> dict:
    x = np.cumsum(rng.uniform(0, 2, STEPS)) + rng.uniform(-30, 30)
    y = np.cumsum(rng.normal(0, 0.3, STEPS)) + rng.uniform(-5, 5)
    columns = {
        "speed": rng.uniform(0, 25, STEPS), "yaw": rng.normal(0, 0.3, STEPS), "accel": rng.normal(0, 3, STEPS),
        "lat_accel": rng.normal(0, 3, STEPS), "lane_id": rng.choice(["a", "b"], STEPS).astype(object),
        "opposing_lane": rng.random(STEPS) < 0.3, "centerline_marker": rng.choice(CENTERLINE_MARKERS, STEPS).astype(object),
        "centerline_intrusion": rng.normal(0, 0.5, STEPS), "in_junction": rng.random(STEPS) < 0.3,
        "maneuver": rng.choice(MANEUVERS, STEPS).astype(object), "control": rng.choice(CONTROLS, STEPS).astype(object),
        "signal": rng.choice(SIGNAL_STATES, STEPS).astype(object), "stop_line_dist": 20 - np.cumsum(rng.uniform(0, 2, STEPS)),
        "speed_limit": np.full(STEPS, 13.4), "lane_change": rng.random(STEPS) < 0.2,
        "target_lane_id": rng.choice(["a", "b"], STEPS).astype(object), "lost_control": rng.random(STEPS) < 0.05,
    }
    track = {"x": x, "y": y}
    track.update({k: v for k, v in columns.items() if k in filled})
    return track


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), filled=st.sets(st.sampled_from(OPTIONAL)), n_actors=st.integers(1, 3))
def test_rule_results_are_consistent_for_any_backend(seed, filled, n_actors):
    rng = np.random.default_rng(seed)
    roles = ["ego"] + [f"npc{i}" for i in range(1, n_actors)]
    result = evaluate(tables({r: random_track(rng, filled) for r in roles}, variations=2), None)
    rows = result.rule_results.to_pylist()
    assert len(rows) == 2 * n_actors * len(registered_rules())
    for row in rows:
        assert row["verdict"] in ("violated", "satisfied", "not_applicable")
        if row["verdict"] == "violated":
            assert np.isfinite(row["first_violation_t"]) and row["robustness"] <= 0, row
        else:
            assert np.isnan(row["first_violation_t"]), row
        if row["verdict"] == "satisfied":
            assert row["robustness"] >= 0, row
        if row["verdict"] == "not_applicable":
            assert np.isnan(row["robustness"]) and np.isnan(row["measured"]), row
    assert sum(result.summary()["verdicts"].values()) == 2
