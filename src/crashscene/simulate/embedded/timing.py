"""Timing plans: when each actor starts moving and when its manoeuvre triggers, so that paths conflict.

A junction conflict: the actor's arrival at the conflict point with the anchor
(the ADS under test) is placed at the anchor's nominal arrival plus an offset
(`<role>_ARRIVAL_OFFSET` from the scene's sampled params, else drawn from the
variation's generator), by scaling its cruise speed within SPEED_SCALE and,
when it would still be early, holding it at its start until a trigger time.
A lateral manoeuvre (lane change, crossing the centre line, overtaking, losing
control, leaving the road) triggers so that it is under way when the two
vehicles meet. Everything is a pure function of the scene and its generator,
so variation i's plan depends only on (scenario, seed, i).
"""
from __future__ import annotations

import math

import numpy as np

from crashscene.simulate.drivers.behaviors import DRIFTING

SPEED_SCALE = (0.6, 1.4)  # [-] range of cruise-speed adjustment for timing
ARRIVAL_OFFSET_SD = 0.3  # [s] default spread of the arrival offset
ARRIVAL_OFFSET_MEAN = 0.25  # [s] the other actor arrives just after the anchor: it strikes the anchor's side
ARRIVAL_OFFSET_MAX = 0.8  # [s]
TURNER_LEAD = 0.0  # [s] a turning vehicle reaches a crossing conflict point this much before a straight one (measured best: 0)
REPRODUCE_OFFSET_SCALE = 0.4  # [-] reproduce mode narrows the sampled offset window (the crash must happen)
LATERAL_RATE = 1.2  # [m/s] lateral speed of a lane change
SWERVE_RATE = 2.0  # [m/s] lateral speed of a drift or swerve across the centre line or off the road
SWERVE_BEHAVIORS = DRIFTING  # the drifts across the centre line or off the road swerve at SWERVE_RATE


def lateral_rate(behavior: str) -> float:
    """Lateral speed [m/s] of the behaviour's manoeuvre."""
    return SWERVE_RATE if behavior in SWERVE_BEHAVIORS else LATERAL_RATE
STOP_DWELL = 1.0  # [s] time stopped at a stop sign before proceeding (drivers.longitudinal stop_dwell)
STOP_TAIL = 1.1  # [-] a smooth stop takes this much longer than braking at a constant rate


def arrival_time(dist: float, speed: float, accel: float, from_rest: bool = False,
                 stop_dist: float | None = None, brake: float = 2.5) -> float:
    """Nominal time [s] to travel `dist` [m] at cruise `speed` [m/s].

    from_rest: starts at 0 and accelerates at `accel` [m/s2]. stop_dist: stops at
    that distance first (stop sign), dwells STOP_DWELL, then accelerates from rest.
    """
    speed = max(speed, 0.5)
    if dist <= 0:
        return 0.0
    if stop_dist is not None and 0 < stop_dist < dist:
        speed = min(speed, math.sqrt(2 * brake * stop_dist))  # already slowing down when that close
        brake_len = speed ** 2 / (2 * brake)
        cruise_len = max(stop_dist - brake_len, 0.0)
        t_stop = cruise_len / speed + STOP_TAIL * speed / brake
        return t_stop + STOP_DWELL + _from_rest(dist - stop_dist, speed, accel)
    if from_rest:
        return _from_rest(dist, speed, accel)
    return dist / speed


def _from_rest(dist: float, speed: float, accel: float) -> float:
    ramp = speed ** 2 / (2 * accel)
    if dist <= ramp:
        return math.sqrt(2 * dist / accel)
    return speed / accel + (dist - ramp) / speed


def arrival_offset(params: dict, role: str, rng: np.random.Generator) -> float:
    """The sampled `<role>_ARRIVAL_OFFSET` [s] if the scene has it, else a draw from `rng`."""
    for key in (f"{role}_ARRIVAL_OFFSET", f"{role.upper()}_ARRIVAL_OFFSET"):
        if key in params:
            return float(params[key])
    return float(np.clip(rng.normal(ARRIVAL_OFFSET_MEAN, ARRIVAL_OFFSET_SD), -ARRIVAL_OFFSET_MAX, ARRIVAL_OFFSET_MAX))


def junction_plan(t_target: float, dist: float, speed: float, accel: float,
                  stop_dist: float | None = None) -> tuple[float, float]:
    """(speed_scale, hold_until [s]) that bring an actor `dist` [m] from the conflict point there at t_target [s]."""
    t_nominal = arrival_time(dist, speed, accel, stop_dist=stop_dist)
    if stop_dist is not None:
        return 1.0, max(0.0, t_target - t_nominal)
    if t_target <= 0:
        return SPEED_SCALE[1], 0.0
    scale = float(np.clip(t_nominal / t_target, *SPEED_SCALE))
    t_scaled = arrival_time(dist, speed * scale, accel)
    if t_scaled >= t_target - 0.05:
        return scale, 0.0
    # still early at the slowest allowed speed: wait at the start, then go (accelerating from rest)
    t_rest = arrival_time(dist, speed * scale, accel, from_rest=True)
    return scale, max(0.0, t_target - t_rest)


def lateral_trigger(gap: float, speed: float, partner_speed: float, opposite: bool, lateral_dist: float,
                    lead_time: float, rate: float = LATERAL_RATE) -> float:
    """Trigger time [s] of a lateral manoeuvre so that it is complete `lead_time` [s] before the meeting.

    A negative result means the manoeuvre should have started before the scene begins.

    gap: partner's station ahead along the actor's route minus the actor's [m] (negative: behind).
    opposite: the partner comes the other way (closing speed = sum of speeds).
    """
    duration = abs(lateral_dist) / rate
    if opposite:
        closing = max(speed + partner_speed, 1.0)
        t_meet = max(gap, 0.0) / closing
    else:
        rel = speed - partner_speed
        if abs(rel) < 0.3 or gap * rel <= 0:
            return max(0.0, 1.5 - duration / 2)
        t_meet = gap / rel
    return t_meet - duration - lead_time  # negative: the manoeuvre should already be under way at t = 0


def skid_trigger(gap: float, speed: float, partner_speed: float, lateral: float, spin: float = 0.35,
                 decel: float = 3.0, opposite: bool = True) -> float:
    """Trigger time [s] of a loss of control so that the skidding car reaches the partner's lane
    (`lateral` [m] to its side) just as they meet `gap` [m] ahead (negative: too late to reach it).

    The skid is integrated as the embedded simulator moves it: yaw rate `spin` [rad/s] (scaled down
    below 5 m/s), speed falling at `decel` [m/s2].
    """
    dt = 0.05
    v, yaw, y, x, t = max(speed, 0.5), 0.0, 0.0, 0.0, 0.0
    target = max(abs(lateral), 0.5)
    while y < target and t < 6.0 and v > 0.1:
        yaw += spin * min(v / 5.0, 1.0) * dt
        x += v * math.cos(yaw) * dt
        y += v * math.sin(yaw) * dt
        v = max(v - decel * dt, 0.0)
        t += dt
    partner = partner_speed * t if opposite else -partner_speed * t
    return (gap - x - partner) / max(speed + (partner_speed if opposite else -partner_speed), 0.5)
