"""The slide after an impact as the cascade plan predicts it (simulate.embedded.cascade.slide_path), and the same
bytes for the same seed on a cascade."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from crashscene.dsl import loads
from crashscene.pipeline.simulate import simulate_scenario
from crashscene.simulate.embedded import impact
from crashscene.simulate.embedded.cascade import slide_path
from crashscene.units import G


@pytest.mark.parametrize("friction", [0.4, 0.8])
def test_slide_path_rolls_and_slides_to_rest_at_the_simulators_rates(friction):
    dt, steps = 0.01, 1200
    v = np.array([10.0, 6.0])
    # the first car rolls straight on, the second slides sideways (its heading across its velocity)
    x, y, yaw = slide_path(np.zeros(2), np.zeros(2), np.array([0.0, np.pi / 2]), v * [1, 1], np.zeros(2),
                           np.zeros(2), friction, np.full(2, 4.5), np.full(2, 1.8), dt, steps)
    roll = impact.ROLL_FRACTION * friction * G
    assert x[0, -1] == pytest.approx(v[0] ** 2 / (2 * roll), rel=0.02)
    assert x[1, -1] == pytest.approx(v[1] ** 2 / (2 * friction * G), rel=0.02)
    assert np.abs(y).max() < 1e-9 and np.all(yaw[:, -1] == yaw[:, 0])


@pytest.mark.slow
def test_a_cascade_gives_the_same_bytes_for_the_same_seed(tmp_path):
    from tests.simulate.test_reproduce_configurations import CASCADE

    for name in ("a", "b"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scenario(loads(CASCADE), tmp_path / name, 4, 7, mode="reproduce")
    for name in ("traces", "collisions", "variations"):
        assert (tmp_path / "a" / f"{name}.parquet").read_bytes() == (tmp_path / "b" / f"{name}.parquet").read_bytes()


def test_touch_again_flags_a_striker_that_catches_up_with_the_car_it_pushed():
    from crashscene.simulate.embedded.cascade import DT, SEPARATE_STEPS, touch_again

    t = np.arange(40) * DT
    struck = (np.stack([2.0 * t] * 3), np.zeros((3, 40)), np.zeros((3, 40)))
    # the strikers start touching its rear; the first falls back, then comes faster and catches up, the second falls
    # back, the third goes on pushing (it never leaves it: no new contact)
    striker = (np.stack([-4.45 + 2.0 * t - 1.0 * t + 3.0 * t ** 2, -4.45 - 1.0 * t, -4.46 + 2.0 * t]),
               np.zeros((3, 40)), np.zeros((3, 40)))
    again = touch_again(struck, striker, 4.5, 1.8, 4.5, 1.8)
    assert not again[:, :SEPARATE_STEPS].any()
    assert again[0, -1] and not again[0, 4] and np.all(np.diff(again[0].astype(int)) >= 0)  # once touched, it stays
    assert not again[1].any()
    assert not again[2].any()


def test_pushed_paths_gives_the_strikers_slide_from_where_it_struck():
    from crashscene.simulate.embedded.cascade import pushed_paths

    offsets = np.array([-0.4, 0.4])
    alone = pushed_paths(20.0, 0.0, offsets, 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8)
    struck, (x, y, yaw) = pushed_paths(20.0, 0.0, offsets, 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8, striker=True)
    for a, b in zip(alone, struck):
        assert np.array_equal(a, b)
    # the striker came from behind, slowed by the impact: it stays behind the struck car's centre, off its line
    assert np.all(x < struck[0]) and np.all(np.sign(y[:, 0]) == np.sign(offsets))
    assert np.all(np.diff(x, axis=1) >= -1e-9)


def test_clip_slide_starts_where_a_car_driving_straight_on_touches_the_slower_car_ahead():
    from crashscene.simulate.embedded.cascade import DT, clip_slide

    dt, speed, partner_speed, ahead = 0.1, 20.0, 12.0, 10.0
    t = dt * np.arange(1, 61)
    rows = (speed * t, np.zeros(60), np.zeros(60))  # no pull-out at all: straight on, the partner 0.9 m aside
    touch = (ahead - 4.5) / (speed - partner_speed)  # [s] the bumpers meet
    t_meet = dt * np.ceil(touch / dt - 1e-9)
    car = (4.5, 1.8, 1500.0, 0.6)
    t_touch, (along, across, yaw) = clip_slide(rows, 1.0, speed, 0.0, ahead, partner_speed, -0.9, t_meet, dt, car,
                                               car, 0.8)
    assert t_touch == pytest.approx(touch, abs=dt / 100)
    # it slides on from where it touched, slower than it came and no faster than the partner it pushed ahead
    assert along[0] == pytest.approx(speed * touch, abs=speed * DT + 0.1)
    assert np.all(np.diff(along) / DT < speed)
    # pushed back on its right front corner (the car it clipped is on its right) it turns right, clockwise
    assert yaw[10] < -0.05 and np.all(np.diff(yaw[:10]) < 0.0)


@pytest.mark.parametrize("partner_speed, slides", [(19.7, False), (12.0, True)])
def test_a_clip_slides_only_when_it_upsets_the_car(partner_speed, slides):
    """A clip that changes the car's velocity and yaw rate too little to upset it (crashscene.upset) leaves its
    driver driving on, as the simulator does: no slide is predicted for it."""
    from crashscene.simulate.embedded.cascade import Clip, clip_slides

    dt, speed = 0.1, 20.0
    t = dt * np.arange(1, 61)
    rows = (speed * t, np.zeros(60), np.zeros(60))
    ahead = 4.5 + (speed - partner_speed) * 3.02  # [m] the bumpers meet 3 s on
    touch = (ahead - 4.5) / (speed - partner_speed)
    t_meet = dt * np.ceil(touch / dt - 1e-9)
    car = (4.5, 1.8, 1500.0, 0.6)
    found = clip_slides([Clip(rows, 1.0, speed, 0.0, ahead, partner_speed, -0.9, t_meet, dt, car, car, 0.8)])[0]
    assert (found is not None) == slides


def test_pushes_of_several_impacts_at_once_equal_each_alone():
    from crashscene.simulate.embedded.cascade import Push, pushed_paths, pushes

    items = [Push(20.0, 0.0, np.array([-0.4, 0.3]), 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8),
             Push(14.0, 11.0, np.array([0.5]), 15000.0, 1500.0, 12.0, 2.5, 4.2, 1.7, 0.5, True, (0.55, 0.6)),
             Push(25.0, 3.0, np.array([0.3, 0.4, 0.6]), 1800.0, 1400.0, 4.8, 1.9, 4.4, 1.8, 0.7),
             Push(25.0, 3.0, np.array([0.3, 0.6]), 1800.0, 1400.0, 4.8, 1.9, 4.4, 1.8, 0.7, stepped=False),
             Push(18.0, 0.0, np.array([0.5]), 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8, dt=0.05)]
    together = pushes(items)
    for item, (struck, striker) in zip(items, together):
        alone = pushed_paths(item.v_striker, item.v_struck, item.offsets, item.m_striker, item.m_struck,
                             item.l_striker, item.w_striker, item.l_struck, item.w_struck, item.friction,
                             item.head_on, striker=True, wheelbase_ratios=item.wheelbase_ratios, stepped=item.stepped)
        if item.dt != items[0].dt:
            continue  # pushed_paths steps at the simulator's default step
        for a, b in zip((*alone[0], *alone[1]), (*struck, *striker)):
            assert a.shape == b.shape and np.array_equal(a, b)
    # without the striker's slide the struck car's is the same
    assert all(np.array_equal(a, b) for a, b in zip(pushes(items[:1], striker=False)[0][0], together[0][0]))


def test_a_push_stepped_through_the_contact_turns_an_angled_striker_as_the_simulator_does():
    from crashscene.simulate.embedded.cascade import Push, pushes

    # a striker drifting 1.3 deg to the right into the right rear corner of a parked car at 27 m/s: at the
    # simulator's 0.1 s step the two turn into each other after the first exchange and exchange again, and the
    # striker is thrown to the left (one exchange at the first touch turns it right; measured in the simulator:
    # left, +15 deg 0.1 s after the touch, tests/simulate/test_rollout.py)
    common = (27.0, 0.0, np.array([0.3]), 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8)
    (_, (_, _, stepped)), (_, (_, _, once)) = pushes([Push(*common, approach=math.radians(-1.3)),
                                                      Push(*common, stepped=False)])
    assert stepped[0, 4] > math.radians(20.0) and once[0, 4] < 0.0
    # a 3 m/s touch upsets neither (crashscene.upset): stepped as the simulator steps it, the parked car is pushed
    # straight on and keeps its heading, where one exchange's slide turns it
    slow = (3.0, 0.0, np.array([0.6]), 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8)
    (stepped, _), (once, _) = pushes([Push(*slow), Push(*slow, stepped=False)])
    assert np.all(stepped[2] == 0.0) and np.all(stepped[1] == 0.0) and np.abs(once[2]).max() > 0.01


def test_step_lead_is_the_time_from_the_simulators_last_step_to_the_touch():
    from crashscene.simulate.embedded.cascade import step_lead

    assert step_lead(0.715, 0.1) == pytest.approx(0.015)
    assert step_lead(0.7, 0.1) == pytest.approx(0.1)  # a touch on a step: the whole step before it
    assert step_lead(0.05, 0.1) == pytest.approx(0.05)


def test_where_in_its_step_the_touch_falls_changes_what_the_repeated_exchanges_do():
    # an offset rear-end into a parked car, stepped as the simulator steps it: the same touch found early or late
    # in a simulator step leaves the bodies differently deep at the next steps (the plan gives it the touch's
    # time, cascade.step_lead)
    from crashscene.simulate.embedded.cascade import Push, pushes

    items = [Push(28.0, 0.0, np.array([0.3]), 1500.0, 1500.0, 4.8, 2.2, 4.7, 1.8, 0.8, False, (0.6, 0.6), 0.1,
                  -0.015, -0.05, lead=lead) for lead in (0.015, 0.1)]
    (_, early), (_, late) = pushes(items)
    assert np.all(np.isfinite(early[2])) and abs(early[2][0, 10] - late[2][0, 10]) > math.radians(5)


def test_a_drifting_striker_touches_at_its_approach_heading_and_place(monkeypatch):
    """A striker whose driver turns it right at 0.055 rad/s (a drift to the road's edge) comes into the corner of
    a parked car: its approach (-0.025 rad) is its heading at the touch, 0.06 s after the simulator's last step,
    and it touches there end to end (its centre the two half lengths behind the struck car's): the prediction
    starts it a step earlier less turned (measured on 3-C1-2017-001: started at its approach heading, the striker
    came 0.003 rad further right, and its slide after the impact drifted 0.1 m/s off the simulator's)."""
    from crashscene.simulate.embedded import cascade, rollout

    seen, original = [], rollout.stepped

    def stepped(a, b, *args, **kwargs):
        steps = rollout.contact_steps(a.copy(), b.copy(), 0.8, 0.1, 2)
        seen.append(next(s for s in steps if s.onset.any()).contact)
        return original(a, b, *args, **kwargs)

    monkeypatch.setattr(cascade.rollout, "stepped", stepped)
    push = cascade.Push(28.0, 0.0, np.array([0.3]), 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8, dt=0.1,
                        approach=-0.025, approach_rate=-0.055, lead=0.06)
    cascade.pushes([push])
    xa, ya, yaw_a = (float(q[0]) for q in seen[0][:3])
    assert yaw_a == pytest.approx(-0.025, abs=1e-4)
    assert (xa, ya) == pytest.approx((-4.5, 0.3 * 1.8), abs=0.01)  # (its front corner first: 0.007 m sooner)
