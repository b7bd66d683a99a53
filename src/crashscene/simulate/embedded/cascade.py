"""The motion a first impact gives the struck vehicle, predicted for planning a later contact (a cascade).

A rear-end can push the struck car out of its lane when it strikes one rear corner: the impulse
(`impact.exchange`, the simulator's own model) turns the struck car and it slides (`impact.slide`) the
way its nose points. `pushed_path` integrates that motion from the moment of contact, so that the plan
can place the third vehicle of the written sequence where the pushed car will be, when it is there.
`slide_path` is that slide for any vehicle already sliding (later.LaterMeetings times later contacts with it).
"""
from __future__ import annotations

import math

import numpy as np

from crashscene.geometry import classify_contact, wrap_angle
from crashscene.simulate.embedded import impact

DT = 0.05  # [s] integration step of the prediction
HORIZON = 4.0  # [s] how long after the impact the pushed car is followed
CORNER = 0.4  # [-] the striker's centre is this fraction of the struck car's width off its centre line


def pushed_path(v_striker: float, v_struck: float, side: float, m_striker: float, m_struck: float,
                l_striker: float, w_striker: float, l_struck: float, w_struck: float, friction: float,
                head_on: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, left, yaw) of the struck car every DT after a rear-end (or a head-on), in its own frame at
    the impact ([m], [m], [rad]); the striker comes from behind (from ahead, the other way) at `v_striker`
    [m/s], its centre `side` * CORNER * width to the struck car's left (side = +1) or right (-1); the struck
    car moves at `v_struck` [m/s]."""
    reach = (l_striker + l_struck) / 2 - 0.05
    xa = np.array([reach if head_on else -reach])
    ya = np.array([side * CORNER * w_struck])
    one = np.ones(1)
    yaw_a = (math.pi if head_on else 0.0) * one
    nx, ny, px, py = impact.contact_frame(xa, ya, yaw_a, l_striker * one, w_striker * one,
                                          0 * one, 0 * one, 0 * one, l_struck * one, w_struck * one)
    ma, mb = m_striker * one, m_struck * one
    ia = impact.yaw_inertia(ma, l_striker * one, w_striker * one)
    ib = impact.yaw_inertia(mb, l_struck * one, w_struck * one)
    va = np.array([[-v_striker if head_on else v_striker], [0.0]])
    vb = np.array([[v_struck], [0.0]])
    _, _, vb, wb, _ = impact.exchange(nx, ny, px, py, xa, ya, va, 0 * one, ma, ia, 0 * one, 0 * one, vb,
                                      0 * one, mb, ib)
    x, y, yaw = slide_path(np.zeros(1), np.zeros(1), np.zeros(1), vb[0], vb[1], wb, friction, l_struck * one,
                           w_struck * one, DT, int(HORIZON / DT))
    return x[0], y[0], yaw[0]


def slide_path(x, y, yaw, vx, vy, yaw_rate, friction: float, length, width, dt: float, steps: int):
    """(x, y, yaw) (N, steps) of N sliding vehicles every dt [s] from now ([m], [m/s], [rad/s] (N,)), integrated
    as the simulator moves a vehicle after an impact (simulator._move: impact.slide, trapezoidal), exact until
    it touches something else."""
    out = np.zeros((3, len(x), steps))
    for k in range(steps):
        vx1, vy1, w1 = impact.slide(vx, vy, yaw, yaw_rate, friction, length, width, dt)
        x = x + 0.5 * (vx + vx1) * dt
        y = y + 0.5 * (vy + vy1) * dt
        yaw = yaw + 0.5 * (yaw_rate + w1) * dt
        vx, vy, yaw_rate = vx1, vy1, w1
        out[:, :, k] = x, y, yaw
    return out[0], out[1], out[2]


def contact_class(relative_yaw: float) -> str:
    """The class (rules.md, geometry.classify_contact) of an end-on contact at this relative heading [rad]."""
    return str(classify_contact(abs(wrap_angle(relative_yaw)))[()])


AREAS = ("front", "left", "rear", "right")  # a body's faces, counter-clockwise from its heading


def facing_area(yaw_struck: float, yaw_striker: float) -> str:
    """The face of the struck body [rad heading] that a striker coming at heading `yaw_striker` [rad] meets:
    the one whose outward normal points most nearly back at it."""
    toward = yaw_striker + math.pi
    return max(zip(AREAS, range(4)), key=lambda f: math.cos(yaw_struck + f[1] * math.pi / 2 - toward))[0]


def to_world(x0: float, y0: float, yaw0: float, fwd: np.ndarray, left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World coordinates [m] of points given in the frame of a pose (x0, y0, yaw0)."""
    c, s = math.cos(yaw0), math.sin(yaw0)
    return x0 + fwd * c - left * s, y0 + fwd * s + left * c
