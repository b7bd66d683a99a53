"""Per-variation verdicts, invalid variations, reproduction of the oracle, summary."""
from __future__ import annotations

import numpy as np

from crashscene.dsl import loads
from crashscene.monitor import ExpectedCollision, evaluate, expected_collision
from tests.monitor.builders import tables, track

STEPS = 60

REAR_END = loads("""
environment: {weather: clear, time_of_day: daytime}
road_network: {road_type: straight, number_of_ways: 2, number_of_lanes: 2, road_marker: broken_line,
               traffic_signs: [speed_limit_sign], speed_limit_mph: 30}
actors:
  ego: {type: car, behavior: go_forward, position: {reference: road, relation: behind}}
  npc1: {type: car, behavior: decelerate, position: {reference: ego, relation: front, heading: same_direction}}
oracle:
  - {code: CVC_21703, violation: following_too_closely, actor: ego, description: "V1 followed too closely"}
""")


def crash(variations=1, **kw):
    return tables({"ego": track(STEPS, speed=15.0, lane_id="L"), "npc1": track(STEPS, x0=25.0, speed=7.0, lane_id="L")},
                  variations=variations, **kw)


def test_violation_and_reproduction():
    result = evaluate(crash(variations=3), REAR_END)
    rows = result.verdicts.to_pylist()
    assert [r["verdict"] for r in rows] == ["violation"] * 3
    assert all(r["reproduced"] for r in rows)
    assert "CVC_21703 by ego" in rows[0]["reason"] and "rear_end collision ego-npc1" in rows[0]["reason"]
    summary = result.summary()
    assert summary["violations"]["CVC_21703"] == {"ego": 3}
    assert summary["verdicts"] == {"violation": 3, "collision": 0, "pass": 0, "invalid": 0}
    assert summary["reproduced"] == 3 and summary["reproduction_rate"] == 1.0


def test_collision_verdict_when_the_ads_violates_nothing():
    # the ADS (ego) is struck from behind by npc1 that follows too closely
    actors = {"ego": track(STEPS, x0=25.0, speed=7.0, lane_id="L"), "npc1": track(STEPS, speed=15.0, lane_id="L")}
    row = evaluate(tables(actors), None).verdicts.to_pylist()[0]
    assert row["verdict"] == "collision" and row["collision_classes"] == ["rear_end"]


def test_pass():
    actors = {"ego": track(STEPS, speed=10.0, speed_limit=20.0), "npc1": track(STEPS, y0=3.5, speed=10.0)}
    assert evaluate(tables(actors), None).verdicts.to_pylist()[0]["verdict"] == "pass"


def test_invalid_variation_is_never_a_pass_and_not_counted():
    result = evaluate(crash(variations=3, valid=[True, False, True], invalid_reason="spawn failed"), REAR_END)
    rows = result.verdicts.to_pylist()
    assert rows[1]["verdict"] == "invalid" and rows[1]["reason"] == "spawn failed" and not rows[1]["reproduced"]
    summary = result.summary()
    assert summary["valid"] == 2 and summary["verdicts"]["invalid"] == 1
    assert summary["violations"]["CVC_21703"] == {"ego": 2} and summary["reproduction_rate"] == 1.0
    assert summary["invalid_reasons"] == {"spawn failed": 1}


def test_ego_that_never_moved_is_invalid():
    actors = {"ego": track(STEPS, speed=0.0), "npc1": track(STEPS, y0=3.5, speed=10.0)}
    row = evaluate(tables(actors), None).verdicts.to_pylist()[0]
    assert row["verdict"] == "invalid" and "never moved" in row["reason"]


def test_is_ads_decides_who_is_under_test():
    # npc1 is the ADS: the ego's violation does not make the verdict a violation
    tabs = tables({"ego": track(STEPS, speed=15.0, lane_id="L"), "npc1": track(STEPS, x0=25.0, speed=7.0, lane_id="L")},
                  ads=("npc1",))
    row = evaluate(tabs, None).verdicts.to_pylist()[0]
    assert row["verdict"] == "collision" and row["ads_violations"] == []


def test_missing_collision_class_is_not_reproduced():
    result = evaluate(crash(), REAR_END, expected=ExpectedCollision("ego", "npc1", "head_on"))
    row = result.verdicts.to_pylist()[0]
    assert not row["reproduced"] and "missing head_on collision ego-npc1" in row["reason"]


def test_backend_without_optional_columns_gives_not_applicable_not_crash():
    # positions only: no speed, yaw, lanes, signals
    ego = {"x": np.arange(STEPS) * 1.0, "y": np.zeros(STEPS)}
    result = evaluate(tables({"ego": ego}), REAR_END)
    verdicts = {r["code"]: r["verdict"] for r in result.rule_results.to_pylist()}
    assert verdicts["CVC_21453"] == "not_applicable" and verdicts["CVC_21650"] == "not_applicable"
    assert verdicts["CVC_22349"] == "satisfied"  # speed derived from positions


def test_expected_collision_from_dsl_headings(examples_dir):
    from crashscene.dsl import load_file

    cases = {"121520": ("npc1", "angle"), "103378": ("npc1", "head_on"), "109176": ("npc1", "rear_end"),
             "100343": ("npc1", "sideswipe"), "100237": ("npc1", "angle")}
    for case, (partner, klass) in cases.items():
        expected = expected_collision(load_file(examples_dir / case / "golden.yaml"))
        assert (expected.actor_b, expected.klass) == (partner, klass), case
    assert expected_collision(load_file(examples_dir / "3-C1-2017-006" / "golden.yaml")) is None


def test_batch_without_any_trace_rows():
    tabs = crash(variations=2, valid=[False, True])
    tabs["traces"] = tabs["traces"].slice(0, 0)
    result = evaluate(tabs, REAR_END)
    rows = result.verdicts.to_pylist()
    assert [r["verdict"] for r in rows] == ["invalid", "invalid"]
    assert rows[1]["reason"].startswith("no trace rows")
    assert set(result.rule_results.column("verdict").to_pylist()) == {"not_applicable"}
    assert result.summary()["reproduction_rate"] is None


def test_reproduce_mode_without_ads_the_ego_stands_in_for_the_verdict():
    result = evaluate(crash(ads=()), REAR_END)
    assert result.verdicts.to_pylist()[0]["verdict"] == "violation"
    assert not any(result.rule_results.column("is_ads").to_pylist())
    assert result.collisions.to_pylist()[0]["involves_ads"] is False


def test_summary_per_rule_counts_and_closest_margins():
    summary = evaluate(crash(variations=2, valid=[True, False]), REAR_END).summary()
    assert summary["rule_verdicts"]["CVC_21703"] == {"violated": 1, "satisfied": 0, "not_applicable": 1}
    assert summary["min_robustness"]["CVC_21703"]["ego"] < 0
    assert "CVC_21453" not in summary["min_robustness"]  # never applicable: no margin to report


def test_stationary_ads_struck_at_once_took_part_in_the_test():
    actors = {"ego": track(STEPS, speed=0.0, lane_id="L"), "npc1": track(STEPS, x0=-20.0, speed=15.0, lane_id="L")}
    row = evaluate(tables(actors), None).verdicts.to_pylist()[0]
    assert row["verdict"] == "collision" and row["collision_classes"] == ["rear_end"]
