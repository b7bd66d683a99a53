"""A user ADS for the plug-in test: holds its speed and its lane, ignores everything (documents the interface)."""
from __future__ import annotations

import numpy as np

from crashscene.simulate.drivers.base import Action, DriverContext, Observation


class ConstantSpeed:
    def __init__(self, params: dict):
        self.gain = float(params.get("gain", 1.0))

    def reset(self, ctx: DriverContext) -> None:
        self.target = ctx.cruise_speed * self.gain

    def step(self, obs: Observation) -> Action:
        return Action(accel=np.clip(self.target - obs.speed, -3.0, 3.0), lateral_offset=np.zeros_like(obs.speed))


class Parked:
    """Never drives off: the variation must be flagged invalid ("ego never moved")."""

    def __init__(self, params: dict):
        pass

    def reset(self, ctx: DriverContext) -> None:
        pass

    def step(self, obs: Observation) -> Action:
        return Action(accel=np.full_like(obs.speed, -8.0))


class Vandal(ConstantSpeed):
    """Writes into its observation (it would freeze the other vehicles if that reached the state)."""

    def step(self, obs: Observation) -> Action:
        obs.others_speed[:] = 0.0
        return super().step(obs)


class Sneaky(ConstantSpeed):
    """Clears the read-only flag first, then writes: only its own copy may change."""

    def step(self, obs: Observation) -> Action:
        for array in (obs.others_speed, obs.others_x, obs.others_yaw, obs.x, obs.y):
            array.flags.writeable = True
            array[:] = 0.0
        return super().step(obs)


class BadAction:
    """Returns the action `params["kind"]` names, from step `params["at"]` on (hostile-input tests)."""

    def __init__(self, params: dict):
        self.kind, self.at = params["kind"], int(params.get("at", 0))
        self.steps = 0

    def reset(self, ctx: DriverContext) -> None:
        self.n = ctx.n_variations

    def step(self, obs: Observation):
        self.steps += 1
        if self.steps <= self.at:
            return Action(accel=np.zeros(self.n))
        nan_in_last = np.zeros(self.n)
        nan_in_last[-1] = np.nan
        return {
            "nan": lambda: Action(accel=nan_in_last),
            "shape": lambda: Action(accel=np.zeros(self.n + 1)),
            "string": lambda: Action(accel="fast"),
            "none": lambda: Action(accel=None),
            "dict": lambda: {"accel": 1.0},
            "raise": lambda: 1 / 0,
            "offset": lambda: Action(accel=np.zeros(self.n), lateral_offset=np.full(self.n, 1e6)),
        }[self.kind]()
