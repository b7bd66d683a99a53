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
