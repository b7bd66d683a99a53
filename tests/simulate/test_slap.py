"""A side slap after an offset angle impact (embedded.slap): the written sequence that asks for one, the contact
physics that gives one (a touch ahead of the struck car's centre), and the bodies that no longer pass through each
other after an exchange (embedded.impact.separate)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from crashscene.geometry import footprint_separation
from crashscene.simulate.embedded import impact, rollout, slap, touch
from crashscene.simulate.embedded.vehicles import VehicleLimits

L, W = 4.7, 1.85  # [m]
M = 1500.0  # [kg]


def body(speed: float) -> slap.Body:
    return slap.Body(touch.Mover(0, 0.0, speed, None, L, W, VehicleLimits()), M)


def first_touch(d: np.ndarray, rel_deg: float, v_s: float, v_t: float, turn: float):
    """Poses and motions at a first touch: the striker (heading +x) with its front right corner on the struck
    car's right side, d [m] ahead of the struck centre; the struck car heading rel_deg clockwise of the striker,
    turning left at `turn` [rad/s]."""
    n = len(d)
    yaw_t = np.full(n, -math.radians(rel_deg))
    px, py = L / 2, -W / 2  # the striker's front right corner
    # the struck car's right side faces (sin yaw, -cos yaw): its centre is half a width behind that face
    xt = px - np.sin(yaw_t) * W / 2 - d * np.cos(yaw_t)
    yt = py + np.cos(yaw_t) * W / 2 - d * np.sin(yaw_t)
    zero = np.zeros(n)
    poses = ([zero, zero.copy(), zero.copy()], [xt, yt, yaw_t])
    motions = ([np.full(n, v_s), zero.copy(), zero.copy()],
               [v_t * np.cos(yaw_t), v_t * np.sin(yaw_t), np.full(n, turn)])
    return poses, motions


@pytest.mark.parametrize(("contacts", "expected"), [
    ([("ego", "npc1", "angle"), ("ego", "npc1", "sideswipe")], True),
    ([("ego", "npc1", "angle"), ("npc1", "ego", "sideswipe")], True),  # the same pair, whoever strikes
    # another car touching one of the two in between: their motion after the first touch is not theirs alone
    ([("ego", "npc1", "angle"), ("ego", "npc2", "angle"), ("ego", "npc1", "sideswipe")], False),
    ([("ego", "npc1", "angle"), ("npc2", "npc3", "rear_end"), ("ego", "npc1", "sideswipe")], True),
    ([("ego", "npc1", "angle")], False),
    ([("ego", "npc1", "angle"), ("ego", "npc1", "angle")], False),
    ([("ego", "npc1", "rear_end"), ("ego", "npc1", "sideswipe")], False),
    ([("ego", "npc1", "angle"), ("npc1", "npc2", "sideswipe")], False),  # another pair's contact comes first
])
def test_a_slap_is_the_same_pairs_sideswipe_after_its_angle_contact(contacts, expected):
    assert slap.slaps_after(contacts, "ego", "npc1") is expected


@pytest.mark.parametrize("v_s", [12.0, 16.0, 22.0])
def test_a_front_into_the_side_ahead_of_the_centre_is_followed_by_a_side_slap(v_s):
    # the struck car (a left turner at 4 m/s, 106 deg to the striker) struck 1.5-2.0 m ahead of its centre turns
    # away from the striker's path and its rear swings into the striker's side, nearly parallel
    d = np.array([1.5, 1.7, 2.0])
    poses, motions = first_touch(d, 106.0, v_s, 4.0, 0.4)
    margin = slap.after_touch(poses, motions, (body(v_s), body(4.0)), np.ones(len(d)), 0.8, 0.1)
    assert (margin >= slap.SLAP_MARGIN).all(), margin


def test_a_front_into_the_side_behind_the_centre_is_not():
    # struck behind its centre the struck car turns the other way, its rear away from the striker
    d = np.array([-1.5, -1.0, -0.5])
    poses, motions = first_touch(d, 106.0, 16.0, 4.0, 0.4)
    margin = slap.after_touch(poses, motions, (body(16.0), body(4.0)), np.ones(len(d)), 0.8, 0.1)
    assert np.isneginf(margin).all(), margin


def test_overlapping_bodies_are_pushed_apart_along_the_normal_the_lighter_one_further():
    # b 0.4 m into a's front, b half a's mass: a moves back a third of the excess, b forward two thirds
    x = np.array([0.0, 0.0])
    xb = np.array([L - 0.4, L + 1.0])  # the second pair does not overlap
    dxa, dya, dxb, dyb = impact.separate(x, x, x, L, W, np.full(2, 2.0 * M), xb, x, x, L, W, np.full(2, M))
    excess = 0.4 - impact.OVERLAP_KEPT
    assert dxa == pytest.approx([-excess / 3, 0.0])
    assert dxb == pytest.approx([2 * excess / 3, 0.0])
    assert dya == pytest.approx([0.0, 0.0]) and dyb == pytest.approx([0.0, 0.0])
    gap = footprint_separation(x + dxa, x, x, L, W, xb + dxb, x, x, L, W)
    assert gap[0] == pytest.approx(-impact.OVERLAP_KEPT)


def test_a_fresh_touch_is_left_where_it_is():
    # a contact's onset (moved back to where the two first touched) keeps its overlap for the monitor to read
    x = np.zeros(1)
    moves = impact.separate(x, x, x, L, W, np.full(1, M), np.full(1, L - 0.01), x, x, L, W, np.full(1, M))
    assert all(m == pytest.approx([0.0]) for m in moves)


@pytest.mark.parametrize(("d", "rel_deg", "v_s", "v_t"), [
    ([1.5, 1.7, 2.0, -1.0], 106.0, 16.0, 4.0),  # slaps ahead of the centre, none behind it
    # a slow striker the impulse does not upset: its driver drives it on along its heading (the simulator's
    # rule), not carried on at the impulse's velocity and yaw rate, and it does not touch the struck car again
    ([0.6, 0.8, 1.0], 130.0, 4.0, 8.0),
])
def test_after_touch_steps_the_pair_as_rollout_does_through_its_first_touch(d, rel_deg, v_s, v_t):
    # the pair a simulator step before it touches, stepped by rollout's stepping (rollout.contact_steps, as
    # `rollout` steps a pair) through the touch and on, and after_touch from the poses at that touch: the same
    # next touch and so the same margin (one stepping of a contact, not two)
    d = np.array(d)
    n, dt = len(d), 0.1
    poses, motions = first_touch(d, rel_deg, v_s, v_t, 0.0)  # straight on: one step back is exact
    ones = np.ones(n)
    bodies = [rollout.Bodies(*(np.asarray(p, dtype=float) - dt * v for p, v in zip(pose[:2], motion[:2])),
                             np.asarray(pose[2], dtype=float) * ones, *(np.asarray(v, dtype=float) * ones
                                                                          for v in motion),
                             L * ones, W * ones, M * ones, VehicleLimits().wheelbase_ratio * L * ones,
                             np.zeros(n, dtype=bool), np.zeros(n))
              for pose, motion in zip(poses, motions)]
    bodies[0].x += 0.05  # [m] the striker a little further in, so that its first step crosses the touch
    steps = rollout.contact_steps(*bodies, 0.8, dt, int(round(slap.HORIZON / dt)) + 1)
    first = next(steps)
    assert first.onset.all()
    at_touch = [first.contact[:3], first.contact[3:]]
    expected = np.full(n, -np.inf)
    done = np.zeros(n, dtype=bool)
    for step in steps:
        expected, done = slap.touched_again(step, expected, done, L, W)
    got = slap.after_touch(at_touch, motions, (body(v_s), body(v_t)), ones, 0.8, dt)
    np.testing.assert_allclose(got, expected, atol=1e-6)
