"""Meeting at the planned contact, closed loop: in reproduce mode the actor that keeps its speed freely (the
follower) adjusts its cruise speed every step so that it reaches the conflict point of the first written contact
just when its partner (the leader) is where the contact says: the striker's front at the middle-to-rear of the
struck actor's side. The open-loop plan (plan.py) places and times both; this corrects what its kinematics
could not foresee (a turn taken faster, a driver slowing for its line). Like OpenSCENARIO's synchronisation.
The leader's arrival is extrapolated from its present motion: gaining speed up to its cruise, braking for the
curve of its turn down to the speed that curve allows (`leader_turn_speed`), else holding its speed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SYNC_RANGE = (0.5, 1.5)  # [-] the follower's cruise stays within this factor of its planned cruise
SYNC_FREEZE = 0.8  # [s] closer than this to the conflict point the follower stops adjusting
LEADER_MOVING = 0.3  # [m/s] a leader slower than this (waiting at its line) gives no arrival time yet
LEADER_ACCEL = 2.0  # [m/s2] a leader below its cruise speed is assumed to gain speed at this rate
LEADER_BRAKING = 0.2  # [m/s2] a leader braking harder than this before a curve is assumed to brake on to its speed


def arrival_time(dist: np.ndarray, v: np.ndarray, cruise: np.ndarray) -> np.ndarray:
    """Time [s] to cover `dist` [m] from speed v [m/s], gaining speed at LEADER_ACCEL up to `cruise`."""
    dist = np.maximum(dist, 0.0)
    v = np.maximum(v, 0.1)
    vc = np.maximum(cruise, v)
    d_ramp = (vc ** 2 - v ** 2) / (2 * LEADER_ACCEL)
    t_ramp = (np.sqrt(v ** 2 + 2 * LEADER_ACCEL * np.minimum(dist, d_ramp)) - v) / LEADER_ACCEL
    return t_ramp + np.maximum(dist - d_ramp, 0.0) / vc


def braking_time(dist: np.ndarray, v: np.ndarray, decel: np.ndarray, v_end: np.ndarray) -> np.ndarray:
    """Time [s] to cover `dist` [m] from speed v [m/s] braking at `decel` [m/s2] down to v_end [m/s], then
    holding it."""
    decel = np.maximum(decel, 1e-3)
    v_end = np.maximum(np.minimum(v_end, v), 0.5)
    dist = np.maximum(dist, 0.0)
    d_brake = (v ** 2 - v_end ** 2) / (2 * decel)
    within = dist <= d_brake
    t_within = (v - np.sqrt(np.maximum(v ** 2 - 2 * decel * np.minimum(dist, d_brake), 0.0))) / decel
    return np.where(within, t_within, (v - v_end) / decel + (dist - d_brake) / v_end)


@dataclass
class Meeting:
    """Per variation (V,): follower and leader actor columns (-1: none), their conflict stations [m], and
    whether the follower strikes (its front meets the leader's side) or is struck."""

    follower: np.ndarray
    leader: np.ndarray
    cs_follower: np.ndarray
    cs_leader: np.ndarray
    follower_strikes: np.ndarray
    leader_stop: np.ndarray  # [m] station of the stop line the leader stops at first, -inf if none
    struck_offset: np.ndarray  # [m] how far past the striker's path the struck centre is at contact (plan)
    leader_turn_speed: np.ndarray  # [m/s] the speed the leader's curves up to its conflict point allow (at its
    # driver's comfortable lateral acceleration; inf: none given)

    @classmethod
    def none(cls, n_v: int) -> "Meeting":
        return cls(np.full(n_v, -1), np.full(n_v, -1), np.full(n_v, np.nan), np.full(n_v, np.nan),
                   np.zeros(n_v, dtype=bool), np.full(n_v, -np.inf), np.zeros(n_v), np.full(n_v, np.inf))

    def cruise(self, s: np.ndarray, v: np.ndarray, accel: np.ndarray, length: np.ndarray, width: np.ndarray, planned: np.ndarray,
               current: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(variation indices, new cruise [m/s]) of the followers still adjusting; s, v, length, width,
        planned and current are (V, A). A leader gaining speed (accel > 0.2 m/s2) is assumed to go on gaining
        it up to its planned cruise; otherwise it keeps its speed."""
        idx = np.nonzero(self.follower >= 0)[0]
        if len(idx) == 0:
            return idx, np.zeros(0)
        f, l_ = self.follower[idx], self.leader[idx]
        dist_f = self.cs_follower[idx] - s[idx, f]
        dist_l = self.cs_leader[idx] - s[idx, l_]
        v_f, v_l = np.maximum(v[idx, f], 0.5), v[idx, l_]
        strikes = self.follower_strikes[idx]
        s_i = np.where(strikes, f, l_)
        t_i = np.where(strikes, l_, f)
        v_s = np.maximum(v[idx, s_i], 1.0)
        v_t = np.maximum(v[idx, t_i], 1.0)
        side_hit = (length[idx, s_i] / 2 + width[idx, t_i] / 2) / v_s + self.struck_offset[idx] / v_t
        gaining = accel[idx, l_] > 0.2
        eta_l = np.where(gaining, arrival_time(dist_l, v_l, planned[idx, l_]), dist_l / np.maximum(v_l, 0.1))
        # a leader braking for the curve of its turn goes on braking down to the speed the curve allows
        braking = (accel[idx, l_] < -LEADER_BRAKING) & (v_l > self.leader_turn_speed[idx] + 0.1)
        eta_l = np.where(braking, braking_time(dist_l, v_l, -accel[idx, l_], self.leader_turn_speed[idx]), eta_l)
        want = eta_l + np.where(strikes, side_hit, -side_hit)
        # a leader that must first stop at its line gives an arrival time only once it pulls away from it
        departed = s[idx, l_] + length[idx, l_] / 2 > self.leader_stop[idx] + 0.5
        active = departed & (dist_f / v_f > SYNC_FREEZE) & (dist_l > -length[idx, l_] / 2) & (v_l > LEADER_MOVING) \
            & (want > 0.2)
        base = planned[idx, f]
        new = np.clip(dist_f / np.maximum(want, 0.2), SYNC_RANGE[0] * base, SYNC_RANGE[1] * base)
        new = np.where(active, new, current[idx, f])
        return idx, new
