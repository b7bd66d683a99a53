"""NPC drivers: each executes its actor's DSL behaviour, with oracle codes injected as dispositions.

Dispositions (reproduce mode injects them into every actor, test mode into the NPCs):
each oracle code injects the traits its rule class declares (`Rule.disposition`,
`crashscene.monitor.rules.Disposition`): a driver charged with a right-of-way
code does not yield, one charged with CVC_21453 runs red lights, with CVC_22350
drives too fast for conditions, reacts late and does not slow for curves (and
loses control when its behaviour says so), and so on. Centre-line codes
(CVC_21650, CVC_21460) inject nothing: the DSL behaviour crosses the line.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from crashscene.dsl.tokens import LANE_CHANGES, OPPOSING_PASSES
from crashscene.monitor.rules import Disposition, codes_with, dispositions_of
from crashscene.simulate.drivers.base import (
    Action,
    Driver,
    DriverContext,
    Observation,
    stop_accel,
)
from crashscene.simulate.drivers.longitudinal import (
    LongitudinalRules,
    LongitudinalState,
    desired_speed,
    longitudinal_accel,
)
from crashscene.units import G

CLOSE_HEADWAY = 0.5  # [s] a tailgater's time headway
REACTION = 1.0  # [s] perception-reaction time of an ordinary human driver
TAILGATE_RANGE = 80.0  # [m] a tailgater matches the speed of a car ahead closer than this
PULL_OUT_BEHAVIORS = LANE_CHANGES + OPPOSING_PASSES
PULL_OUT_GAP = 2.0  # [m] a tailgater about to pass pulls out when this close to the car ahead...
PULL_OUT_TIME = 0.25  # [s] ...or this close in time
CLOSING_SPEED = 3.0  # [m/s] how much faster than the car ahead a tailgater about to pass drives
CROSSING_YAW = 0.7  # [rad] a lead more than this off the route's heading is crossing, not followed
LATE_REACTION = 1.8  # [s] perception delay of an inattentive driver
OVERSPEED = 1.25  # [-] a speeding driver's cruise speed factor
DECELERATE_TO = 0.25  # [-] decelerate: fraction of cruise speed it slows to
DECELERATE_RATE = 4.0  # [m/s2]
SPIN_RATE = 0.35  # [rad/s] yaw rate of a vehicle out of control
OVERTAKE_TIME = 6.0  # [s] in the opposing lane during an overtake
DRIFTING = ("cross_centerline", "overtake", "lose_control", "leave_road")
EDGE_TARGETS = ("leave_road",)  # behaviours that steer over the road's edge: their lateral target is that edge
# (setup: the road edge's offset), not an offset from their lane, so a plan that moves their start across keeps it
LANE_CHANGE_GAP = 1.0  # [s] time gap a careful driver needs in the target lane


# The oracle codes a driver carries inject the traits their rule classes declare (`Rule.disposition`).
SPEEDING_CODES = codes_with(Disposition.SPEEDING)  # the built-in rules' speeding codes
NO_YIELD_CODES = codes_with(Disposition.NO_YIELD)  # the built-in rules' codes of drivers who take the right of way
OVER_LIMIT = 3.0  # [m/s] a speeding driver's margin above the (condition-adjusted) limit


def speed_factor(dispositions: frozenset[str]) -> float:
    """Factor on the sampled speed of a speeding driver (also its initial speed)."""
    return OVERSPEED if Disposition.SPEEDING in dispositions_of(dispositions) else 1.0


def rules_for(dispositions: frozenset[str], friction: float = 0.8) -> LongitudinalRules:
    """The longitudinal rules of a driver carrying these oracle codes."""
    traits = dispositions_of(dispositions)
    return LongitudinalRules(
        lat_accel=min(2.5, 0.4 * friction * G),
        headway=CLOSE_HEADWAY if Disposition.TAILGATES in traits else 1.5,
        obey_red=Disposition.RUNS_RED not in traits,
        obey_stop=Disposition.RUNS_STOP not in traits,
        yields=Disposition.NO_YIELD not in traits,
        curve_speed=Disposition.CARELESS not in traits,
    )


class DelayedPerception:
    """Lead-vehicle perception delayed by a reaction time; a vehicle cutting across the path from the side
    (more than CROSSING_YAW off the route's heading) is not anticipated at all: scripted drivers re-enact
    the report, where the vehicle with priority did not avoid the one that pulled out."""

    def __init__(self, delay: float, dt: float):
        self.buffer: deque = deque(maxlen=max(1, int(round(delay / dt)) + 1))

    def __call__(self, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        crossing = np.abs(np.sin(np.nan_to_num(obs.lead_rel_yaw))) > np.sin(CROSSING_YAW)
        gap = np.where(crossing, np.inf, obs.lead_gap)
        speed = np.where(crossing, np.nan, obs.lead_speed)
        self.buffer.append((gap, speed))
        gap, speed = self.buffer[0]
        return gap, speed


class BehaviorDriver(Driver):
    """Drives one actor's DSL behaviour in every variation of the batch."""

    def reset(self, ctx: DriverContext) -> None:
        super().reset(ctx)
        traits = dispositions_of(ctx.dispositions)
        self.rules = rules_for(ctx.dispositions, ctx.friction)
        self.speeding = Disposition.SPEEDING in traits
        self.careless = Disposition.CARELESS in traits
        self.state = LongitudinalState(ctx.n_variations)
        inattentive = Disposition.INATTENTIVE in traits
        self.perception = DelayedPerception(LATE_REACTION if inattentive else REACTION, ctx.dt)
        self.cruise = ctx.cruise_speed  # already includes the speeding factor (embedded.setup plans with it)
        self.check_gap = Disposition.NO_GAP_CHECK not in traits
        self.tailgater = Disposition.TAILGATES in traits
        self.pulled_out = np.zeros(ctx.n_variations, dtype=bool)
        self.lane_changed = np.zeros(ctx.n_variations, dtype=bool)
        self.stopping = np.zeros(ctx.n_variations, dtype=bool)

    def _cruise(self, obs: Observation) -> np.ndarray:
        """Desired speed [m/s]: the sampled one, capped at the condition-adjusted limit unless speeding."""
        limit = obs.speed_limit
        if self.speeding:
            factor = self.ctx.condition_factor if self.careless else 1.0
            floor = np.where(np.isnan(limit), 0.0, limit * factor + OVER_LIMIT)
            return np.maximum(self.cruise, floor)
        return np.where(np.isnan(limit), self.cruise, np.minimum(self.cruise, limit * self.ctx.condition_factor))

    def step(self, obs: Observation) -> Action:
        ctx = self.ctx
        behavior = ctx.behavior
        n = ctx.n_variations
        triggered = obs.t >= ctx.trigger_time
        if self.tailgater and behavior in PULL_OUT_BEHAVIORS:
            # a tailgater pulls out late: when it has closed in on the car ahead in its lane, or on the
            # plan's trigger when no car is close ahead
            lead_near = obs.lead_gap < TAILGATE_RANGE / 2
            close = obs.lead_gap < np.maximum(PULL_OUT_GAP, PULL_OUT_TIME * obs.speed)
            self.pulled_out |= close | (triggered & ~lead_near)
            triggered = self.pulled_out
        if behavior == "static":
            return Action(accel=np.full(n, -ctx.limits.brake_max))

        lead_gap, lead_speed = self.perception(obs)
        if behavior in DRIFTING:
            # drifting across the centre line or off the road: the driver does not react to what is ahead
            gap = obs.lead_gap if lead_gap is None else lead_gap
            lead_gap = np.where(triggered, np.inf, gap)
            lead_speed = np.where(triggered, np.nan, obs.lead_speed if lead_speed is None else lead_speed)
        cruise = self._cruise(obs)
        if self.tailgater:
            # a tailgater keeps up with the car ahead: it closes in to its short headway
            near = np.nan_to_num(obs.lead_gap, posinf=np.inf) < TAILGATE_RANGE
            closing = np.nan_to_num(obs.lead_speed) + (CLOSING_SPEED if behavior in PULL_OUT_BEHAVIORS else 0.0)
            cruise = np.where(near & ~np.isnan(obs.lead_speed), np.maximum(cruise, closing), cruise)
        if behavior == "decelerate":
            cruise = np.where(triggered, cruise * DECELERATE_TO, cruise)
        accel = longitudinal_accel(obs, ctx, self.state, self.rules, desired_speed(obs, cruise, self.rules),
                                   lead_gap, lead_speed)
        if behavior == "decelerate":
            accel = np.where(triggered & (obs.speed > cruise), np.minimum(accel, -DECELERATE_RATE), accel)
        if behavior == "stop":
            near_junction = np.nan_to_num(obs.junction_dist, nan=np.inf) < 40.0
            to_line = np.where(near_junction, obs.junction_dist - 1.0, np.nan)
            self.stopping |= triggered | (obs.speed < 0.1)
            brake = np.where(near_junction, stop_accel(obs.speed, to_line, ctx.limits.brake_max),
                             -DECELERATE_RATE)
            accel = np.where(self.stopping, np.minimum(accel, brake), accel)
        hold = obs.t < ctx.hold_until
        accel = np.where(hold, -ctx.limits.brake_max, accel)

        offset = np.zeros(n)
        lose = None
        spin = None
        if behavior in LANE_CHANGES:
            ok = triggered
            if self.check_gap:
                ok = ok & (obs.target_gap_front > 5.0 + LANE_CHANGE_GAP * obs.speed) & (
                    obs.target_gap_rear > 5.0 + LANE_CHANGE_GAP * np.nan_to_num(obs.target_rear_speed, nan=0.0))
            self.lane_changed |= ok
            offset = np.where(self.lane_changed, ctx.lateral_target, ctx.initial_offset)
        elif behavior == "cross_centerline":
            offset = np.where(triggered, ctx.lateral_target, ctx.initial_offset)
        elif behavior == "overtake":
            passing = triggered & (obs.t < ctx.trigger_time + OVERTAKE_TIME)
            offset = np.where(passing, ctx.lateral_target, 0.0)
        elif behavior == "leave_road":
            # before its trigger it holds the offset it starts at (a plan starts it partway across a drift it times)
            offset = np.where(triggered, ctx.lateral_target, ctx.initial_offset)
            beyond = triggered & (np.abs(obs.d) > np.abs(ctx.lateral_target) * 0.8)
            accel = np.where(beyond, -DECELERATE_RATE, accel)
        elif behavior == "lose_control":
            lose = triggered
            spin = np.where(ctx.lateral_target >= 0, SPIN_RATE, -SPIN_RATE)
            accel = np.where(triggered, -3.0, accel)
        else:
            # settles onto its lane's centre after its start, or holds the offset its plan gives it; a driver still in
            # control after a contact (crashscene.upset) holds its lane's centre
            offset = np.where(obs.t < 2.0, ctx.initial_offset, ctx.lateral_target)
            offset = np.where(obs.collided, 0.0, offset)
        return Action(accel=accel, lateral_offset=offset, lose_control=lose, spin_rate=spin)
