"""The impulse exchange at a contact (embedded.impact.exchange), checked against hand-computed impacts, and the
tyre forces after it (embedded.impact.tyre_slide)."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.embedded import impact
from crashscene.units import G

L, W = 4.6, 1.8  # [m]
M = 1500.0  # [kg]
E = impact.RESTITUTION


def one(value: float) -> np.ndarray:
    return np.array([float(value)])


def exchange(pa, va, wa, pb, vb, wb, normal, point, ma=M, mb=M):
    """exchange for one contact; poses (x, y), velocities (vx, vy) [m/s], yaw rates [rad/s]."""
    ia, ib = impact.yaw_inertia(one(ma), one(L), one(W)), impact.yaw_inertia(one(mb), one(L), one(W))
    out = impact.exchange(one(normal[0]), one(normal[1]), one(point[0]), one(point[1]), one(pa[0]), one(pa[1]),
                          np.array([[va[0]], [va[1]]]), one(wa), one(ma), ia, one(pb[0]), one(pb[1]),
                          np.array([[vb[0]], [vb[1]]]), one(wb), one(mb), ib)
    va1, wa1, vb1, wb1, j = (np.asarray(q, dtype=float) for q in out)
    return va1[:, 0], float(wa1[0]), vb1[:, 0], float(wb1[0]), j[:, 0], float(ia[0]), float(ib[0])


def test_a_central_rear_end_gives_the_textbook_delta_v():
    # 1500 kg at 20 m/s into 2500 kg at 5 m/s, centre to centre: dv_b = (1 + e) m_a / (m_a + m_b) x 15 m/s
    va, wa, vb, wb, j, _, _ = exchange((-L, 0.0), (20.0, 0.0), 0.0, (0.0, 0.0), (5.0, 0.0), 0.0, (1.0, 0.0),
                                       (-L / 2, 0.0), mb=2500.0)
    dv_b = (1 + E) * 1500.0 / 4000.0 * 15.0
    assert vb == pytest.approx([5.0 + dv_b, 0.0])
    assert va == pytest.approx([20.0 - dv_b * 2500.0 / 1500.0, 0.0])
    assert wa == pytest.approx(0.0) and wb == pytest.approx(0.0)
    assert (vb[0] - va[0]) == pytest.approx(E * 15.0)  # separating at E times the approach speed


@pytest.mark.parametrize(("offset", "side_speed"), [(0.6, 0.0), (-0.5, 3.0), (0.8, -6.0)])
def test_an_eccentric_impact_conserves_momentum_and_creates_no_energy(offset, side_speed):
    # a striker's front into the left side of a crossing car, off its centre: the struck car turns
    pa, pb = (0.0, -(W + L) / 2 + 0.02), (offset, 0.0)
    point = (0.0, -W / 2)
    va0, vb0, wa0, wb0 = np.array([1.0, 15.0]), np.array([side_speed, 0.5]), 0.2, -0.1
    va, wa, vb, wb, j, ia, ib = exchange(pa, va0, wa0, pb, vb0, wb0, (0.0, 1.0), point)
    assert M * (va + vb) == pytest.approx(M * (va0 + vb0))  # linear momentum

    def angular(v, w, p, inertia):  # about the origin [kg m2/s]
        return M * (p[0] * v[1] - p[1] * v[0]) + inertia * w

    before = angular(va0, wa0, pa, ia) + angular(vb0, wb0, pb, ib)
    after = angular(va, wa, pa, ia) + angular(vb, wb, pb, ib)
    assert after == pytest.approx(before, rel=1e-9, abs=1e-6)

    def energy(v, w, inertia):
        return 0.5 * M * float(v @ v) + 0.5 * inertia * w ** 2

    assert energy(va, wa, ia) + energy(vb, wb, ib) <= energy(va0, wa0, ia) + energy(vb0, wb0, ib) + 1e-6
    assert j[1] > 0  # the struck car is pushed away from the striker
    # the tangential impulse never exceeds MU_CONTACT times the normal one
    assert abs(j[0]) <= impact.MU_CONTACT * j[1] + 1e-9
    # struck behind its centre (offset > 0 puts the point on its rear half), it turns the other way than ahead
    assert np.sign(wb - wb0) == np.sign(-offset)


def test_a_sticking_impact_leaves_the_contact_points_together_along_the_face():
    # a slow push with little sliding along the face: the points stick (no tangential relative velocity after)
    pa, pb = (-L, 0.3), (0.0, 0.0)
    va, wa, vb, wb, j, _, _ = exchange(pa, (8.0, 0.2), 0.0, pb, (0.0, 0.0), 0.0, (1.0, 0.0), (-L / 2, 0.3))
    rx_a, ry_a, rx_b, ry_b = L / 2, 0.0, -L / 2, 0.3
    vpa = va + wa * np.array([-ry_a, rx_a])
    vpb = vb + wb * np.array([-ry_b, rx_b])
    assert vpb[1] - vpa[1] == pytest.approx(0.0, abs=1e-9)
    assert vpb[0] - vpa[0] == pytest.approx(E * 8.0, rel=1e-6)


def test_bodies_already_separating_exchange_nothing():
    va, wa, vb, wb, j, _, _ = exchange((-L, 0.0), (2.0, 0.0), 0.0, (0.0, 0.0), (5.0, 0.0), 0.0, (1.0, 0.0),
                                       (-L / 2, 0.0))
    assert np.all(j == 0.0) and va == pytest.approx([2.0, 0.0]) and vb == pytest.approx([5.0, 0.0])


def slide(v, heading_of_velocity, yaw_rate, seconds=6.0, dt=0.01, friction=0.8):
    """A car at yaw 0 after an impact: (speed, yaw rate, heading turned) after `seconds` of tyre forces."""
    vx, vy = one(v * np.cos(heading_of_velocity)), one(v * np.sin(heading_of_velocity))
    yaw, w = one(0.0), one(yaw_rate)
    for _ in range(int(seconds / dt)):
        vx1, vy1, w1 = impact.tyre_slide(vx, vy, yaw, w, friction, one(L), one(W), one(0.6 * L), dt)
        yaw = yaw + 0.5 * (w + w1) * dt
        vx, vy, w = vx1, vy1, w1
    return float(np.hypot(vx, vy)[0]), float(w[0]), float(yaw[0])


def test_without_yaw_the_tyres_roll_and_slide_at_the_simulators_rates():
    friction, dt = 0.8, 0.01
    for heading, decel in ((0.0, impact.ROLL_FRACTION * friction * G), (np.pi / 2, friction * G)):
        speed = slide(10.0, heading, 0.0, seconds=1.0, dt=dt, friction=friction)[0]
        assert speed == pytest.approx(10.0 - decel * 1.0, abs=1e-6)


def test_a_car_spun_while_sliding_sideways_keeps_turning_longer_than_one_rolling_on():
    _, _, turned_sliding = slide(12.0, np.pi / 2, 2.0)
    _, _, turned_rolling = slide(3.0, 0.0, 2.0)
    _, _, turned_still = slide(0.0, 0.0, 2.0)
    assert turned_sliding > 2.0 * turned_rolling > 0
    # at rest the two axles' friction stops the spin as the friction torque of the box would: mu g h / k^2
    h, k2 = 0.3 * L, (L ** 2 + W ** 2) / 12
    assert turned_still == pytest.approx(2.0 ** 2 / (2 * 0.8 * G * h / k2), rel=0.05)


def test_the_tyres_never_add_energy():
    rng = np.random.default_rng(3)
    n = 200
    vx, vy, w = rng.normal(0, 10, n), rng.normal(0, 10, n), rng.normal(0, 2, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    k2 = (L ** 2 + W ** 2) / 12
    before = vx ** 2 + vy ** 2 + k2 * w ** 2
    vx1, vy1, w1 = impact.tyre_slide(vx, vy, yaw, w, 0.7, np.full(n, L), np.full(n, W), np.full(n, 0.6 * L), 0.1)
    assert np.all(vx1 ** 2 + vy1 ** 2 + k2 * w1 ** 2 <= before + 1e-9)
