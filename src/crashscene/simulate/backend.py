"""The backend interface of the simulate stage, and the registry of backends by name.

As in Scenic's `Simulator`/`Simulation`: a `Simulator` is long-lived (a
connection, a compiled road network, a worker pool) and is created once per
backend and options; `Simulator.simulate(request)` runs one batch of sampled
scenes and returns an explicit `BatchResult` holding the four tables of
`crashscene.traces` (traces, actors, collisions, variations).

A backend that runs scenes one by one implements `Simulator.run_scene`: it
returns each actor's states (the state protocol of
`crashscene.simulate.recorder`: x, y, yaw, speed per step) and the shared
recorder fills every trace column from them, map columns included; a new
backend is then one module (`crashscene.simulate.dummy` is the smallest).
Batched engines override `Simulator.simulate`; `Simulator.simulate_scene`
(raw trace columns) is still accepted, and its pose goes through the same
recorder. Everything else (which actor is the ADS, which dispositions an
actor gets, table layout) is shared here, in `crashscene.simulate.tables` and
in the recorder, so every backend yields rows the monitor reads the same way.

Backends are found by name (`get_simulator_class("embedded")`), by an entry
point of group `crashscene.backends` in an installed package, or by an import
string 'package.module:Class': a plugin is named by text, so a spawned worker
process finds it too. Optional ones (`carla`) are imported lazily so a missing
extra only fails its own backend, with a `BackendUnavailable` error that says
what to install.
"""
from __future__ import annotations

import importlib
import time
from abc import ABC
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar, Literal

import pyarrow as pa
from pydantic import BaseModel, ConfigDict, Field

from crashscene.dsl import Scenario
from crashscene.scene import SampledScene

Mode = Literal["test", "reproduce"]
MODES: tuple[str, ...] = ("test", "reproduce")

DEFAULT_DT = 0.1  # [s] 10 Hz
DEFAULT_HORIZON = 20.0  # [s]


class SimulationError(Exception):
    """Any failure of the simulate stage; the message says what, where and what is allowed."""


class AdsError(SimulationError):
    """The ADS under test failed (raised in `step`, or returned a bad action): its fault, not the scenario's."""


class BackendUnavailable(SimulationError):
    """A backend whose optional dependency or server is missing (e.g. `carla`)."""


def import_ads(spec: str, what: str = "attribute") -> object:
    """The attribute named by an `--ads 'package.module:Class'` spec; SimulationError naming what is wrong
    (`what` is the noun the message uses for a missing name: a driver may be any factory, an agent a class)."""
    module_name, sep, class_name = spec.partition(":")
    if not sep or not module_name or not class_name:
        raise SimulationError(f"--ads {spec!r}: expected 'package.module:Class'")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise SimulationError(f"--ads {spec!r}: cannot import module {module_name!r} ({exc})") from exc
    found = getattr(module, class_name, None)
    if found is None:
        raise SimulationError(f"--ads {spec!r}: module {module_name!r} has no {what} {class_name!r}")
    return found


class SimulationSettings(BaseModel):
    """Options shared by every backend (a backend may ignore those it cannot honour, and says so)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    dt: float = Field(default=DEFAULT_DT, gt=0, le=1.0, description="[s] simulation step")
    horizon: float = Field(default=DEFAULT_HORIZON, gt=0, le=600.0, description="[s] simulated time per variation")
    mode: Mode = Field(default="test", description="test: the ego role is the ADS under test; "
                                                   "reproduce: every actor replays its DSL behaviour")
    ego_role: str = Field(default="ego", description="DSL role handed to the ADS under test (test mode)")
    ads: str | None = Field(default=None, description="'package.module:Class' of a user driver for the ADS, "
                                                      "None = the reference ADS")
    ads_params: dict[str, float | int | str | bool] = Field(default_factory=dict,
                                                           description="overrides of the ADS driver's parameters")
    carla_host: str = Field(default="127.0.0.1", description="CARLA server host (carla backend only)")
    carla_port: int = Field(default=2000, ge=1, le=65535, description="CARLA server port (carla backend only)")
    refine: bool = Field(default=True, description="reproduce mode: each variation's plan is checked against the "
                         "simulator and one that misses the written crash sequence is replanned (embedded backend; "
                         "False: the analytic plans alone)")
    conditions: dict[str, float] = Field(default_factory=dict, description="the rulebook's CVC_22350 condition "
                                         "factors and friction coefficients (factor_wet, friction_ice, ...) the "
                                         "drivers use; missing keys keep the rules.md defaults")

    @property
    def steps(self) -> int:
        """Number of simulated steps after the initial state (the trace has steps + 1 rows per actor)."""
        return int(round(self.horizon / self.dt))


@dataclass(frozen=True)
class SimulationRequest:
    """One batch to simulate: the scenario, its rendered program and map, and the sampled scenes.

    `scenes` may be any contiguous chunk [first, first + n) of a campaign; a
    backend must make variation i depend only on (scenario, seed, i), never on
    the other scenes of the batch.
    """

    scenario: Scenario
    scenes: Sequence[SampledScene]
    map_file: Path
    settings: SimulationSettings = field(default_factory=SimulationSettings)
    program: str | None = None  # Scenic source of the rendered program (newtonian/carla backends)
    progress: Callable[[int], None] | None = None  # called with the number of variations just finished


@dataclass
class BatchResult:
    """What one batch produced: the tables of `crashscene.traces`, keyed by table name."""

    backend: str
    tables: dict[str, pa.Table]
    seconds: float = 0.0  # [s] wall-clock time of the simulation proper
    notes: list[str] = field(default_factory=list)  # e.g. "newtonian: no traffic-light states"


@dataclass
class SceneResult:
    """What a one-scene-at-a-time backend returns for one variation.

    `traces` maps TRACE_SCHEMA column names to equal-length lists or arrays
    (one entry per actor and step). When it holds every actor's x and y at
    every step, the recorder derives the other columns (yaw and speed from the
    motion when absent, map columns from the map); the columns given win.
    Otherwise missing columns are NaN/null. `variation` is taken from the scene.
    """

    traces: dict[str, Sequence]
    collisions: list[dict] = field(default_factory=list)  # COLLISION_SCHEMA rows
    valid: bool = True
    invalid_reason: str | None = None


class Simulator(ABC):
    """A long-lived simulator: create once, call `simulate` per batch, `close` at the end.

    Subclasses set `name` and implement `run_scene` (one scene at a time: the
    recorder fills every column), or override `simulate` (batched engines). Use
    `tables.is_ads(role, settings)` and `tables.driver_dispositions(actor, settings)`
    to decide who is the ADS and which oracle codes an actor's driver carries.
    """

    name: ClassVar[str] = "abstract"
    # whose scenes the backend can run: "compiled" (any scene), or "scenic" for backends that re-generate each
    # scene in Scenic from (seed, index) and pin it to the sampled one (they need Scenic's own draws)
    scene_sampler: ClassVar[str] = "compiled"

    def __init__(self, settings: SimulationSettings | None = None):
        self.settings = settings or SimulationSettings()

    def simulate(self, request: SimulationRequest) -> BatchResult:
        """Simulate every scene of `request` and return the four tables.

        The default runs `run_scene` (or `simulate_scene`) on each scene in turn and records the
        tables with the shared recorder; batched backends override it.
        """
        from crashscene.simulate import recorder

        check_ego_role(request.scenario, self.settings)
        if type(self).run_scene is not Simulator.run_scene:
            return recorder.run_scenes(self.name, request, self.settings, self.run_scene)
        start = time.perf_counter()
        results = []
        for scene in request.scenes:
            results.append(self.simulate_scene(request, scene))
            if request.progress is not None:
                request.progress(1)
        tables = recorder.record_scene_results(request, results, self.settings)
        return BatchResult(backend=self.name, tables=tables, seconds=time.perf_counter() - start)

    def run_scene(self, request: SimulationRequest, scene: SampledScene):
        """Simulate one scene: a `recorder.SceneRun` with each actor's states (x, y, yaw, speed per step)."""
        raise NotImplementedError(f"backend {self.name!r} implements none of run_scene, simulate_scene, simulate")

    def simulate_scene(self, request: SimulationRequest, scene: SampledScene) -> SceneResult:
        """Simulate one scene as raw trace columns (older interface; prefer `run_scene`)."""
        raise NotImplementedError(f"backend {self.name!r} implements none of run_scene, simulate_scene, simulate")

    def close(self) -> None:
        """Release connections, pools, caches."""

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# name -> "module:Class"; imported on first use so optional backends cost nothing until chosen.
_REGISTRY: dict[str, str] = {
    "embedded": "crashscene.simulate.embedded.simulator:EmbeddedSimulator",
    "newtonian": "crashscene.simulate.newtonian:NewtonianSimulator",
    "carla": "crashscene.simulate.carla:CarlaSimulator",
    "dummy": "crashscene.simulate.dummy:DummySimulator",
}
ENTRY_POINT_GROUP = "crashscene.backends"  # installed packages declare backends here: name = "module:Class"


def _entry_points() -> dict[str, str]:
    from importlib.metadata import entry_points

    return {ep.name: ep.value for ep in entry_points(group=ENTRY_POINT_GROUP)}


def backend_names() -> list[str]:
    """Names accepted by `--backend` (besides any 'package.module:Class' import string)."""
    return list(dict.fromkeys([*_REGISTRY, *_entry_points()]))


def register_backend(name: str, target: str | type[Simulator]) -> None:
    """Register a backend under `name`: a Simulator subclass or a 'module:Class' string. The registration
    lives in this process; campaigns carry `backend_target(name)` to their workers, which import it."""
    if isinstance(target, type):
        target = f"{target.__module__}:{target.__qualname__}"
    _REGISTRY[name] = target


def backend_target(name: str) -> str:
    """The 'module:Class' import string of backend `name`: a registered name, an entry point of group
    `crashscene.backends`, or an import string itself. A worker process resolves it without any registration."""
    if name in _REGISTRY:
        return _REGISTRY[name]
    found = _entry_points().get(name)
    if found is not None:
        return found
    module_name, sep, class_name = name.partition(":")
    if sep and module_name and class_name:
        return name
    raise SimulationError(f"unknown backend {name!r}; allowed: {', '.join(backend_names())}, or "
                          f"'package.module:Class' of a Simulator subclass")


def get_simulator_class(name: str) -> type[Simulator]:
    """The Simulator class of backend `name` (see `backend_target`); SimulationError if unknown,
    BackendUnavailable if not importable."""
    target = backend_target(name)
    module_name, _, class_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise BackendUnavailable(f"backend {name!r} cannot be loaded ({exc}); "
                                 f"install its extra or choose one of: {', '.join(backend_names())}") from exc
    cls = getattr(module, class_name, None)
    if not (isinstance(cls, type) and issubclass(cls, Simulator)):
        raise BackendUnavailable(f"backend {name!r}: {target} is not a Simulator class")
    return cls


def create_simulator(name: str, settings: SimulationSettings | None = None) -> Simulator:
    """Instantiate the backend `name` with `settings`."""
    return get_simulator_class(name)(settings)


def check_ego_role(scenario: Scenario, settings: SimulationSettings) -> None:
    """Fail clearly when `--ego ROLE` names no actor of the scenario."""
    if settings.ego_role not in scenario.actors:
        raise SimulationError(f"--ego {settings.ego_role!r}: no such actor in the scenario; "
                              f"allowed: {', '.join(scenario.actors)}")
