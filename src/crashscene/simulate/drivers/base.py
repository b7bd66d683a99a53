"""The driver step interface: how every actor, the ADS under test included, is driven.

Every actor of a batch has one driver object, which drives that actor in *all*
variations of the batch at once: each field of an `Observation` is a numpy
array of shape (V,), one entry per variation, and `step` returns an `Action`
of arrays of the same shape. Write drivers with numpy operations (`np.where`,
masks), never a Python loop over variations.

A user ADS (`crashscene simulate ... --ads mypkg.mymodule:MyDriver`) is any
class with this shape:

    class MyDriver:
        def __init__(self, params: dict):          # --ads-param overrides, may be empty
            ...
        def reset(self, ctx: DriverContext) -> None:   # once per batch, before step 0
            ...
        def step(self, obs: Observation) -> Action:    # every step (dt = ctx.dt)
            return Action(accel=..., lateral_offset=...)

The simulator turns the action into motion with a kinematic bicycle model: the
commanded acceleration is clipped to the vehicle's limits and the steering
follows the route, shifted by `lateral_offset` (d, [m], left positive) at a
bounded lateral rate. Units are SI: m, s, m/s, m/s2, rad.

A driver gets read-only copies of the state (writing into an observation
raises), and the ADS's every action is checked (`ads_step`): numbers, finite,
shape (V,), a lateral offset within `MAX_LATERAL_OFFSET`; a failure names the
ADS class, the field, the actor, the step and the variation.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields

import numpy as np

from crashscene.simulate.backend import AdsError
from crashscene.simulate.embedded.vehicles import VehicleLimits

MAX_LATERAL_OFFSET = 20.0  # [m] from the route's lane centre: a lane change is ~3.5 m; beyond this is off any road

# integer codes used in observations (index into crashscene.traces vocabularies)
CONTROL_NONE, CONTROL_SIGNAL, CONTROL_STOP, CONTROL_YIELD = 0, 1, 2, 3  # traces.CONTROLS
SIGNAL_NONE, SIGNAL_GREEN, SIGNAL_YELLOW, SIGNAL_RED = 0, 1, 2, 3  # traces.SIGNAL_STATES
MANEUVER_NONE, MANEUVER_STRAIGHT, MANEUVER_LEFT, MANEUVER_RIGHT, MANEUVER_U_TURN = 0, 1, 2, 3, 4  # traces.MANEUVERS


@dataclass
class DriverContext:
    """What a driver knows about its actor before the batch starts (arrays are shape (V,))."""

    role: str  # DSL role: ego, npc1, ...
    behavior: str  # DSL behavior token
    actor_type: str  # car | truck | motorcycle
    dispositions: frozenset[str]  # oracle codes injected into this driver (empty for the ADS under test)
    n_variations: int
    dt: float  # [s]
    limits: VehicleLimits
    length: np.ndarray  # [m]
    width: np.ndarray  # [m]
    cruise_speed: np.ndarray  # [m/s] sampled desired speed
    trigger_time: np.ndarray  # [s] when the behaviour's manoeuvre starts (timing plan), inf = never
    hold_until: np.ndarray  # [s] stay stopped until this time (timing plan), 0 = go at once
    lateral_target: np.ndarray  # [m] d to reach by the manoeuvre (lane change, cross centre line, leave road)
    initial_offset: np.ndarray  # [m] d at spawn (a lane change starts off its target lane's centre)
    lane_width: np.ndarray  # [m] at spawn
    condition_factor: float = 1.0  # [-] safe speed = posted limit x this (wet 0.85, fog 0.70, snow/ice 0.60, night 0.90)
    friction: float = 0.8  # [-] tyre-road friction coefficient of the surface
    params: dict[str, np.ndarray] = field(default_factory=dict)  # the scenes' parameters of this role, e.g.
    #                      "SPEED" from npc1_SPEED: one value per variation, NaN where a scene lacks it
    rng: np.random.Generator | None = None  # seeded per (seed, first variation, role): draw per-variation values only


@dataclass
class Observation:
    """What the driver sees this step; arrays of shape (V,) unless noted."""

    t: float  # [s]
    dt: float  # [s]
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    speed: np.ndarray  # [m/s]
    accel: np.ndarray  # [m/s2] last step
    s: np.ndarray  # [m] station along the actor's route
    d: np.ndarray  # [m] lateral offset from the route, left positive
    route_remaining: np.ndarray  # [m] until the route (map) ends
    lane_width: np.ndarray  # [m]
    speed_limit: np.ndarray  # [m/s], NaN if unknown
    curvature_ahead: np.ndarray  # [1/m] largest |curvature| on the next max(20 m, 3 s) of route
    curve_speed: np.ndarray  # [m/s] highest speed from which the curves ahead can be taken at 2.5 m/s2 lateral,
    #                          braking at 2 m/s2 before them (a driver scales it to its own lateral limit)
    lead_gap: np.ndarray  # [m] bumper to bumper to the nearest vehicle ahead in the actor's path, inf if none
    lead_speed: np.ndarray  # [m/s] its speed along the route, NaN if none
    lead_rel_yaw: np.ndarray  # [rad] its heading minus the route's there, in [-pi, pi], NaN if none
    control: np.ndarray  # int: CONTROL_* of the approach to the next junction
    signal: np.ndarray  # int: SIGNAL_* governing the next stop line
    stop_line_dist: np.ndarray  # [m] front bumper to the next stop line (>0 before it), NaN if none
    junction_dist: np.ndarray  # [m] front bumper to the next junction entry, NaN if none
    in_junction: np.ndarray  # bool
    maneuver: np.ndarray  # int: MANEUVER_* at the next (or current) junction
    yield_tta: np.ndarray  # [s] smallest time-to-arrival at the shared conflict point of a vehicle with priority
    yield_occupied: np.ndarray  # bool: a vehicle with priority is inside the conflict area now
    conflict_dist: np.ndarray  # [m] front bumper to that conflict point, NaN if none
    cross_tta: np.ndarray  # [s] smallest time-to-arrival of ANY vehicle at a conflict point still ahead of us
    #                        (priority or not: what a defensive driver watches), inf if none
    cross_accel: np.ndarray  # [m/s2] that vehicle's acceleration (a vehicle about to yield is braking), NaN if none
    cross_dist: np.ndarray  # [m] our front bumper to that conflict point, NaN if none
    target_gap_front: np.ndarray  # [m] gap to the nearest vehicle ahead in the lane at d = lateral target, inf if none
    target_gap_rear: np.ndarray  # [m] gap to the nearest vehicle behind in that lane, inf if none
    target_rear_speed: np.ndarray  # [m/s] that vehicle's speed, NaN if none
    others_x: np.ndarray  # (V, A) [m] every actor's position (own column included), NaN when not perceivable
    others_y: np.ndarray  # (V, A)
    others_yaw: np.ndarray  # (V, A) [rad]
    others_speed: np.ndarray  # (V, A) [m/s]
    collided: np.ndarray  # bool: this actor has already collided (it slides out of control unless the impact barely
    # upset it, crashscene.upset)

    def read_only(self) -> Observation:
        """A copy whose arrays are copies marked read-only: a driver cannot change the simulator's state."""
        values = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                value = value.copy()
                value.flags.writeable = False
            values[f.name] = value
        return Observation(**values)


@dataclass
class Action:
    """The driver's command for this step; arrays of shape (V,)."""

    accel: np.ndarray  # [m/s2] longitudinal; clipped to [-brake_max, accel_max]
    lateral_offset: np.ndarray | None = None  # [m] target d (left positive); None keeps the lane centre (0)
    lose_control: np.ndarray | None = None  # bool: from now on the vehicle skids (yaw spin, friction braking)
    spin_rate: np.ndarray | None = None  # [rad/s] yaw rate while skidding (sign = direction)


def ads_step(driver: object, obs: Observation, role: str, step: int, variations: Sequence[int]) -> Action:
    """`driver.step(obs)` of the ADS under test, checked: AdsError naming the ADS class, the field, the actor
    (`role`), the step and the variation (`variations[i]` is the index of batch entry i)."""
    name = type(driver).__name__
    where = f"ADS {name} driving {role!r} at step {step} (t = {obs.t:.2f} s)"
    try:
        action = driver.step(obs)
    except Exception as exc:  # the user's code: re-raised as its fault, with the traceback chained
        raise AdsError(f"{where}: step() raised {type(exc).__name__}: {exc}") from exc
    if not isinstance(action, Action):
        raise AdsError(f"{where}: step() returned {type(action).__name__}; expected "
                       f"crashscene.simulate.drivers.base.Action")
    n_v = obs.speed.shape[0]
    out = {}
    for name_, required in (("accel", True), ("lateral_offset", False), ("spin_rate", False)):
        value = getattr(action, name_)
        if value is None and not required:
            out[name_] = None
            continue
        out[name_] = _numbers(value, name_, n_v, where, variations)
    offset = out["lateral_offset"]
    if offset is not None and np.any(far := np.abs(offset) > MAX_LATERAL_OFFSET):
        i = int(np.argmax(far))
        raise AdsError(f"{where}: Action.lateral_offset = {offset[i]:g} m in variation {variations[i]}; allowed: "
                       f"within +-{MAX_LATERAL_OFFSET:g} m of the route's lane centre (a lane is ~3.5 m)")
    lose = action.lose_control
    if lose is not None:
        lose = np.asarray(lose)
        if lose.dtype != bool or lose.shape not in ((), (n_v,)):
            raise AdsError(f"{where}: Action.lose_control must be a bool array of shape ({n_v},) or a bool "
                           f"(got dtype {lose.dtype}, shape {lose.shape})")
    return Action(accel=out["accel"], lateral_offset=offset, lose_control=lose, spin_rate=out["spin_rate"])


def _numbers(value: object, field_name: str, n_v: int, where: str, variations: Sequence[int]) -> np.ndarray:
    """`value` as a float array of shape (n_v,) (a scalar broadcasts); AdsError if not numbers or not finite."""
    allowed = f"a finite number or a float array of shape ({n_v},), one entry per variation"
    try:
        array = np.asarray(value)
    except Exception:  # noqa: BLE001 - any object numpy cannot take is the same user error
        array = np.asarray(None)
    if array.dtype == bool or not (np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)):
        raise AdsError(f"{where}: Action.{field_name} is {_describe(value)}; allowed: {allowed}")
    if array.shape not in ((), (n_v,)):
        raise AdsError(f"{where}: Action.{field_name} has shape {array.shape}; allowed: {allowed}")
    array = np.broadcast_to(array.astype(float), (n_v,))
    bad = ~np.isfinite(array)
    if bad.any():
        i = int(np.argmax(bad))
        raise AdsError(f"{where}: Action.{field_name} = {array[i]} in variation {variations[i]}; allowed: {allowed}")
    return array


def _describe(value: object) -> str:
    text = repr(value)
    return f"a {type(value).__name__} ({text if len(text) <= 60 else text[:57] + '...'})"


class Driver:
    """Base class of built-in drivers; user drivers need not inherit from it (duck typing is enough)."""

    def __init__(self, params: dict | None = None):
        self.params = dict(params or {})
        self.ctx: DriverContext | None = None

    def reset(self, ctx: DriverContext) -> None:
        self.ctx = ctx

    def step(self, obs: Observation) -> Action:  # pragma: no cover - abstract
        raise NotImplementedError


def idm_accel(speed: np.ndarray, desired: np.ndarray, gap: np.ndarray, lead_speed: np.ndarray,
              accel_max: float, brake_comfort: float, headway: float | np.ndarray, min_gap: float = 2.0,
              delta: float = 4.0) -> np.ndarray:
    """Intelligent Driver Model acceleration [m/s2] (Treiber et al.); gap = inf means a free road."""
    desired = np.maximum(desired, 0.1)
    # above the desired speed, slow down at most at the comfortable rate (the plain IDM term explodes)
    free = np.maximum(1.0 - (speed / desired) ** delta, -brake_comfort / accel_max)
    lead = np.where(np.isnan(lead_speed), speed, lead_speed)
    dv = speed - lead
    s_star = min_gap + np.maximum(0.0, speed * headway + speed * dv / (2.0 * np.sqrt(accel_max * brake_comfort)))
    inter = np.where(np.isfinite(gap), (s_star / np.maximum(gap, 0.1)) ** 2, 0.0)
    return accel_max * (free - inter)


def stop_accel(speed: np.ndarray, dist: np.ndarray, brake_max: float) -> np.ndarray:
    """Deceleration [m/s2] (<= 0) that stops within `dist` [m]; NaN/negative dist brakes at brake_max."""
    dist = np.where(np.isnan(dist), np.inf, dist)
    need = speed ** 2 / (2.0 * np.maximum(dist, 0.05))
    return -np.minimum(need, brake_max)
