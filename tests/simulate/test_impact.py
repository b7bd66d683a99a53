"""Motion after impact (embedded.impact, embedded.cascade): where two footprints touch, and what a rear-end
into a corner does to the struck car."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.embedded import cascade, impact

L, W = 4.6, 1.8  # [m]


def frame(offset: float):
    """The contact frame of a striker from behind, its centre `offset` [m] left of the struck car's, just touching."""
    one = np.ones(1)
    return impact.contact_frame(np.array([-L + 0.05]), offset * one, 0 * one, L * one, W * one,
                                0 * one, 0 * one, 0 * one, L * one, W * one)


@pytest.mark.parametrize("offset", [-0.7, 0.0, 0.7])
def test_face_contact_point_lies_where_the_faces_overlap(offset):
    nx, ny, px, py = frame(offset)
    assert (nx[0], ny[0]) == pytest.approx((1.0, 0.0))
    overlap = (max(offset, 0.0) - W / 2 + min(offset, 0.0) + W / 2) / 2  # middle of the overlapping widths
    assert py[0] == pytest.approx(overlap, abs=1e-9) and px[0] == pytest.approx(-L / 2, abs=0.06)


@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_a_rear_end_into_a_corner_turns_the_struck_car_and_pushes_it_to_the_other_side(side):
    fwd, left, yaw = cascade.pushed_path(20.0, 0.0, side, 1500.0, 1500.0, L, W, L, W, 0.8)
    assert fwd[-1] > 5.0  # pushed ahead
    assert -side * yaw[-1] > 0.3 and -side * left[-1] > 1.0  # struck on its right rear corner: it turns left


def test_a_square_rear_end_pushes_straight_on():
    fwd, left, yaw = cascade.pushed_path(20.0, 0.0, 0.0, 1500.0, 1500.0, L, W, L, W, 0.8)
    assert fwd[-1] > 5.0 and abs(left[-1]) < 1e-6 and abs(yaw[-1]) < 1e-6


def test_pushed_paths_gives_each_offsets_pushed_path():
    offsets = np.array([-0.6, -0.3, 0.4])
    fwd, left, yaw = cascade.pushed_paths(20.0, 3.0, offsets, 2500.0, 1500.0, 5.5, 2.1, L, W, 0.7)
    for j, offset in enumerate(offsets):
        one = cascade.pushed_path(20.0, 3.0, np.sign(offset), 2500.0, 1500.0, 5.5, 2.1, L, W, 0.7,
                                  corner=abs(offset))
        assert np.array_equal(one[0], fwd[j]) and np.array_equal(one[1], left[j]) and np.array_equal(one[2], yaw[j])


@pytest.mark.parametrize(("deg", "klass", "margin"), [(10, "rear_end", 20), (100, "angle", 20), (70, "angle", 10),
                                                       (45, "sideswipe", 15), (140, "sideswipe", 10),
                                                       (170, "head_on", 20), (50, "angle", -10)])
def test_class_margin_is_the_distance_inside_the_class_heading_range(deg, klass, margin):
    assert float(cascade.class_margin(np.radians(deg), klass)) == pytest.approx(margin)
    assert float(cascade.class_margin(-np.radians(deg), klass)) == pytest.approx(margin)


def test_facing_area_is_the_face_turned_towards_the_striker():
    # a car heading +x, struck by vehicles coming from behind, from its left and head on
    areas = cascade.facing_area(np.zeros(3), np.array([0.0, -np.pi / 2, np.pi]))
    assert list(areas) == ["rear", "left", "front"]


@pytest.mark.parametrize(("deg", "margin"), [(10, 50), (45, 15), (170, 50), (130, 10), (80, -20)])
def test_a_side_to_side_contact_is_a_sideswipe_below_the_angle_range(deg, margin):
    # side to side (a car coming alongside into another's side), a near-parallel contact is a sideswipe, not a
    # rear-end or a head-on; end on it is not
    assert float(cascade.class_margin(np.radians(deg), "sideswipe", side=True)) == pytest.approx(margin)
    side = cascade.contact_class(np.radians([10.0, 45.0, 90.0, 170.0]), side=True)
    assert list(side) == ["sideswipe", "sideswipe", "angle", "sideswipe"]
    assert list(cascade.contact_class(np.radians([10.0, 170.0]))) == ["rear_end", "head_on"]


def test_a_third_car_is_met_on_its_side_only_by_a_written_sideswipe_there():
    assert cascade.meeting_mode("sideswipe", "right") == "side"
    assert cascade.meeting_mode("sideswipe", "front") == "front"
    assert cascade.meeting_mode("angle", "left") == "front"
    # a car heading +x struck on its right side: the striker comes from its right, so the striker's face towards it
    # is the one turned to +y (its left, when it heads +x too)
    toward = cascade.toward_third(np.zeros(1), "right")
    assert list(cascade.facing_area(np.zeros(1), toward - np.pi)) == ["left"]
    assert list(cascade.facing_area(np.zeros(1), cascade.toward_third(np.zeros(1), "left") - np.pi)) == ["right"]


def test_contact_penetration_is_minus_the_separation_bit_for_bit():
    """`impact.contact`'s penetration is what `separate` measures of the same poses (-footprint_separation),
    so a caller that has the contact may hand it to `separate` and move the bodies by the same floats."""
    from crashscene.geometry import footprint_separation

    rng = np.random.default_rng(4)
    n = 500
    poses = (rng.normal(0, 2, n), rng.normal(0, 2, n), rng.uniform(-4, 4, n), rng.uniform(3, 6, n),
             rng.uniform(1.5, 2.2, n), rng.normal(0, 2, n), rng.normal(0, 2, n), rng.uniform(-4, 4, n),
             rng.uniform(3, 6, n), rng.uniform(1.5, 2.2, n))
    nx, ny, px, py, penetration = impact.contact(*poses)
    assert np.array_equal(penetration, -footprint_separation(*poses))
    assert all(np.array_equal(p, q) for p, q in zip((nx, ny, px, py), impact.contact_frame(*poses)))
    ma, mb = rng.uniform(800, 3000, n), rng.uniform(800, 3000, n)
    alone = impact.separate(*poses[:5], ma, *poses[5:], mb)
    handed = impact.separate(*poses[:5], ma, *poses[5:], mb, frame=(nx, ny, penetration))
    assert all(np.array_equal(p, q) for p, q in zip(alone, handed))
    assert (penetration > 0).any() and (penetration < 0).any()  # both touching and apart poses were tried
