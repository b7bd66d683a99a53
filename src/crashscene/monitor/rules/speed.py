"""Speed rules: CVC 22350 (basic speed law, conditions) and CVC 22349 (maximum speed).

The limit at each step is the scenario's posted `speed_limit_mph`, else the
trace's lane limit, else the statutory defaults (25 mph at junctions, 55 mph on
a two-lane two-way road, 65 mph otherwise); `limit_source: trace` makes the
map's lane limit win over the scenario's.
"""
from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from crashscene.monitor.context import EvalContext
from crashscene.monitor.rules.base import Disposition, Rule, RuleOutcome, RuleParams, register_rule
from crashscene.monitor.timeseries import (
    first_index,
    margin_in,
    steps_for,
    window_min,
)
from crashscene.units import G, MPH



JUNCTION_LIMIT_MPH = 25.0  # [mph] where no limit is posted, in a junction (rules.md rule 7; CVC 22352 prima facie)
TWO_LANE_LIMIT_MPH = 55.0  # [mph] where no limit is posted, on a two-lane two-way road (CVC 22349(b))
ROAD_LIMIT_MPH = 65.0  # [mph] where no limit is posted, elsewhere (CVC 22349(a))


def two_lane_two_way(number_of_ways: int, number_of_lanes: int) -> bool:
    """A two-lane undivided road (CVC 22349(b)): two ways, at most two through lanes in all."""
    return number_of_ways == 2 and number_of_lanes <= 2


def unposted_limit(number_of_ways: int, number_of_lanes: int, in_junction: bool) -> float:
    """[m/s] the limit the speed rules apply where none is posted, with their default parameters."""
    if in_junction:
        return JUNCTION_LIMIT_MPH * MPH
    return (TWO_LANE_LIMIT_MPH if two_lane_two_way(number_of_ways, number_of_lanes) else ROAD_LIMIT_MPH) * MPH


class LimitParams(RuleParams):
    limit_source: Literal["scenario", "trace"] = Field(
        default="scenario", description="which posted limit wins when both the DSL and the trace give one")
    junction_limit_mph: float = Field(default=JUNCTION_LIMIT_MPH, gt=0, le=100,
                                      description="[mph] default limit in junctions")
    two_lane_limit_mph: float = Field(default=TWO_LANE_LIMIT_MPH, gt=0, le=100,
                                      description="[mph] default limit on two-lane two-way roads")
    default_limit_mph: float = Field(default=ROAD_LIMIT_MPH, gt=0, le=100, description="[mph] default limit elsewhere")
    start_grace: float = Field(default=2.0, ge=0, le=30, description="[s] from the start of a trace during which "
                               "an ADS's speed is the test's initial condition, not its choice")


def speed_limit(ctx: EvalContext, p: LimitParams) -> np.ndarray:
    """(V, A, T) applicable limit [m/s]."""
    a = ctx.arrays
    trace_limit = a.floats["speed_limit"]
    road = ctx.scenario.road_network if ctx.scenario is not None else None
    two_lane = road is not None and two_lane_two_way(road.number_of_ways, road.number_of_lanes)
    road_default = (p.two_lane_limit_mph if two_lane else p.default_limit_mph) * MPH
    default = np.where(a.flag("in_junction"), p.junction_limit_mph * MPH, road_default)
    scenario_limit = ctx.scenario_speed_limit()
    trace_ok = np.isfinite(trace_limit) & (trace_limit > 0)
    if scenario_limit is None:
        return np.where(trace_ok, trace_limit, default)
    if p.limit_source == "trace":
        return np.where(trace_ok, trace_limit, scenario_limit)
    return np.full(trace_limit.shape, scenario_limit)


def sustained_excess(ctx: EvalContext, excess: np.ndarray, duration: float, grace: float) -> np.ndarray:
    """(V, A, T) lowest excess over the `duration` [s] ending at each step (> 0: exceeded all along),
    counting from `grace` [s] after the actor's first sample."""
    return window_min(np.where(ctx.settled(grace), excess, np.nan), steps_for(duration, ctx.dt))


class SpeedLimitParams(LimitParams):
    tolerance: float = Field(default=1.0, ge=0, le=10, description="[m/s] allowed above the posted limit")
    min_duration: float = Field(default=1.0, gt=0, le=30, description="[s] the excess must last this long")


@register_rule
class SpeedLimit(Rule):
    code = "CVC_22349"
    violation = "speed_limit"
    unit = "m/s"
    summary = "speed above the posted limit + tolerance for the minimum duration"
    rank = 7
    columns = ("t", "x", "y", "yaw", "speed", "in_junction", "speed_limit")
    guide = "speeding above the posted limit is stated"
    disposition = frozenset({Disposition.SPEEDING})
    Params = SpeedLimitParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: SpeedLimitParams = self.params
        a = ctx.arrays
        threshold = speed_limit(ctx, p) + p.tolerance
        excess = sustained_excess(ctx, a.floats["speed"] - threshold, p.min_duration, p.start_grace)
        return _speed_outcome(ctx, excess, threshold).finalize()


def _speed_outcome(ctx: EvalContext, excess: np.ndarray, threshold: np.ndarray) -> RuleOutcome:
    a = ctx.arrays
    worst_step = np.argmax(np.where(np.isfinite(excess), excess, -np.inf), axis=2)
    worst = np.take_along_axis(excess, worst_step[..., None], axis=2)[..., 0]
    thr = np.take_along_axis(threshold, worst_step[..., None], axis=2)[..., 0]
    out = RuleOutcome.empty(ctx.shape)
    out.applicable = (a.alive & np.isfinite(a.floats["speed"])).any(axis=2)
    bad = excess > 0
    out.violated = bad.any(axis=2)
    out.first_t = ctx.time_at(first_index(bad))
    out.threshold = thr
    finite = np.isfinite(worst)
    out.measured = np.where(finite, thr + worst, np.nan)
    out.robustness = np.where(finite, -worst, np.inf)
    return out


class UnsafeSpeedParams(LimitParams):
    min_duration: float = Field(default=1.0, gt=0, le=30, description="[s] the excess must last this long")
    factor_wet: float = Field(default=0.85, gt=0, le=1, description="limit factor on a wet surface or in rain")
    factor_fog: float = Field(default=0.70, gt=0, le=1, description="limit factor in fog")
    factor_snow_ice: float = Field(default=0.60, gt=0, le=1, description="limit factor on snow or ice")
    factor_night: float = Field(default=0.90, gt=0, le=1, description="limit factor at night")
    friction_dry: float = Field(default=0.8, gt=0, le=1.5, description="tyre-road friction coefficient, dry")
    friction_wet: float = Field(default=0.5, gt=0, le=1.5, description="friction coefficient, wet or rain")
    friction_snow: float = Field(default=0.3, gt=0, le=1.5, description="friction coefficient, snow")
    friction_ice: float = Field(default=0.15, gt=0, le=1.5, description="friction coefficient, ice")
    rear_end_stopped: bool = Field(default=True, description="rear-ending a stopped vehicle ahead is driving too fast "
                                   "for traffic (dsl.md convention 9)")
    stopped_speed: float = Field(default=0.5, ge=0, le=5, description="[m/s] a struck vehicle slower than this "
                                 "was stopped")


def condition_factor(ctx: EvalContext, p: UnsafeSpeedParams) -> tuple[float, list[str]]:
    """Product of the environment's factors and the conditions that set them."""
    return environment_factor(*ctx.environment(), p)


def environment_factor(weather: str, surface: str, time_of_day: str,
                       p: UnsafeSpeedParams | None = None) -> tuple[float, list[str]]:
    """Safe speed / posted limit [-] for these conditions, and the conditions that set it (the drivers use
    the same function, so a rulebook's factors reach them)."""
    p = p or UnsafeSpeedParams()
    factor, why = 1.0, []
    if surface == "wet" or weather == "rainy":
        factor *= p.factor_wet
        why.append("wet")
    if weather == "foggy":
        factor *= p.factor_fog
        why.append("fog")
    if weather == "snowy" or surface in ("snowy", "icy"):
        factor *= p.factor_snow_ice
        why.append("snow/ice")
    if time_of_day == "nighttime":
        factor *= p.factor_night
        why.append("night")
    return factor, why


def friction(ctx: EvalContext, p: UnsafeSpeedParams) -> float:
    weather, surface, _ = ctx.environment()
    return surface_friction(weather, surface, p)


def surface_friction(weather: str, surface: str, p: UnsafeSpeedParams | None = None) -> float:
    """Tyre-road friction coefficient [-] for the weather and surface."""
    p = p or UnsafeSpeedParams()
    if surface == "icy":
        return p.friction_ice
    if surface == "snowy" or weather == "snowy":
        return p.friction_snow
    if surface == "wet" or weather == "rainy":
        return p.friction_wet
    return p.friction_dry


@register_rule
class UnsafeSpeed(Rule):
    code = "CVC_22350"
    violation = "unsafe_speed"
    unit = "m/s"
    summary = ("speed above the limit times the condition factor for the minimum duration, loss of control, "
               "or rear-ending a stopped vehicle")
    rank = 6
    columns = ("t", "x", "y", "yaw", "speed", "lat_accel", "in_junction", "speed_limit", "lost_control")
    guide = "lost control, too fast for conditions, or struck a STOPPED vehicle ahead"
    disposition = frozenset({Disposition.SPEEDING, Disposition.CARELESS, Disposition.INATTENTIVE})
    Params = UnsafeSpeedParams

    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        p: UnsafeSpeedParams = self.params
        a = ctx.arrays
        factor, why = condition_factor(ctx, p)
        threshold = speed_limit(ctx, p) * factor
        excess = sustained_excess(ctx, a.floats["speed"] - threshold, p.min_duration, p.start_grace)
        out = _speed_outcome(ctx, excess, threshold)

        mu_g = friction(ctx, p) * G
        # a car shoved or spun by an impact is not a driver losing control: only steps before its first contact
        steps = np.arange(a.shape[2])
        contact = ctx.first_contact[..., None]
        driven = a.alive & ((contact < 0) | (steps < contact))
        lat = np.abs(np.where(driven, a.floats["lat_accel"], np.nan))
        skid = ((lat > mu_g) | a.flag("lost_control")) & driven
        # A backend that cannot tell loss of control: a non-ADS actor scripted to lose control counts.
        lost_unknown = ~a.known("lost_control").any(axis=2)
        scripted = (a.behavior == "lose_control") & ~a.is_ads & lost_unknown & a.present
        skid_first = ctx.time_at(first_index(skid))
        skid_first = np.where(scripted & np.isnan(skid_first), 0.0, skid_first)
        lost = skid.any(axis=2) | scripted
        out.first_t = np.fmin(out.first_t, skid_first)
        out.violated |= lost
        out.applicable |= lost
        struck = ctx.struck_stopped(p.stopped_speed) if p.rear_end_stopped else np.full(ctx.shape, np.nan)
        hit_stopped = np.isfinite(struck)
        out.first_t = np.fmin(out.first_t, struck)
        out.violated |= hit_stopped
        max_lat = np.nanmax(np.where(np.isfinite(lat), lat, -np.inf), axis=2)
        lat_margin = np.where(np.isfinite(max_lat), margin_in(out.threshold, mu_g - max_lat, mu_g), np.inf)
        out.robustness = np.fmin(out.robustness, lat_margin)
        notes = []
        if why:
            notes.append(f"condition factor {factor:.3f} ({', '.join(why)})")
        base = "; ".join(notes) or None
        out.note = np.full(ctx.shape, base, dtype=object)
        out.note[lost] = "; ".join(filter(None, [base, "loss of control"]))
        out.note[hit_stopped] = "; ".join(filter(None, [base, "struck a stopped vehicle ahead (too fast for traffic)"]))
        return out.finalize()
