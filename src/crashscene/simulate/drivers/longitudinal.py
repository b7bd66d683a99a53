"""Longitudinal decisions shared by the NPC drivers and the reference ADS.

Car following (IDM), stopping for red and yellow lights, full stops at stop
signs, and gap acceptance before entering a conflict area; each can be
switched off to inject a disposition (a driver that ignores red lights...).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crashscene.simulate.drivers.base import (
    CONTROL_STOP,
    SIGNAL_RED,
    SIGNAL_YELLOW,
    DriverContext,
    Observation,
    idm_accel,
)

STOP_SPEED = 0.3  # [m/s] a full stop (rules.md rule 2)
STOP_ZONE = 4.0  # [m] a stop counts within this distance before the line
CURVE_LAT_ACCEL = 2.5  # [m/s2] lateral acceleration Observation.curve_speed is computed for
CURVE_FLOOR = 3.0  # [m/s] a driver slowing for a curve slows to no less than this
WAIT_BEFORE_CONFLICT = 3.0  # [m] where a yielding driver waits inside a junction (front bumper to conflict point)


@dataclass
class LongitudinalRules:
    """Which rules a driver follows, and how (dispositions switch rules off)."""

    headway: float = 1.5  # [s] IDM time headway
    min_gap: float = 2.0  # [m] IDM standstill gap
    obey_red: bool = True
    obey_stop: bool = True
    yields: bool = True
    gap_time: float = 4.0  # [s] accepted time-to-arrival of a vehicle with priority
    yellow_decel: float = 3.0  # [m/s2] stop on yellow when the stop needs less than this
    brake_comfort: float = 3.0  # [m/s2]
    stop_dwell: float = 1.0  # [s] time stopped at a stop sign before looking for a gap
    curve_speed: bool = True  # slow down for curvature
    lat_accel: float = 2.5  # [m/s2] lateral acceleration accepted in curves


class LongitudinalState:
    """Per-variation memory of the rules (stop-sign stops)."""

    def __init__(self, n: int):
        self.stopped_at_sign = np.zeros(n, dtype=bool)
        self.stop_timer = np.zeros(n)
        self.last_junction_dist = np.full(n, np.nan)

    def new_approach(self, junction_dist: np.ndarray) -> None:
        """Forget a completed stop when the next junction's entry jumps farther away (a new approach)."""
        jumped = junction_dist > self.last_junction_dist + 10.0
        self.stopped_at_sign &= ~jumped
        self.stop_timer = np.where(jumped, 0.0, self.stop_timer)
        self.last_junction_dist = junction_dist


def desired_speed(obs: Observation, cruise: np.ndarray, rules: LongitudinalRules) -> np.ndarray:
    """Cruise speed [m/s], limited by the curvature ahead when the driver slows for curves."""
    if not rules.curve_speed:
        return cruise
    # obs.curve_speed assumes 2.5 m/s2 lateral; v scales with sqrt(lateral acceleration)
    curve_limit = obs.curve_speed * np.sqrt(rules.lat_accel / CURVE_LAT_ACCEL)
    return np.minimum(cruise, np.maximum(curve_limit, CURVE_FLOOR))


def longitudinal_accel(obs: Observation, ctx: DriverContext, state: LongitudinalState, rules: LongitudinalRules,
                       desired: np.ndarray, lead_gap: np.ndarray | None = None,
                       lead_speed: np.ndarray | None = None) -> np.ndarray:
    """Acceleration [m/s2] from car following, signals, stop signs and yielding."""
    v = obs.speed
    limits = ctx.limits
    gap = obs.lead_gap if lead_gap is None else lead_gap
    lspeed = obs.lead_speed if lead_speed is None else lead_speed
    accel = idm_accel(v, desired, gap, lspeed, limits.accel_max, rules.brake_comfort, rules.headway, rules.min_gap)

    line = obs.stop_line_dist
    before_line = line > -0.5  # False where there is no stop line (NaN)
    zero = np.zeros_like(v)

    def stop_at(dist: np.ndarray) -> np.ndarray:
        return idm_accel(v, desired, np.maximum(dist, 0.05), zero, limits.accel_max, rules.brake_comfort,
                         0.5, 0.3)

    if rules.obey_red:
        can_stop = v ** 2 / (2 * np.maximum(np.nan_to_num(line, nan=0.0), 0.1)) < rules.yellow_decel
        red = (obs.signal == SIGNAL_RED) | ((obs.signal == SIGNAL_YELLOW) & can_stop)
        stop_red = red & before_line
        if stop_red.any():
            accel = np.where(stop_red, np.minimum(accel, stop_at(line)), accel)

    state.new_approach(obs.junction_dist)
    if rules.obey_stop:
        stop_control = (obs.control == CONTROL_STOP) & before_line
        state.stopped_at_sign |= stop_control & (v < STOP_SPEED) & (line < STOP_ZONE)
        state.stop_timer = np.where(state.stopped_at_sign & (v < STOP_SPEED), state.stop_timer + obs.dt,
                                    state.stop_timer)
        must_stop = stop_control & (~state.stopped_at_sign | (state.stop_timer < rules.stop_dwell))
        if must_stop.any():
            accel = np.where(must_stop, np.minimum(accel, stop_at(line)), accel)

    if rules.yields:
        hazard = (obs.yield_tta < rules.gap_time) | obs.yield_occupied
        wait_dist = np.where(before_line, line, obs.conflict_dist - WAIT_BEFORE_CONFLICT)
        committed = obs.conflict_dist < 1.0  # NaN (no conflict point) is not committed
        wait = hazard & (wait_dist > -0.3) & ~committed
        if wait.any():
            accel = np.where(wait, np.minimum(accel, stop_at(wait_dist)), accel)
    return accel
