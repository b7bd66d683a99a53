"""The geometric vocabulary: angle wrapping, footprints, overlap, contact classes, route projection."""
from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from crashscene.geometry import (
    classify_contact,
    footprint_corners,
    footprints_overlap,
    heading_difference,
    relative_position,
    wrap_angle,
)


@pytest.mark.parametrize("angle, wrapped", [(0.0, 0.0), (math.pi / 2, math.pi / 2), (3 * math.pi / 2, -math.pi / 2),
                                            (-3 * math.pi / 2, math.pi / 2), (7.0, 7.0 - 2 * math.pi)])
def test_wrap_angle_scalars_and_arrays_agree(angle, wrapped):
    assert wrap_angle(angle) == pytest.approx(wrapped, abs=1e-12)
    assert isinstance(wrap_angle(angle), float)
    assert wrap_angle(np.array([angle]))[0] == pytest.approx(wrapped, abs=1e-12)


def test_wrap_angle_keeps_the_array_form_bit_for_bit():
    # the simulator's state was always wrapped as (a + pi) mod 2 pi - pi: seeded runs keep their bytes
    a = np.random.default_rng(3).uniform(-9, 9, 1000)
    assert np.array_equal(wrap_angle(a), (a + np.pi) % (2 * np.pi) - np.pi)
    assert all(wrap_angle(float(v)) == math.remainder(float(v), 2 * math.pi) for v in a[:50])


def test_exact_array_wrap_is_the_ieee_remainder():
    a = np.concatenate([np.random.default_rng(4).uniform(-20, 20, 5000), [math.pi, -math.pi, 3 * math.pi, 0.0]])
    want = np.array([math.remainder(v, 2 * math.pi) for v in a])
    assert np.array_equal(wrap_angle(a, exact=True), want)


def test_heading_difference_is_unsigned_and_symmetric():
    assert heading_difference(0.1, -0.1) == pytest.approx(0.2)
    assert heading_difference(3.0, -3.0) == pytest.approx(2 * math.pi - 6.0)
    assert heading_difference(np.array([0.0]), np.array([math.pi]))[0] == pytest.approx(math.pi)


def test_footprint_corners_follow_yaw():
    corners = footprint_corners(10.0, 5.0, math.pi / 2, 4.0, 2.0)
    # facing +y: front-left, front-right, rear-right, rear-left
    assert corners == pytest.approx(np.array([[9.0, 7.0], [11.0, 7.0], [11.0, 3.0], [9.0, 3.0]]))


def test_footprint_overlap_agrees_with_shapely_on_random_rectangles():
    rng = np.random.default_rng(5)
    n = 2000
    xa, ya, xb, yb = rng.uniform(-6, 6, (4, n))
    ta, tb = rng.uniform(-math.pi, math.pi, (2, n))
    got = footprints_overlap(xa, ya, ta, 4.5, 2.0, xb, yb, tb, 7.0, 2.5)
    corners_a, corners_b = footprint_corners(xa, ya, ta, 4.5, 2.0), footprint_corners(xb, yb, tb, 7.0, 2.5)
    want = np.array([shapely.Polygon(a).intersects(shapely.Polygon(b)) for a, b in zip(corners_a, corners_b)])
    assert got.shape == (n,)
    assert want.any() and not want.all()
    assert np.array_equal(got, want)


def test_footprint_overlap_touching_counts_and_nan_never_overlaps():
    z = np.zeros(4)
    hit = footprints_overlap(z, z, z, 4.5, 1.9, np.array([4.0, 4.6, 2.0, np.nan]), np.array([0.0, 0.0, 2.0, 0.0]),
                             np.array([0.0, 0.0, math.pi / 4, 0.0]), 4.5, 1.9)
    assert hit.tolist() == [True, False, True, False]
    assert footprints_overlap(0.0, 0.0, 0.0, 4.0, 2.0, 4.0, 0.0, 0.0, 4.0, 2.0)  # nose to tail, touching


def test_relative_position_is_in_the_first_actors_frame():
    lon, lat = relative_position(1.0, 1.0, math.pi / 2, 0.0, 4.0)
    assert (lon, lat) == pytest.approx((3.0, 1.0))


@pytest.mark.parametrize("degrees, want", [(0, "rear_end"), (29, "rear_end"), (45, "sideswipe"), (90, "angle"),
                                           (120, "angle"), (135, "sideswipe"), (170, "head_on")])
def test_contact_classes_by_relative_heading(degrees, want):
    assert classify_contact(math.radians(degrees)) == want


def test_side_by_side_contacts_are_sideswipes():
    # b level with a (lateral gap closer to touching than the longitudinal one): sideswipe, not rear-end
    rel = np.radians([5.0, 5.0, 175.0])
    lon, lat = np.array([4.6, 1.0, 1.0]), np.array([0.2, 1.9, 1.9])
    got = classify_contact(rel, lon, lat, np.full(3, 4.5), np.full(3, 1.9))
    assert got.tolist() == ["rear_end", "sideswipe", "sideswipe"]


def test_end_on_says_how_contacts_without_offsets_touch():
    # side to side, a near-parallel contact is a sideswipe; an angle stays an angle (cascade.contact_class)
    rel = np.radians([5.0, 45.0, 90.0, 175.0])
    assert classify_contact(rel, end_on=False).tolist() == ["sideswipe", "sideswipe", "angle", "sideswipe"]
    assert classify_contact(rel, end_on=True).tolist() == classify_contact(rel).tolist()
    assert classify_contact(rel, end_on=np.array([True, True, False, False])).tolist() == \
        ["rear_end", "sideswipe", "angle", "sideswipe"]
    with pytest.raises(ValueError, match="not both"):
        classify_contact(rel, np.zeros(4), np.zeros(4), np.ones(4), np.ones(4), end_on=True)


def test_clip_scalar_gives_numpys_clip_float():
    """clip_scalar is float(np.clip(x, lo, hi)) bit for bit: NaN of x or of a bound, signed zeros at a bound (a tie
    keeps x), infinities, inverted bounds, numpy and Python floats."""
    import numpy as np

    from crashscene.geometry import clip_scalar

    rng = np.random.default_rng(0)
    values = [*rng.normal(0.0, 3.0, 300), 0.0, -0.0, 1.0, -1.0, 2.0, np.nan, np.inf, -np.inf, 5e-324]
    bounds = [(-1.0, 1.0), (0.0, 2.0), (-0.0, 0.0), (0, 7), (2.0, 0.0), (-np.inf, 0.0), (0.0, np.nan), (np.nan, 1.0)]
    for lo, hi in bounds:
        for x in values:
            for number in (x, np.float64(x)):
                want, got = float(np.clip(number, lo, hi)), clip_scalar(number, lo, hi)
                assert type(got) is float
                assert np.array_equal(np.array(want), np.array(got), equal_nan=True), (number, lo, hi)
                assert np.signbit(want) == np.signbit(got), (number, lo, hi)
