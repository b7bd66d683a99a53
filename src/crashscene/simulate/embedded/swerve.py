"""A driver steering to a new lateral offset: the embedded simulator's pure pursuit (`simulator._move`: a
lookahead point on the lane at the reference offset, which moves toward the command at the manoeuvre's
lateral rate; a front wheel angle with a bounded rate; a kinematic bicycle), and the path it gives on a
straight road, from which the plan times a manoeuvre whose contact depends on how far across and how turned
the car is when it gets there (a pull-out clipping the car ahead).
"""
from __future__ import annotations

import numpy as np

from crashscene.geometry import wrap_angle

LOOKAHEAD = (4.0, 25.0)  # [m] pure-pursuit lookahead range
LOOKAHEAD_TIME = 0.9  # [s]
HORIZON = 6.0  # [s] how long a planned path runs after its trigger


def lookahead(speed: np.ndarray) -> np.ndarray:
    """[m] the pure-pursuit lookahead distance at a speed [m/s]."""
    return np.clip(LOOKAHEAD_TIME * speed + 3.0, *LOOKAHEAD)


def steer_step(steer: np.ndarray, alpha: np.ndarray, look: np.ndarray, wheelbase, steer_rate, steer_max,
               dt: float) -> np.ndarray:
    """[rad] the front wheel angle after one step, turned at most `steer_rate` [rad/s] toward the pure-pursuit
    angle for the lookahead point `alpha` [rad] off the heading, `look` [m] ahead."""
    steer_cmd = np.arctan2(2.0 * wheelbase * np.sin(alpha), look)
    steer = steer + np.clip(steer_cmd - steer, -steer_rate * dt, steer_rate * dt)
    return np.clip(steer, -steer_max, steer_max)


def bicycle_yaw_rate(speed, steer, wheelbase):
    """[rad/s] the yaw rate of a kinematic bicycle at `speed` [m/s] with front wheel angle `steer` [rad]."""
    return speed / wheelbase * np.tan(steer)


def bicycle_move(x, y, yaw, speed, yaw_rate, dt: float):
    """(x, y, yaw) [m, m, rad] of a kinematic bicycle after one step of `dt` [s] at `speed` [m/s] and `yaw_rate`
    [rad/s], moving along its mid-step heading (the embedded simulator's integration)."""
    heading = yaw + 0.5 * yaw_rate * dt
    return x + speed * np.cos(heading) * dt, y + speed * np.sin(heading) * dt, yaw + yaw_rate * dt


def bicycle_before(x, y, yaw, speed, yaw_rate, dt):
    """(x, y, yaw) [m, m, rad] of a kinematic bicycle `dt` [s] before the pose (x, y, yaw), driving at `speed`
    [m/s] and `yaw_rate` [rad/s]: the pose `bicycle_move` takes there in one step of dt."""
    yaw0 = yaw - yaw_rate * dt
    heading = yaw0 + 0.5 * yaw_rate * dt
    return x - speed * np.cos(heading) * dt, y - speed * np.sin(heading) * dt, yaw0


def path(speed: float, offset: float, rate: float, wheelbase: float, steer_rate: float, steer_max: float,
         dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, yaw) (1, n_steps) [m, m, rad] every dt [s] after a car driving straight along x at `speed` [m/s]
    is commanded to the lateral `offset` [m] (left positive), its reference moving there at `rate` [m/s]."""
    return paths([(speed, offset, rate, wheelbase, steer_rate, steer_max, dt)])[0]


def paths(requests: list[tuple[float, float, float, float, float, float, float]]
          ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """`path` of each request (speed, offset, rate, wheelbase, steer_rate, steer_max, dt), integrated at once,
    each element by element as it would be alone (requests of one dt)."""
    if not requests:
        return []
    speed, offset, rate, wheelbase, steer_rate, steer_max, dts = (np.array(q, dtype=float) for q in zip(*requests))
    dt = float(dts[0])
    if np.any(dts != dt):
        raise ValueError("swerve.paths: requests with different steps")
    steps = int(round(HORIZON / dt))
    n = len(requests)
    x, y, yaw, steer, d_ref = (np.zeros(n) for _ in range(5))
    look = lookahead(speed)
    rate_dt = rate * dt
    out = np.zeros((3, n, steps))
    for k in range(steps):
        d_ref = d_ref + np.minimum(np.maximum(offset - d_ref, -rate_dt), rate_dt)
        alpha = wrap_angle(np.arctan2(d_ref - y, look) - yaw)  # as the simulator wraps arrays
        steer = steer_step(steer, alpha, look, wheelbase, steer_rate, steer_max, dt)
        x, y, yaw = bicycle_move(x, y, yaw, speed, bicycle_yaw_rate(speed, steer, wheelbase), dt)
        out[:, :, k] = x, y, yaw
    return [(out[0, i:i + 1], out[1, i:i + 1], out[2, i:i + 1]) for i in range(n)]
