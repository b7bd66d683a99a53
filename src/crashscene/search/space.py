"""The search space of a rendered Scenic program, and scenes drawn with its parameters pinned.

The space is the program's `VerifaiRange` parameters (name, low, high). A
search proposes points of the unit cube; `ParameterSpace.values` maps them to
parameter values, and `pinned_scenes` draws the scenes with those values held
fixed: Scenic's external sampler is replaced by `PinnedSampler`, so every
other random choice (placement candidates, blueprints) is drawn as in
`crashscene.render.sample`, index-deterministically from (seed, variation).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scenic.core.external_params import ExternalSampler

from crashscene.render.sample import SampleError, sample_scenes
from crashscene.scene import SampledScene
from crashscene.search.errors import SearchError


@dataclass(frozen=True)
class ParameterSpace:
    """The sampled parameters of a program: names and bounds, in program order."""

    names: tuple[str, ...]
    low: np.ndarray    # (D,)
    high: np.ndarray   # (D,)

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


class PinnedSampler(ExternalSampler):
    """An external sampler that returns values set from outside (`pin`), for every attempt of a scene."""

    def __init__(self, params: tuple[Any, ...]):
        self.params = params
        self.rejectionFeedback = None
        self.cachedSample: dict[int, float] = {}
        self._values: dict[int, float] = {}
        for index, param in enumerate(params):
            param.sampler = self
            param.pinned_index = index

    def pin(self, values: np.ndarray) -> None:
        self._values = {i: float(v) for i, v in enumerate(values)}

    def nextSample(self, feedback):  # noqa: N802 (Scenic's hook name)
        return self._values

    def valueFor(self, param):  # noqa: N802  (a 1-tuple, as VerifAI features give)
        return (self.cachedSample[param.pinned_index],)  # VerifaiRange unpacks a 1-tuple


def parameter_space(scenario: Any, program: Path) -> ParameterSpace:
    """The VerifaiRange parameters of a compiled program; pins them (the scenario's sampler is replaced)."""
    from scenic.core.external_params import VerifaiRange

    params = tuple(scenario.externalParams)
    named = {id(value): name for name, value in scenario.params.items() if isinstance(value, VerifaiRange)}
    if not params or any(not isinstance(p, VerifaiRange) or id(p) not in named for p in params):
        raise SearchError(f"{program}: no sampled parameters to search (the program has no `param NAME = "
                          f"VerifaiRange(low, high)` with low < high); give the DSL ranges instead of fixed values")
    bounds = np.array([p.domain.intervals[0] for p in params], dtype=float)
    if not (bounds[:, 1] > bounds[:, 0]).any():
        raise SearchError(f"{program}: every sampled parameter has an empty range; nothing to search")
    scenario.externalSampler = PinnedSampler(params)
    return ParameterSpace(names=tuple(named[id(p)] for p in params), low=bounds[:, 0], high=bounds[:, 1])


def pinned_scenes(scenario: Any, program: Path, values: np.ndarray, seed: int,
                  first: int) -> list[SampledScene | str]:
    """One scene per row of `values` (variation first + row), or the reason it could not be drawn."""
    sampler: PinnedSampler = scenario.externalSampler
    out: list[SampledScene | str] = []
    for row, vector in enumerate(values):
        sampler.pin(vector)
        try:
            out.append(sample_scenes(program, 1, seed, first=first + row, scenario=scenario)[0])
        except SampleError as exc:
            out.append(f"scene rejected: {exc}")
    return out
