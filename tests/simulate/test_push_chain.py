"""A chain of rear-ends after a push (simulate.embedded.pushchain): the end-on push it predicts is the simulator's
impulse exchange, and on a synthetic queue the whole written chain happens."""
from __future__ import annotations

import math

import numpy as np
import pytest

from crashscene.simulate.embedded import impact
from crashscene.simulate.embedded.pushchain import meeting, pushed_speed
from tests.simulate.test_reproduce_configurations import actor, contact, oracle, run, scenario

N = 20  # variations (0.9 of 20: at most 2 misses)


def test_pushed_speed_is_the_simulators_end_on_exchange():
    la, wa, lb, wb, ma, mb = 4.9, 2.1, 4.5, 1.8, 1800.0, 1400.0
    one = np.ones(1)
    xa, xb = -(la + lb) / 2 + 0.01, 0.0  # a's front just inside b's rear, centre lines aligned
    nx, ny, px, py = impact.contact_frame(xa * one, 0 * one, 0 * one, la * one, wa * one, xb * one, 0 * one,
                                          0 * one, lb * one, wb * one)
    va, vb = np.array([[15.0], [0.0]]), np.array([[2.0], [0.0]])
    _, _, vb1, _, _ = impact.exchange(nx, ny, px, py, xa * one, 0 * one, va, 0 * one, ma * one,
                                      impact.yaw_inertia(ma, la, wa) * one, xb * one, 0 * one, vb, 0 * one,
                                      mb * one, impact.yaw_inertia(mb, lb, wb) * one)
    assert vb1[0, 0] == pytest.approx(pushed_speed(15.0, 2.0, ma, mb), rel=1e-6)
    assert abs(vb1[1, 0]) < 1e-9


@pytest.mark.parametrize("part", [0.1, 0.5, 0.9])
def test_meeting_is_where_the_rolling_car_has_covered_that_part_of_its_roll_out(part):
    closing, decel = 8.0, 2.7
    t, gap, at = meeting(closing, decel, part)
    assert gap == pytest.approx(closing * t - decel * t * t / 2)
    assert at == pytest.approx(closing - decel * t)
    assert gap == pytest.approx(part * closing ** 2 / (2 * decel))
    assert 0 < at < closing and math.isclose(at ** 2, closing ** 2 - 2 * decel * gap)


QUEUES = {  # how the cars ahead of the stopped car the ego strikes drive
    # stopped in the lane: 0.0 of 20 (the first push only, in 0.4) with the queue where sampled (15-20 m apart); 1.0
    # of 100 with each car ahead placed within the predicted roll-out of the one pushed into it
    "stopped": "stop",
    # going forward: waiting in the queue (held at their start till the push has reached them): 0.0 of 100 when they
    # drove off; 1.0 of 100 held and placed
    "waiting": "go_forward",
}


def queue(behavior: str) -> str:
    """A rear-end into a stopped car with two more ahead of it in its lane, each pushed into the next (written)."""
    return scenario(
        "divided", "speed_limit_sign", 55,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "stop", "reference: ego, relation: front, heading: same_direction")
        + "".join(actor(f"npc{i}", behavior, "reference: ego, relation: front, heading: same_direction")
                  for i in (2, 3)),
        oracle("CVC_21703", "following_too_closely", "ego"),
        contact("ego", "npc1", "front", "rear", "rear_end") + contact("npc1", "npc2", "front", "rear", "rear_end")
        + contact("npc2", "npc3", "front", "rear", "rear_end"))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(QUEUES))
def test_a_rear_end_into_a_queue_pushes_each_car_into_the_one_ahead(name, tmp_path):
    # a car struck from behind rolls on out of its driver's control into the car ahead, and that one into the next
    summary = run(queue(QUEUES[name]), tmp_path, N)
    assert summary["valid"] >= N * 0.9, summary.get("invalid")
    assert summary["first_contact_rate"] >= 0.9
    assert summary["sequence_rate"] >= 0.9, summary["collisions"]
