"""The `newtonian` backend: run the rendered Scenic program in Scenic's Newtonian simulator.

Faithful to the Scenic program (its own behaviours drive every actor) but slow
(one scene at a time, about 3 runs/s here) and physically thin: Scenic's
Newtonian simulator has no traffic-light states, no collision handling, and
`FollowLaneBehavior` cannot brake. It is the cross-check of the embedded
backend and the fallback for hand-written Scenic programs.

What this backend adds around Scenic:
- placement: each Scenic scene is the one Scenic samples for the variation
  (reseeded from (seed, variation) as `crashscene.render.sample` does), and every
  object is then pinned to the sampled scene's position, yaw and speed, so the
  run starts exactly where the embedded backend's does;
- contact: footprints (oriented rectangles) are checked every step; two
  vehicles that touch are moved back along their last step to the moment of
  first contact and come to rest there (no crash dynamics), as in the embedded
  backend, and the first contact of each pair is a collision row;
- traces: per step x, y, yaw, speed through `scenic_trace.StateRecorder`, laid
  out by the backend-neutral recorder (`recorder.record_tables`: every column filled);
- determinism: Scenic's behaviours draw from Python's `random` and numpy's
  global generator; both are seeded from (seed, variation) for the run and
  restored afterwards, so nothing leaks between runs or into the caller.

Hand-written (or hand-edited) Scenic programs run through `simulate_program`
(Python API), staged against a DSL scenario that names the roles.
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import math
import random
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from crashscene.geometry import footprints_overlap, wrap_angle
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate import recorder, scenic_trace
from crashscene.simulate.backend import (
    BatchResult,
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    Simulator,
    check_ego_role,
)

NEWTONIAN_MODEL = "scenic.simulators.newtonian.driving_model"
SCENIC_PARAMS = {"map", "render", "use2DMap", "carla_map", "address", "port", "timeout", "timestep", "record",
                 "snapToGroundDefault", "debugRender", "verifaiSamplerType"}  # simulator settings, not sampled values
PIN_TOLERANCE = 0.5  # [m] a Scenic scene farther than this from the sampled one means the program changed

NOTES = (
    "newtonian: no traffic-light states in Scenic's Newtonian simulator (actors do not react to signals)",
    "newtonian: vehicles come to rest at first contact (no crash dynamics)",
)


@contextlib.contextmanager
def seeded_globals(seed: int, index: int) -> Iterator[None]:
    """Seed Python's `random` and numpy's global generator from (seed, index); restore both afterwards."""
    py_state, np_state = random.getstate(), np.random.get_state()
    words = np.random.SeedSequence([seed & 0xFFFFFFFFFFFFFFFF, index, 0x4E4557]).generate_state(2)
    random.seed(int(words[0]))
    np.random.seed(int(words[1]))
    try:
        yield
    finally:
        random.setstate(py_state)
        np.random.set_state(np_state)


@contextlib.contextmanager
def quiet_scenic() -> Iterator[None]:
    """Silence Scenic's map-parsing warnings (OpenDRIVE shoulders etc.) that would flood a batch run."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def compile_program(program: str, map_file: Path, model: str = NEWTONIAN_MODEL, extra_params: dict | None = None):
    """Compile a Scenic program in 2D mode against `map_file` under `model` (no window, no server).

    `extra_params` are further global parameters (the CARLA model's address, port...).
    """
    import scenic

    map_file = Path(map_file)
    if not map_file.is_file():
        raise SimulationError(f"{map_file}: map not found (the OpenDRIVE file the program runs on)")
    try:
        with quiet_scenic():
            params = {"render": False, "map": str(map_file), **(extra_params or {})}
            return scenic.scenarioFromString(program, params=params, mode2D=True, model=model)
    except Exception as exc:  # Scenic raises many types (ScenicSyntaxError, InvalidScenarioError, ...)
        raise SimulationError(f"the Scenic program does not compile under {model} with map {map_file}: "
                              f"{type(exc).__name__}: {exc}") from exc


def generate_scenic_scene(scenario, seed: int, index: int, max_iterations: int = 2000):
    """The Scenic scene of variation `index`, drawn exactly as `crashscene.render.sample` draws it.

    Python's `random` and numpy's global generator are seeded with the sample
    module's `scene_seed(seed, index)` and restored afterwards.
    """
    try:
        from crashscene.render.sample import scene_seed
    except ImportError:  # the render stage is absent: any fixed derivation keeps runs reproducible
        def scene_seed(seed: int, index: int) -> tuple[int, int]:
            words = np.random.SeedSequence([seed & 0xFFFFFFFFFFFFFFFF, index]).generate_state(2, dtype=np.uint32)
            return int(words[0]), int(words[1])
    py_state, np_state = random.getstate(), np.random.get_state()
    py_seed, np_seed = scene_seed(seed, index)
    random.seed(py_seed)
    np.random.seed(np_seed)
    try:
        scene, _ = scenario.generate(maxIterations=max_iterations, verbosity=0)
    finally:
        random.setstate(py_state)
        np.random.set_state(np_state)
    return scene


def _rejections() -> tuple[type[Exception], ...]:
    """Scenic's ways of rejecting a run (a requirement, a guard, a lookup that found nothing)."""
    from scenic.core.distributions import RejectionException
    from scenic.core.dynamics import GuardViolation, RejectSimulationException

    return (RejectionException, RejectSimulationException, GuardViolation)


REJECTIONS = _rejections()


@functools.cache
def _tracing_classes():
    """Newtonian Simulator/Simulation subclasses that pin, record and stop at contact (built lazily: pygame import)."""
    from scenic.core.vectors import Vector
    from scenic.simulators.newtonian.simulator import NewtonianSimulation
    from scenic.simulators.newtonian.simulator import NewtonianSimulator as ScenicNewtonianSimulator

    class PinnedNewtonianSimulation(scenic_trace.StateRecorder, NewtonianSimulation):
        """A Newtonian run whose objects start at pinned states and halt at first contact."""

        def __init__(self, scene, network, render, export_gif, debug_render, *, pins, sizes, **kwargs):
            self._pins = pins  # per scene object: (x, y, scenic heading, speed) or None
            self._sizes = sizes  # per scene object: (length, width) [m]
            self._halted: set[int] = set()
            self._spawn_overlaps: set[tuple[int, int]] = set()
            self.contacts: list[tuple[int, int, int, float]] = []  # (object a, object b, step, t [s])
            super().__init__(scene, network, render, export_gif, debug_render, **kwargs)

        def createObjectInSimulator(self, obj):
            index = len(self.objects) - 1  # Scenic appends obj before calling this hook
            pin = self._pins[index]
            if pin is not None:
                x, y, heading, speed = pin
                obj.position = Vector(x, y, 0)
                obj.heading = heading
                obj.velocity = Vector(0, speed).rotatedBy(heading)
            super().createObjectInSimulator(obj)

        def executeActions(self, allActions):
            for index, obj in enumerate(self.objects):
                if index in self._halted and obj in allActions:
                    allActions[obj] = ()  # a vehicle at rest after a contact takes no further action
            super().executeActions(allActions)

        def step(self):
            # Halting happens at the start of the step after the contact, so the trace's
            # contact step still shows the impact speeds.
            for index in self._halted:
                self._halt(self.objects[index])
            before = self._poses()
            super().step()
            self._detect_contacts(before)

        def _poses(self) -> list[tuple[float, float, float]]:
            return [(float(o.position[0]), float(o.position[1]), float(scenic_trace.yaw_from_heading(o.heading)))
                    for o in self.objects]

        def _detect_contacts(self, before):
            after = self._poses()
            touched = {(a, b) for a, b, _, _ in self.contacts} | self._spawn_overlaps
            for i in range(len(after)):
                for j in range(i + 1, len(after)):
                    if (i, j) in touched or not footprints_overlap(*after[i], *self._sizes[i], *after[j],
                                                                   *self._sizes[j]):
                        continue
                    if self.currentTime == 0 and footprints_overlap(*before[i], *self._sizes[i], *before[j],
                                                                    *self._sizes[j]):
                        self._spawn_overlaps.add((i, j))  # an invalid variation, not a crash: nobody halts
                        continue
                    frac = 1.0
                    if i not in self._halted and j not in self._halted:
                        frac = self._back_to_contact(i, j, before, after)
                    self.contacts.append((i, j, self.currentTime + 1, (self.currentTime + frac) * self.timestep))
                    self._halted.update((i, j))

        def _back_to_contact(self, i, j, before, after) -> float:
            """Move both vehicles back along their last step to first contact (as the embedded backend
            does, so the contact geometry is not a 10 Hz overshoot); the fraction of the step it began."""
            def pose(k, f):
                (x0, y0, t0), (x1, y1, t1) = before[k], after[k]
                return (x0 + f * (x1 - x0), y0 + f * (y1 - y0),
                        t0 + f * float(wrap_angle(t1 - t0)))

            lo, hi = 0.0, 1.0
            if footprints_overlap(*pose(i, 0.0), *self._sizes[i], *pose(j, 0.0), *self._sizes[j]):
                return 1.0  # already touching before the step (a graze): leave them where they are
            for _ in range(10):
                mid = (lo + hi) / 2
                if footprints_overlap(*pose(i, mid), *self._sizes[i], *pose(j, mid), *self._sizes[j]):
                    hi = mid
                else:
                    lo = mid
            for k in (i, j):
                x, y, yaw = pose(k, hi)
                obj = self.objects[k]
                obj.position = Vector(x, y, 0)
                obj.heading = yaw - scenic_trace.SCENIC_TO_YAW
            return hi

        @staticmethod
        def _halt(obj):
            obj.velocity = Vector(0, 0)
            obj.speed = 0.0
            obj.angularSpeed = 0.0
            if getattr(obj, "isCar", False):
                obj.throttle, obj.steer, obj.brake = 0.0, 0.0, 1.0

    class PinnedNewtonianSimulator(ScenicNewtonianSimulator):
        """Scenic's Newtonian simulator, headless, creating `PinnedNewtonianSimulation`s."""

        def __init__(self, pins, sizes):
            super().__init__(network=None, render=False)
            self.pins, self.sizes = pins, sizes

        def createSimulation(self, scene, **kwargs):
            return PinnedNewtonianSimulation(scene, self.network, False, False, False,
                                             pins=self.pins, sizes=self.sizes, **kwargs)

    return PinnedNewtonianSimulator


class NewtonianSimulator(Simulator):
    """Runs rendered Scenic programs in Scenic's Newtonian simulator, one scene at a time.

    Compiles each (program, map) once per simulator and reuses it for every
    scene; the traces of a batch are then recorded together (`recorder.record_tables`).
    In `test` mode the ADS role still runs the program's Scenic behaviour: a user
    ADS (`--ads`) cannot be plugged into Scenic behaviours, so asking for one is an error.
    """

    name = "newtonian"
    scene_sampler = "scenic"  # each scene is re-generated by Scenic from (seed, index), then pinned

    def __init__(self, settings: SimulationSettings | None = None):
        super().__init__(settings)
        self._compiled: dict[str, object] = {}

    def simulate(self, request: SimulationRequest) -> BatchResult:
        check_ego_role(request.scenario, self.settings)
        if self.settings.ads is not None:
            raise SimulationError(f"--ads {self.settings.ads!r}: the newtonian backend runs the program's Scenic "
                                  f"behaviours and cannot host a user driver; use --backend embedded "
                                  f"(or carla for an external stack)")
        if not request.program:
            raise SimulationError("the newtonian backend needs the rendered Scenic program "
                                  "(SimulationRequest.program is empty)")
        result = recorder.run_scenes(self.name, request, self.settings, self.run_scene)
        result.notes.extend(NOTES)
        if self.settings.mode == "test":
            result.notes.append(f"newtonian: the ADS role {self.settings.ego_role!r} runs the program's "
                                f"Scenic behaviour, not the reference ADS")
        return result

    def compiled(self, program: str, map_file: Path):
        """The compiled Scenic scenario of (program, map), compiled on first use."""
        key = hashlib.sha256(program.encode() + b"\0" + str(Path(map_file).resolve()).encode()).hexdigest()
        if key not in self._compiled:
            self._compiled[key] = compile_program(program, map_file)
        return self._compiled[key]

    def run_scene(self, request: SimulationRequest, scene: SampledScene) -> recorder.SceneRun:
        """Run one scene in the Newtonian simulator: its tracks and contacts, or why it is invalid."""
        scenario = self.compiled(request.program or "", request.map_file)
        steps, dt = self.settings.steps, self.settings.dt
        with quiet_scenic():
            try:
                scenic_scene = generate_scenic_scene(scenario, scene.seed, scene.index)
            except Exception as exc:  # noqa: BLE001 - RejectionException when no scene satisfies the requirements
                return recorder.failed_run(scene, steps, f"scenic could not place the scene: "
                                                             f"{type(exc).__name__}: {exc}")
            roles = scenic_trace.object_roles(scenic_scene.objects, scene)
            by_role = {actor.role: actor for actor in scene.actors}
            pins, sizes, drift = [], [], 0.0
            for obj, role in zip(scenic_scene.objects, roles):
                actor = by_role[role]
                pins.append((actor.x, actor.y, actor.yaw - scenic_trace.SCENIC_TO_YAW, actor.speed))
                sizes.append((actor.length, actor.width))
                drift = max(drift, math.hypot(float(obj.position[0]) - actor.x, float(obj.position[1]) - actor.y))
            mismatch = placement_mismatch(scenic_scene, scene, drift)
            if mismatch:
                return recorder.failed_run(scene, steps, mismatch)
            simulator = _tracing_classes()(pins, sizes)
            try:
                with seeded_globals(scene.seed, scene.index):
                    simulation = simulator.createSimulation(scenic_scene, maxSteps=steps, timestep=dt,
                                                            name=str(scene.index), verbosity=0)
            except REJECTIONS as exc:
                # e.g. a behaviour asking for `self.lane` once its car has left the road: keep what ran
                partial = getattr(exc, "simulation", None)
                trajectory = partial.trajectory if partial is not None else []
                reason = f"scenic rejected the run at t={max(len(trajectory) - 1, 0) * dt:.1f} s: {exc}"
                if not trajectory:
                    return recorder.failed_run(scene, steps, reason)
                tracks = scenic_trace.tracks_from_trajectory(trajectory, roles)
                return recorder.SceneRun(recorder.pad_tracks(tracks, steps + 1), invalid_reason=reason,
                                              contacts=_contacts(partial, roles))
            except Exception as exc:  # noqa: BLE001 - a behaviour failing at run time invalidates this variation only
                return recorder.failed_run(scene, steps, f"newtonian run failed: {type(exc).__name__}: {exc}")
            finally:
                simulator.destroy()
        tracks = scenic_trace.tracks_from_trajectory(simulation.result.trajectory, roles)
        tracks = recorder.pad_tracks(tracks, steps + 1)
        return recorder.SceneRun(tracks, contacts=_contacts(simulation, roles))


def _contacts(simulation, roles: list[str]) -> list[dict]:
    """The first contacts a `PinnedNewtonianSimulation` logged, by role."""
    return [{"actor_a": roles[a], "actor_b": roles[b], "step": step, "t": t}
            for a, b, step, t in getattr(simulation, "contacts", [])]


def placement_mismatch(scenic_scene, scene: SampledScene, drift: float) -> str | None:
    """Why the Scenic scene is not the sampled scene (placement or sampled parameters differ), or None.

    Behaviour arguments come from the Scenic scene's parameters, so a scene
    whose parameters differ would not replay the sampled variation even with
    its actors pinned in place.
    """
    if drift > PIN_TOLERANCE:
        return (f"scenic placed an actor {drift:.2f} m from the sampled scene (tolerance {PIN_TOLERANCE} m): "
                f"the program and the scenes disagree (re-sample the scenes from this program)")
    for key, value in scene.params.items():
        ours = scenic_scene.params.get(key)
        if isinstance(value, float) and isinstance(ours, (int, float)) and not math.isclose(value, ours,
                                                                                              rel_tol=1e-9):
            return (f"scenic sampled parameter {key} = {ours!r} but the scene has {value!r}: "
                    f"the program and the scenes disagree (re-sample the scenes from this program)")
    return None


# ---------------------------------------------------------------- hand-written Scenic programs

def scenes_from_program(program: str, map_file: Path, scenario, n: int, seed: int, first: int = 0,
                        scenario_hash: str | None = None) -> list[SampledScene]:
    """Sampled scenes of a Scenic program that `crashscene render` did not write (hand-written or edited).

    Scene i is Scenic's scene for (seed, i), as `crashscene.render.sample` draws it.
    Objects tagged `cs_role` (or `role`) keep their role; untagged ones take the
    DSL scenario's roles in order, the ego object first. What the program does
    not say (type, behaviour, position relation, dispositions) comes from the
    scenario's actor of that role, so the traces are monitored against it.
    """
    from crashscene.dsl.tokens import Behavior

    scenario_roles = list(scenario.actors)
    simulator = NewtonianSimulator()
    compiled = simulator.compiled(program, map_file)
    digest = scenario_hash or hashlib.sha256(program.encode()).hexdigest()[:16]
    scenes = []
    for index in range(first, first + n):
        with quiet_scenic():
            try:
                scene = generate_scenic_scene(compiled, seed, index)
            except Exception as exc:
                raise SimulationError(f"the Scenic program gives no scene {index} (seed {seed}): "
                                      f"{type(exc).__name__}: {exc}") from exc
        objects = sorted(scene.objects, key=lambda obj: obj is not scene.egoObject)  # ego first, stable
        if len(objects) != len(scenario_roles):
            raise SimulationError(f"the Scenic program places {len(objects)} objects but the scenario has "
                                  f"{len(scenario_roles)} actors ({', '.join(scenario_roles)}): one object per actor")
        tagged = [getattr(obj, "cs_role", None) or getattr(obj, "role", None) for obj in objects]
        roles = tagged if sorted(map(str, tagged)) == sorted(scenario_roles) else scenario_roles
        actors = [_program_actor(obj, role, scenario, Behavior) for obj, role in zip(objects, roles)]
        scenes.append(SampledScene(index=index, seed=seed, scenario_hash=digest, map_file=str(map_file),
                                   params={k: v for k, v in scene.params.items() if k not in SCENIC_PARAMS
                                           and isinstance(v, (int, float, str)) and not isinstance(v, bool)},
                                   actors=actors))
    return scenes


def _program_actor(obj, role: str, scenario, behavior_enum) -> SampledActor:
    """A SampledActor for a Scenic object, the DSL actor of its role filling what Scenic does not know."""
    from crashscene.render.plan import ROUTE_INTENT

    dsl = scenario.actors[role]
    lane = getattr(obj, "_lane", None)
    behavior = str(getattr(obj, "cs_behavior", None) or _token(dsl.behavior))
    intent = getattr(obj, "cs_route_intent", None) or ROUTE_INTENT[behavior_enum(behavior)]
    codes = [entry.code for entry in scenario.oracle if entry.actor == role]
    return SampledActor(
        role=role, label=dsl.label, type=str(getattr(obj, "cs_type", None) or _token(dsl.type)),
        blueprint=str(getattr(obj, "blueprint", None) or "unknown"), behavior=behavior,
        x=float(obj.position[0]), y=float(obj.position[1]),
        yaw=float(scenic_trace.yaw_from_heading(obj.heading)), speed=max(0.0, float(obj.speed or 0.0)),
        length=float(obj.length), width=float(obj.width), lane_id=lane.uid if lane is not None else None,
        route_intent=str(intent), reference=_token(dsl.position.reference), relation=_token(dsl.position.relation),
        heading_relation=_token(dsl.position.heading) if dsl.position.heading else None, dispositions=codes)


def _token(value) -> str:
    """The DSL token of an enum member, or the string itself (roles used as references)."""
    return str(getattr(value, "value", value))


def simulate_program(scenario, program: str | Path, map_file: Path, n: int, seed: int, first: int = 0,
                     settings: SimulationSettings | None = None) -> BatchResult:
    """Run a hand-written Scenic program on the newtonian backend: n variations from `first`, seeded `seed`.

    `program` is Scenic source or a path to a .scenic file; `scenario` is the DSL
    scenario it stages (roles, behaviours, oracle for the monitor).
    """
    text = Path(program).read_text(encoding="utf-8") if isinstance(program, Path) else program
    scenes = scenes_from_program(text, Path(map_file), scenario, n, seed, first)
    with NewtonianSimulator(settings) as simulator:
        return simulator.simulate(SimulationRequest(scenario=scenario, scenes=scenes, map_file=Path(map_file),
                                                    settings=simulator.settings, program=text))


@dataclass(frozen=True)
class NewtonianTiming:
    """Wall-clock cost of the newtonian backend on one scenario: a one-off compile plus a cost per run."""

    compile_seconds: float  # [s] compiling the program (once per scenario and map)
    run_seconds: float  # [s] running and recording `runs` scenes
    runs: int

    @property
    def per_run(self) -> float:
        """[s] per variation (Scenic scene, Newtonian run, trace recording)."""
        return self.run_seconds / max(self.runs, 1)

    def extrapolate(self, n: int) -> float:
        """[s] for n variations: one compile plus n runs."""
        return self.compile_seconds + n * self.per_run


def newtonian_timing(request: SimulationRequest, k: int = 50) -> NewtonianTiming:
    """Benchmark input: time the first `k` scenes of `request` on the newtonian backend.

    `benchmarks/bench_simulate.py` extrapolates 2,000 variations from 50 with
    `newtonian_timing(request, 50).extrapolate(2000)`.
    """
    scenes = list(request.scenes)[:k]
    with NewtonianSimulator(request.settings) as simulator:
        start = time.perf_counter()
        simulator.compiled(request.program or "", request.map_file)
        compiled = time.perf_counter()
        simulator.simulate(SimulationRequest(scenario=request.scenario, scenes=scenes, map_file=request.map_file,
                                             settings=request.settings, program=request.program))
        done = time.perf_counter()
    return NewtonianTiming(compile_seconds=compiled - start, run_seconds=done - compiled, runs=len(scenes))


def time_newtonian_runs(request: SimulationRequest, k: int | None = None) -> float:
    """Seconds [s] to run the first `k` scenes of `request` (all when None), the one-off compile excluded."""
    return newtonian_timing(request, len(request.scenes) if k is None else k).run_seconds
