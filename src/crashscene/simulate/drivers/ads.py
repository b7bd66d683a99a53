"""The reference ADS: a careful rule-following driver, the default system under test.

Lane following along the route of its DSL behaviour (turns included), IDM car
following, stopping for red lights (and for yellow when it can stop
comfortably), full stops at stop signs, gap acceptance before entering a
conflict area where another vehicle has priority, and lane changes only into
a sufficient gap. Every parameter is in `ReferenceAdsParams` and can be
overridden (`SimulationSettings.ads_params`, CLI `--ads-param key=value`).
"""
from __future__ import annotations

from collections import deque

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from crashscene.dsl.tokens import LANE_CHANGES
from crashscene.simulate.backend import SimulationError, import_ads
from crashscene.simulate.drivers.base import Action, Driver, DriverContext, Observation
from crashscene.simulate.drivers.longitudinal import (
    LongitudinalRules,
    LongitudinalState,
    desired_speed,
    longitudinal_accel,
)
from crashscene.units import G


class ReferenceAdsParams(BaseModel):
    """Parameters of the reference ADS."""

    model_config = ConfigDict(extra="forbid")

    reaction_time: float = Field(0.3, ge=0, le=3.0, description="[s] delay between perception and actuation")
    perception_range: float = Field(120.0, gt=0, description="[m] vehicles farther away are not seen")
    headway: float = Field(2.3, gt=0, description="[s] IDM desired time headway (CVC_21703 needs 2 s)")
    min_gap: float = Field(2.5, ge=0, description="[m] IDM standstill gap")
    brake_comfort: float = Field(3.0, gt=0, description="[m/s2] IDM comfortable deceleration")
    gap_acceptance: float = Field(4.5, gt=0, description="[s] smallest accepted time-to-arrival of a priority vehicle")
    lane_change_gap: float = Field(1.5, gt=0, description="[s] time gap needed ahead and behind in the target lane")
    lane_change_time: float = Field(2.0, ge=0, description="[s] after which a lane change behaviour starts")
    lat_accel: float = Field(2.0, gt=0, description="[m/s2] lateral acceleration accepted in curves")
    yellow_decel: float = Field(3.5, gt=0, description="[m/s2] stops on yellow when that suffices")
    defensive: bool = Field(True, description="also slow for a crossing vehicle without the right of way that is "
                                              "not braking for its own stop or yield line")
    defensive_window: float = Field(3.0, gt=0, description="[s] such a vehicle is a threat when it reaches the "
                                                           "conflict point within this time")
    defensive_decel: float = Field(5.0, gt=0, description="[m/s2] hardest braking used to let it pass")
    respect_speed_limit: bool = Field(True, description="never cruise above the posted limit times the "
                                                       "condition factor (wet, fog, snow, night)")


class ReferenceADS(Driver):
    """The default ADS under test (see module docstring)."""

    def __init__(self, params: dict | None = None):
        super().__init__(params)
        try:
            self.config = ReferenceAdsParams(**self.params)
        except ValidationError as exc:
            raise SimulationError(f"reference ADS parameters: {exc}") from exc
        self.perception_range = self.config.perception_range

    def reset(self, ctx: DriverContext) -> None:
        super().reset(ctx)
        c = self.config
        self.rules = LongitudinalRules(headway=c.headway, min_gap=c.min_gap, gap_time=c.gap_acceptance,
                                       yellow_decel=c.yellow_decel, brake_comfort=c.brake_comfort,
                                       lat_accel=min(c.lat_accel, 0.4 * ctx.friction * G))
        self.state = LongitudinalState(ctx.n_variations)
        self.commands: deque = deque(maxlen=max(1, int(round(c.reaction_time / ctx.dt)) + 1))
        self.lane_changed = np.zeros(ctx.n_variations, dtype=bool)

    def _defensive(self, obs: Observation) -> np.ndarray:
        """Brake for a crossing vehicle that will not stop: it arrives soon and is not slowing down."""
        c = self.config
        stop_dist = obs.cross_dist - 3.0  # wait with the front bumper 3 m short of the conflict point
        need = _stop_before(obs.speed, stop_dist)
        threat = (obs.cross_tta < c.defensive_window) & (np.nan_to_num(obs.cross_accel, nan=0.0) > -1.0) & (
            stop_dist > 0) & (-need < c.defensive_decel)
        return np.where(threat, need, np.inf)

    def step(self, obs: Observation) -> Action:
        ctx = self.ctx
        cruise = ctx.cruise_speed
        if self.config.respect_speed_limit:
            safe = obs.speed_limit * ctx.condition_factor
            cruise = np.where(np.isnan(safe), cruise, np.minimum(cruise, safe))
        accel = longitudinal_accel(obs, ctx, self.state, self.rules, desired_speed(obs, cruise, self.rules))
        if self.config.defensive:
            accel = np.minimum(accel, self._defensive(obs))
        self.commands.append(accel)
        delayed = self.commands[0]
        # an emergency seen now is not delayed beyond the reaction time: take the more cautious command
        accel = np.minimum(delayed, np.maximum(accel, -ctx.limits.brake_comfort))

        offset = np.zeros(ctx.n_variations)
        if ctx.behavior in LANE_CHANGES:
            gap = self.config.lane_change_gap
            ok = (obs.t >= self.config.lane_change_time) & (obs.target_gap_front > 5.0 + gap * obs.speed) & (
                obs.target_gap_rear > 5.0 + gap * np.nan_to_num(obs.target_rear_speed, nan=0.0))
            self.lane_changed |= ok
            offset = np.where(self.lane_changed, ctx.lateral_target, ctx.initial_offset)
        elif np.any(ctx.initial_offset != 0):
            offset = np.where(obs.t < 1.0, ctx.initial_offset, 0.0)
        return Action(accel=accel, lateral_offset=offset)


def _stop_before(speed: np.ndarray, dist: np.ndarray) -> np.ndarray:
    return -(speed ** 2) / (2.0 * np.maximum(dist, 0.1))


def load_driver(spec: str | None, params: dict | None = None):
    """The ADS driver named by 'package.module:Class' (None: the reference ADS), instantiated with params."""
    if spec is None:
        return ReferenceADS(params)
    cls = import_ads(spec)
    driver = cls(dict(params or {}))
    for method in ("reset", "step"):
        if not callable(getattr(driver, method, None)):
            raise SimulationError(f"--ads {spec!r}: {type(driver).__name__} has no {method}() method; "
                                  f"see crashscene.simulate.drivers.base for the step interface")
    return driver


__all__ = ["ReferenceADS", "ReferenceAdsParams", "load_driver"]
