"""A loss of control planned from its impact: how fast the car spins and how far its path veers, so that it
reaches its partner's lane turned the way the contact says (the side of a car rotated ~90 deg for an
`angle` contact, its front for a `head_on`), and after how long / how far along the road.

The skid is the sliding motion of `impact.slide` (one model for the plan and the simulator): the body
yaws at the planned rate (held while out of control), the velocity keeps its direction but decays, the part
across the body at the tyre friction, so the path bends toward where the car points.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from crashscene.simulate.embedded import impact

SPIN_RATES = np.array([0.05, 0.15, 0.25, 0.35, 0.5, 0.7, 0.9, 1.2])  # [rad/s] candidate yaw rates of a car out of control
DRIFT_ANGLES = np.array([0.08, 0.15, 0.25, 0.35])  # [rad] candidate veer of the velocity at the loss of control
DT = 0.05  # [s] plan integration step
PLACED_TRIGGER = 1.0  # [s] when the partner is placed to meet the skid, the skid starts this late
HORIZON = 6.0  # [s] a skid that has not reached the partner's lane by then does not count
# relative heading [rad] between the two vehicles at contact that each class needs (rules.md bands, mid)
CLASS_HEADING = {"rear_end": 0.1, "head_on": math.pi - 0.2, "angle": math.pi / 2, "sideswipe": 0.4}


@dataclass(frozen=True)
class Skid:
    """A planned loss of control: signed yaw rate [rad/s] held for `hold` [s], signed velocity veer [rad],
    and the time [s] to lose control so that the partner meets the car `t_meet` [s] later."""

    spin_rate: float
    drift: float
    trigger: float
    t_meet: float
    hold: float
    partner_shift: float = 0.0  # [m] the partner must start this much further along its road to meet


def rotation_for(contact_class: str | None, opposite: bool, rng_value: float) -> float:
    """How far [rad] the spinning car should have turned at contact; `rng_value` in [0, 1) varies it."""
    if contact_class is None:
        return math.radians(20.0 + 50.0 * rng_value)  # not written: somewhere between a drift and a side-on slide
    if contact_class == "angle":
        return math.radians(75.0 + 25.0 * rng_value)
    turned = abs((math.pi if opposite else 0.0) - CLASS_HEADING[contact_class])
    return max(turned + math.radians(10.0 * (rng_value - 0.5)), 0.0)


def lateral_band(contact_class: str | None, lane_width: float) -> tuple[float, float]:
    """Offset [m] between the two centres, across the road, at which the contact has its class: end-on
    contacts (head_on, rear_end) nearly in line, a sideswipe half across, an angle anywhere in the lane."""
    if contact_class in ("head_on", "rear_end"):
        return 0.0, 0.6
    if contact_class == "sideswipe":
        return 1.2, 2.2
    return 0.0, lane_width / 2 + (0.0 if contact_class == "angle" else 0.5)


def trajectories(speed: float, friction: float, length: float, width: float) -> tuple[np.ndarray, ...]:
    """Skids of every candidate (spin, drift), left-turning: (spin, drift, X, Y, YAW), X/Y/YAW (n_cand, n_steps)
    along/across the road [m] and the body's turn [rad] every DT after losing control."""
    spin, drift = np.meshgrid(SPIN_RATES, DRIFT_ANGLES)
    spin, drift = spin.ravel(), drift.ravel()
    n = len(spin)
    vx = np.full(n, max(speed, 0.5)) * np.cos(drift)
    vy = np.full(n, max(speed, 0.5)) * np.sin(drift)
    yaw, x, y = np.zeros(n), np.zeros(n), np.zeros(n)
    lengths, widths = np.full(n, length), np.full(n, width)
    steps = int(HORIZON / DT)
    out = np.zeros((3, n, steps))
    for k in range(steps):
        vx1, vy1, _ = impact.slide(vx, vy, yaw, spin, friction, lengths, widths, DT)
        x += 0.5 * (vx + vx1) * DT
        y += 0.5 * (vy + vy1) * DT
        yaw = yaw + np.where(np.hypot(vx1, vy1) > impact.REST_SPEED, spin, 0.0) * DT
        vx, vy = vx1, vy1
        out[:, :, k] = x, y, yaw
    return spin, drift, out[0], out[1], out[2]


def plan(speed: float, gap: float, partner_speed: float, opposite: bool, partner_lateral: float,
         lane_width: float, friction: float, length: float, width: float, rotation: float,
         contact_class: str | None = None, latest: float = 12.0, dwell: float = 0.0) -> Skid | None:
    """The loss of control that puts the car in its partner's lane, turned closest to `rotation` [rad], just
    as the partner gets there. gap: partner's station ahead along the road [m] (negative: behind);
    partner_lateral: its lane's offset [m] (left positive). None when no candidate meets the partner."""
    spin, drift, x, y, yaw = trajectories(speed, friction, length, width)
    sign = 1.0 if partner_lateral >= 0 else -1.0
    tau = DT * np.arange(1, x.shape[1] + 1)[None, :]
    sigma = -1.0 if opposite else 1.0
    closing = speed - sigma * partner_speed
    lo, hi = lateral_band(contact_class, lane_width)
    off = np.abs(sign * y - partner_lateral)
    in_lane = (off >= lo) & (off <= hi)
    if abs(closing) > 0.5:
        t_trig = (gap + sigma * partner_speed * tau - x) / closing
        ok = in_lane & (t_trig >= 0.0) & (t_trig <= latest)
    else:
        t_trig = np.full(x.shape, 1.0)
        ok = in_lane & (np.abs(gap + sigma * partner_speed * tau - x) < 1.5)
    if dwell > 0:
        # it is in the partner's lane for `dwell` [s] before they meet (a wrong-side driver is seen there)
        k = int(round(dwell / DT))
        ok[:, k:] &= in_lane[:, :-k]
        ok[:, :k] = False
    if ok.any():
        miss = np.where(ok, np.abs(yaw - rotation) + 0.02 * tau, np.inf)
        c, k = np.unravel_index(int(np.argmin(miss)), miss.shape)
        return Skid(sign * float(spin[c]), sign * float(drift[c]), float(t_trig[c, k]), float(tau[0, k]),
                    float(tau[0, k]) + 0.5)
    # no start time meets the partner where it is: keep the best skid and place the partner to meet it
    miss = np.where(in_lane, np.abs(yaw - rotation) + 0.02 * tau, np.inf)
    if not np.isfinite(miss).any():
        return None
    c, k = np.unravel_index(int(np.argmin(miss)), miss.shape)
    t0 = PLACED_TRIGGER
    needed = speed * t0 + x[c, k] - sigma * partner_speed * (t0 + tau[0, k])
    return Skid(sign * float(spin[c]), sign * float(drift[c]), t0, float(tau[0, k]), float(tau[0, k]) + 0.5,
                float(needed - gap))
