"""The search space of a rendered Scenic program, and scenes drawn with its parameters pinned.

The space is the program's sampled parameters (`VerifaiRange(low, high)`, low < high), read
from the sampling plan `render` writes beside the program (`sampler.json`). A search
proposes points of the unit cube; `ParameterSpace.values` maps them to parameter values,
and `PinnedScenes` draws the scenes with those values held fixed, with the compiled
sampler (`crashscene.render.compiled_sampler`, Scenic's distribution without its
interpreter): every other random choice (placement candidate, blueprints without a
search parameter) is drawn as in `crashscene.render.sample`, index-deterministically from
(seed, variation), and a point no attempt can place is a rejected scene.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from crashscene.render.errors import SampleError
from crashscene.render.sample import MAX_ITERATIONS
from crashscene.scene import SampledScene
from crashscene.search.errors import SearchError


@dataclass(frozen=True)
class ParameterSpace:
    """The sampled parameters of a program: names and bounds, in program order, and its constants."""

    names: tuple[str, ...]
    low: np.ndarray    # (D,)
    high: np.ndarray   # (D,)
    constants: tuple[tuple[str, float], ...] = ()   # parameters declared with low == high (name, value)

    @property
    def dimension(self) -> int:
        return len(self.names)

    def values(self, unit: np.ndarray) -> np.ndarray:
        """(N, D) unit-cube points -> parameter values."""
        return self.low + np.clip(unit, 0.0, 1.0) * (self.high - self.low)

    def unit(self, values: np.ndarray) -> np.ndarray:
        """(N, D) parameter values -> unit-cube points."""
        span = np.where(self.high > self.low, self.high - self.low, 1.0)
        return (values - self.low) / span


def space_of(params: list[dict[str, Any]], source: str) -> ParameterSpace:
    """The space of a sampling plan's `params` ({name, low, high}, program order); `source` names the program."""
    searched = [p for p in params if float(p["high"]) > float(p["low"])]
    if not searched:
        raise SearchError(f"{source}: no sampled parameters to search (the program has no `param NAME = "
                          f"VerifaiRange(low, high)` with low < high); give the DSL ranges instead of fixed values")
    return ParameterSpace(names=tuple(p["name"] for p in searched),
                          low=np.array([float(p["low"]) for p in searched]),
                          high=np.array([float(p["high"]) for p in searched]),
                          constants=tuple((p["name"], float(p["low"])) for p in params
                                          if float(p["high"]) <= float(p["low"])))


def parameter_space(program: Path) -> ParameterSpace:
    """The sampled parameters of a rendered program (from its sampling plan)."""
    from crashscene.render.compiled_sampler import PlanError, load_plan

    try:
        plan = load_plan(program)
    except PlanError as exc:
        raise SearchError(str(exc)) from exc
    return space_of(plan["params"], str(program))


class PinnedScenes:
    """Scenes of one rendered program with its searched parameters pinned (module docstring)."""

    def __init__(self, program: Path, space: ParameterSpace):
        from crashscene.render.compiled_sampler import CompiledSampler, PlanError
        from crashscene.render.sample import program_identity

        program = Path(program)
        try:
            self.sampler = CompiledSampler(program)
        except PlanError as exc:
            raise SearchError(str(exc)) from exc
        self.digest, self.map_file = program_identity(program)
        order = {name: k for k, name in enumerate(self.sampler.param_names)}
        self.columns = np.array([order[name] for name in space.names], dtype=np.int64)
        self.fixed = {order[name]: value for name, value in space.constants}

    def __call__(self, values: np.ndarray, seed: int, first: int) -> list[SampledScene | str]:
        """One scene per row of `values` (variation first + row), or the reason it could not be drawn."""
        full = np.empty((len(values), len(self.sampler.param_names)))
        for column, value in self.fixed.items():
            full[:, column] = value
        full[:, self.columns] = values
        try:
            scenes = self.sampler.scenes(first, len(values), seed, self.digest, self.map_file,
                                         max_attempts=MAX_ITERATIONS, pinned=full)
        except SampleError as exc:
            raise SearchError(f"scenes could not be drawn: {exc}") from exc
        return [scene if scene is not None else
                f"scene rejected: no attempt out of {MAX_ITERATIONS} placed the cars with these values (on the "
                f"road, none overlapping)" for scene in scenes]
