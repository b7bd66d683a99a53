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
