"""Reproduction judged on the crash sequence (rules.md): contacts in order, their classes, their areas."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.dsl import loads
from crashscene.dsl.model import Contact
from crashscene.monitor import evaluate
from crashscene.monitor.verdicts import match_sequence
from tests.conftest import EXAMPLES
from tests.monitor.builders import tables, track

STEPS = 60
SCENARIO_TEXT = (EXAMPLES / "100237" / "golden.yaml").read_text(encoding="utf-8")


def contact(striking: str, struck: str, klass: str, a: str = "front", b: str = "rear") -> Contact:
    return Contact.model_validate({"striking": striking, "struck": struck, "striking_area": a,
                                   "struck_area": b, "class": klass})


def test_first_contact_must_be_the_first_observed():
    reported = [contact("npc1", "ego", "rear_end")]
    assert match_sequence([("ego", "npc1", "rear_end", "rear", "front")], reported).first_contact
    late = [("ego", "npc2", "angle", "front", "left"), ("ego", "npc1", "rear_end", "rear", "front")]
    assert match_sequence(late, reported) == match_sequence([], reported)
    assert not match_sequence(late, reported).first_contact
    assert not match_sequence([("ego", "npc1", "sideswipe", "left", "right")], reported).first_contact


def test_later_contacts_follow_in_order_with_others_between():
    reported = [contact("npc1", "ego", "rear_end"), contact("npc2", "ego", "angle", "front", "right")]
    seen = [("ego", "npc1", "rear_end", "rear", "front"), ("ego", "npc1", "sideswipe", "left", "right"),
            ("ego", "npc2", "angle", "right", "front")]
    match = match_sequence(seen, reported)
    assert (match.first_contact, match.sequence, match.area_match) == (True, True, True)
    swapped = [seen[0], seen[2]][::-1]
    assert not match_sequence(swapped, reported).sequence
    missing = match_sequence(seen[:2], reported)
    assert (missing.first_contact, missing.sequence, missing.area_match) == (True, False, False)


def test_areas_are_compared_per_actor_apart_from_the_sequence():
    reported = [contact("npc1", "ego", "angle", "front", "right")]
    wrong_side = match_sequence([("ego", "npc1", "angle", "left", "front")], reported)
    assert (wrong_side.sequence, wrong_side.area_match) == (True, False)


def test_no_contact_reported_means_none_may_happen():
    assert match_sequence([], []).sequence and match_sequence([], []).area_match is None
    assert not match_sequence([("ego", "npc1", "angle", "front", "left")], []).first_contact


def test_areas_from_footprints_rear_end_and_t_bone():
    rear = evaluate(tables({"ego": track(STEPS, speed=15.0), "npc1": track(STEPS, x0=20.0, speed=5.0)}), None)
    row = rear.collisions.to_pylist()[0]
    assert (row["class"], row["area_a"], row["area_b"]) == ("rear_end", "front", "rear")
    # npc1 drives north into the right side of the eastbound ego
    crossing = {"ego": track(STEPS, x0=0.0, speed=10.0), "npc1": track(STEPS, x0=12.0, y0=-14.0, yaw=np.pi / 2,
                                                                        speed=10.0)}
    row = evaluate(tables(crossing), None).collisions.to_pylist()[0]
    assert (row["class"], row["striking_actor"], row["area_a"], row["area_b"]) == ("angle", "npc1", "right", "front")


def test_touching_again_after_separation_is_a_second_contact():
    """The follower hits a standing car (t = 1.6 s), which is shoved 6 m ahead; the follower rolls into it
    again after they were apart for over a second."""
    t = np.arange(STEPS) * 0.1
    ego_x = np.minimum(15.0 * t, 25.6 + 2.0 * np.clip(t - 1.71, 0, None))
    lead_x = 30.0 + np.clip((t - 1.7) * 10.0, 0, 6.0)
    ego = track(STEPS, x=ego_x, speed=np.gradient(ego_x, 0.1))
    lead = track(STEPS, x=lead_x, speed=np.gradient(lead_x, 0.1))
    rows = evaluate(tables({"ego": ego, "npc1": lead}), None).collisions.to_pylist()
    assert [r["contact_index"] for r in rows] == [0, 1]
    assert rows[0]["t"] == pytest.approx(1.6, abs=0.11) and rows[1]["t"] > rows[0]["t"] + 1.0
    assert all((r["class"], r["area_a"], r["area_b"]) == ("rear_end", "front", "rear") for r in rows)


def test_sides_slapping_together_right_after_a_first_impact_are_a_second_contact_of_their_own_class():
    """The ego's front strikes the right side of npc1 (heading south) square on (t = 1.0 s); one step later the
    two are apart, and the step after, the ego, turned by the impact, touches npc1 again with its left side,
    nearly parallel (rules.md: a collision is footprints overlapping; its class is the relative heading)."""
    steps = 20
    half = 4.5 / 2 * np.sin(np.radians(10.0)) + 1.9 / 2 * np.cos(np.radians(10.0))  # [m] ego's x extent at -80 deg
    ego = track(steps, speed=8.0)
    ego["x"] = np.concatenate([-3.0 - 0.8 * (10 - np.arange(11)), [-3.7], np.full(steps - 12, -0.95 - half + 0.15)])
    ego["yaw"] = np.concatenate([np.zeros(12), np.full(steps - 12, np.radians(-80.0))])
    npc1 = track(steps, yaw=-np.pi / 2, speed=0.0)
    rows = evaluate(tables({"ego": ego, "npc1": npc1}), None).collisions.to_pylist()
    assert [(r["contact_index"], r["class"]) for r in rows] == [(0, "angle"), (1, "sideswipe")]
    assert rows[0]["t"] == pytest.approx(1.0) and rows[1]["t"] == pytest.approx(1.2)
    assert (rows[0]["area_a"], rows[0]["area_b"], rows[1]["area_b"]) == ("front", "right", "right")
    reported = [contact("ego", "npc1", "angle", "front", "right"), contact("ego", "npc1", "sideswipe", "left", "right")]
    seen = [(r["actor_a"], r["actor_b"], r["class"], r["area_a"], r["area_b"]) for r in rows]
    assert match_sequence(seen, reported).sequence


def test_verdicts_and_summary_judge_the_written_sequence():
    scenario = loads(SCENARIO_TEXT)  # npc1 front into the right side of the ego, angle; CVC_21803 by npc1
    crossing = {"ego": track(STEPS, x0=0.0, speed=10.0),
                "npc1": track(STEPS, x0=12.0, y0=-14.0, yaw=np.pi / 2, speed=10.0, behavior="go_forward")}
    result = evaluate(tables(crossing, variations=2), scenario)
    verdicts = result.verdicts.to_pylist()
    assert all(v["first_contact"] and v["sequence"] and v["area_match"] for v in verdicts)
    summary = result.summary()
    assert (summary["first_contact_rate"], summary["sequence_rate"], summary["area_match_rate"]) == (1.0, 1.0, 1.0)
    assert summary["expected_sequence"] == [{"striking": "npc1", "struck": "ego", "striking_area": "front",
                                             "struck_area": "right", "class": "angle"}]
    assert summary["reproduction_rate"] == 0.0  # CVC_21803 by npc1 is not observed on these bare tracks


@pytest.mark.parametrize("collisions", [None, []])
def test_files_without_a_sequence_fall_back_or_expect_no_contact(collisions):
    scenario = loads(SCENARIO_TEXT).model_copy(update={"collisions": collisions})
    crossing = {"ego": track(STEPS, x0=0.0, speed=10.0),
                "npc1": track(STEPS, x0=12.0, y0=-14.0, yaw=np.pi / 2, speed=10.0)}
    [verdict] = evaluate(tables(crossing), scenario).verdicts.to_pylist()
    assert verdict["area_match"] is None  # no reported areas to compare
    assert verdict["first_contact"] is (collisions is None)  # fallback: the expected angle crash ego-npc1


def test_one_vehicle_with_a_written_empty_sequence_and_no_oracle_reproduces():
    # rules.md: every monitored oracle entry observed (none written) and the written sequence ([]) happened;
    # e.g. a lone car that struck an animal (animals are never actors)
    scenario = loads((EXAMPLES / "3-C5-2017-002" / "golden.yaml").read_text(encoding="utf-8"))
    assert scenario.oracle == [] and scenario.collisions == [] and not scenario.npcs
    [verdict] = evaluate(tables({"ego": track(STEPS, x0=0.0, speed=10.0)}), scenario).verdicts.to_pylist()
    assert verdict["reproduced"] and verdict["reason"] == "reproduced: one vehicle, no contact between actors"
    unwritten = scenario.model_copy(update={"collisions": None})
    [verdict] = evaluate(tables({"ego": track(STEPS, x0=0.0, speed=10.0)}), unwritten).verdicts.to_pylist()
    assert not verdict["reproduced"] and verdict["reason"].startswith("nothing observable")
