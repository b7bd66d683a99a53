"""The `carla` backend: run the rendered Scenic program in CARLA through Scenic's CARLA interface.

Needs the `carla` Python client (`pip install carla==0.9.16`, a Python 3.11
wheel) and a running CARLA server (0.9.15/0.9.16) at `--carla-host/--carla-port`.
Both are checked before anything else, and either missing gives a
`BackendUnavailable` error saying what to install or start; no test here needs
a server. The import is guarded as in Scenic's `simulators/carla/__init__.py`,
so this module imports fine without `carla`.

Runs mirror the newtonian backend: the Scenic scene of each variation
(checked to be the sampled one), each actor started at its sampled speed
(CARLA cannot spawn a moving actor: the speed is given as a target velocity
right after spawning), traces recorded every tick by
`scenic_trace.StateRecorder` and laid out by `scenic_trace.record_tables`,
footprint contacts as collisions (CARLA's own physics handles the crash itself).

World: a map file named after a CARLA town (`Town04.xodr`) loads that town;
any other OpenDRIVE file is loaded with `generate_opendrive_world` (road
meshes generated from the file, no buildings).

External ADS stack (test mode, `--ads package.module:Class`): the class is a
`CarlaAgent` (below). It is instantiated with `--ads` parameters as keyword
arguments, given the CARLA world and the ego vehicle at the start of each run,
and asked for a `carla.VehicleControl` every tick; the ego's own Scenic
behaviour is then ignored. The ego is spawned with `role_name = "hero"`, the
name CARLA's ROS bridge and Autoware's CARLA interface attach to: for such a
stack, `run_step` returns None (the stack applies its controls through the
bridge) and may block until the stack has processed the tick. A working
example is `CarlaBasicAgent` (CARLA's BasicAgent as the ADS).
"""
from __future__ import annotations

import math
import re
import socket
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate import scenic_trace
from crashscene.simulate.backend import (
    BackendUnavailable,
    BatchResult,
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    Simulator,
    check_ego_role,
    import_ads,
)
from crashscene.simulate.newtonian import (
    compile_program,
    generate_scenic_scene,
    placement_mismatch,
    quiet_scenic,
    seeded_globals,
)

CARLA_MODEL = "scenic.simulators.carla.model"
CARLA_CLIENT_PIN = "carla==0.9.16"
EGO_ROLE_NAME = "hero"  # the role_name CARLA's ROS bridge and Autoware's CARLA interface look for
CONNECT_TIMEOUT = 3.0  # [s] TCP probe of the server
CLIENT_TIMEOUT = 10.0  # [s] CARLA client RPC timeout
TOWN_NAME = re.compile(r"^Town\d{2}(_Opt|HD(_Opt)?)?$")
PROGRAM_TOWN = re.compile(r"^param carla_map = ['\"](Town\d{2}(?:_Opt|HD(?:_Opt)?)?)['\"]", re.MULTILINE)


@runtime_checkable
class CarlaAgent(Protocol):
    """An external ADS driving the ego in CARLA (`--ads package.module:Class` with `--backend carla`).

    Lifecycle per variation: `setup` once after the actors are spawned, `run_step`
    before every tick, `teardown` when the run ends (also after errors).
    """

    def setup(self, world: Any, ego: Any, actor: SampledActor, map_file: Path, dt: float) -> None:
        """`world`: carla.World; `ego`: the carla.Vehicle to drive; `actor`: its sampled start and route intent."""

    def run_step(self, t: float) -> Any:
        """Return a carla.VehicleControl for the ego, or None when the stack applies its own controls."""

    def teardown(self) -> None:
        """Release whatever `setup` acquired."""


class CarlaBasicAgent:
    """A ready-made `CarlaAgent`: CARLA's own `BasicAgent` (PythonAPI `agents.navigation`) drives the ego.

    `--backend carla --ads crashscene.simulate.carla:CarlaBasicAgent` (parameters:
    `target_speed` [m/s], default the ego's sampled speed; `horizon` [m], how far
    along its lane the destination lies). The `agents` package ships with CARLA
    (`PythonAPI/carla`), not with the pip client: put that folder on PYTHONPATH.
    It is also the template for wrapping another stack.
    """

    def __init__(self, target_speed: float | None = None, horizon: float = 300.0):
        self.target_speed = target_speed  # [m/s]
        self.horizon = horizon  # [m]
        self.agent = None

    def setup(self, world: Any, ego: Any, actor: SampledActor, map_file: Path, dt: float) -> None:
        try:
            from agents.navigation.basic_agent import BasicAgent
        except ImportError as exc:
            raise BackendUnavailable("CarlaBasicAgent needs CARLA's PythonAPI `agents` package: add "
                                     "<CARLA>/PythonAPI/carla to PYTHONPATH") from exc
        speed = self.target_speed if self.target_speed is not None else actor.speed
        self.agent = BasicAgent(ego, target_speed=speed * 3.6)  # CARLA agents take km/h
        start = world.get_map().get_waypoint(ego.get_location())
        ahead = start.next(self.horizon)
        self.agent.set_destination((ahead[0] if ahead else start).transform.location)

    def run_step(self, t: float) -> Any:
        return self.agent.run_step()

    def teardown(self) -> None:
        self.agent = None


def import_carla():
    """The `carla` module, or BackendUnavailable saying how to install it."""
    try:
        import carla
    except ImportError as exc:
        raise BackendUnavailable(
            f"the carla backend needs the CARLA Python client, which is not installed ({exc}); "
            f"install it with `pip install {CARLA_CLIENT_PIN}` (Python 3.11 wheel) and start a CARLA server, "
            f"or choose --backend embedded|newtonian") from exc
    return carla


def check_server(host: str, port: int, timeout: float = CONNECT_TIMEOUT) -> None:
    """BackendUnavailable unless something accepts TCP connections at host:port (a CARLA server)."""
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        raise BackendUnavailable(
            f"no CARLA server reachable at {host}:{port} ({exc.strerror or exc}); start one "
            f"(e.g. ./CarlaUE4.sh -RenderOffScreen -carla-rpc-port={port}) or pass --carla-host/--carla-port") from exc


def load_agent(spec: str, params: dict[str, Any] | None = None) -> CarlaAgent:
    """Instantiate the external ADS `package.module:Class` with `params` as keyword arguments."""
    cls = import_ads(spec, what="class")
    if not isinstance(cls, type):
        module_name, _, class_name = spec.partition(":")
        raise SimulationError(f"--ads {spec!r}: module {module_name!r} has no class {class_name!r}")
    try:
        agent = cls(**(params or {}))
    except TypeError as exc:
        raise SimulationError(f"--ads {spec!r}: cannot create it with parameters {params or {}} ({exc})") from exc
    if not isinstance(agent, CarlaAgent):
        raise SimulationError(f"--ads {spec!r}: a CARLA agent needs methods setup, run_step and teardown "
                              f"(see crashscene.simulate.carla.CarlaAgent)")
    return agent


def carla_town(map_file: Path, program: str = "") -> str | None:
    """The CARLA town to load, None to generate the world from `map_file` itself.

    The program's own `param carla_map = 'TownNN'` (render's carla mode) wins;
    else a map file named after a town (`Town04.xodr`) names it.
    """
    found = PROGRAM_TOWN.search(program)
    if found:
        return found.group(1)
    stem = Path(map_file).stem
    return stem if TOWN_NAME.match(stem) else None


def _tracing_classes(carla):
    """Scenic CARLA Simulator/Simulation subclasses that pin, record and host an external agent."""
    from scenic.core.vectors import Vector
    from scenic.simulators.carla.simulator import CarlaSimulation
    from scenic.simulators.carla.simulator import CarlaSimulator as ScenicCarlaSimulator

    class PinnedCarlaSimulation(scenic_trace.StateRecorder, CarlaSimulation):
        def __init__(self, scene, *args, pins, agent_index, agent, agent_setup, **kwargs):
            self._pins, self._agent_index, self._agent, self._agent_setup = pins, agent_index, agent, agent_setup
            super().__init__(scene, *args, **kwargs)

        def createObjectInSimulator(self, obj):
            index = len(self.objects) - 1
            # The Scenic scene is the sampled one (placement_mismatch checked it): only the speed needs
            # pinning. CARLA spawns from `orientation`, which a heading set here would not update.
            _, _, _, speed = self._pins[index]
            heading = float(obj.heading)
            if index == self._agent_index and self._agent is not None:
                obj.rolename = EGO_ROLE_NAME
            actor = super().createObjectInSimulator(obj)
            # CARLA cannot spawn a moving actor: start it through a target velocity
            # (CARLA's y axis points the other way round, hence the sign).
            vx, vy = -speed * math.sin(heading), speed * math.cos(heading)
            actor.set_target_velocity(carla.Vector3D(vx, -vy, 0.0))
            obj.velocity, obj.speed = Vector(0, 0), 0.0
            return actor

        def setup(self):
            super().setup()
            if self._agent is not None:
                self._agent_setup(self.world, self.objects[self._agent_index].carlaActor)

        def executeActions(self, allActions):
            if self._agent is not None:
                ego = self.objects[self._agent_index]
                if ego in allActions:
                    allActions[ego] = ()  # the external stack drives the ego, not its Scenic behaviour
            super().executeActions(allActions)
            if self._agent is not None:
                control = self._agent.run_step(self.currentTime * self.timestep)
                if control is not None:
                    self.objects[self._agent_index].carlaActor.apply_control(control)

    class PinnedCarlaSimulator(ScenicCarlaSimulator):
        """One connection and world for a batch; `prepare` sets the next run's pins and agent."""

        pins: tuple = ()
        agent_index: int | None = None
        agent: CarlaAgent | None = None
        agent_setup = None

        def prepare(self, pins, agent_index=None, agent=None, agent_setup=None):
            self.pins, self.agent_index, self.agent, self.agent_setup = pins, agent_index, agent, agent_setup

        def createSimulation(self, scene, *, timestep, **kwargs):
            self.scenario_number += 1
            return PinnedCarlaSimulation(scene, self.client, self.tm, self.render, self.record,
                                         self.scenario_number, timestep=self.timestep, pins=self.pins,
                                         agent_index=self.agent_index, agent=self.agent,
                                         agent_setup=self.agent_setup, **kwargs)

    return PinnedCarlaSimulator


class CarlaSimulator(Simulator):
    """Runs rendered Scenic programs in CARLA, one scene at a time, in synchronous mode at `dt`.

    Checks for the client and the server when a batch starts, not at import,
    so `--backend carla` fails fast and clearly where CARLA is absent.
    """

    name = "carla"
    scene_sampler = "scenic"  # each scene is re-generated by Scenic from (seed, index), then pinned

    def __init__(self, settings: SimulationSettings | None = None):
        super().__init__(settings)
        self._compiled: dict[tuple[str, str], object] = {}
        self._carla = None
        self._world_key: tuple | None = None
        self._scenic_simulator = None

    def check_available(self) -> None:
        """BackendUnavailable unless `import carla` works and a server answers at the configured host:port."""
        self._carla = import_carla()
        check_server(self.settings.carla_host, self.settings.carla_port)

    def simulate(self, request: SimulationRequest) -> BatchResult:
        check_ego_role(request.scenario, self.settings)
        if not request.program:
            raise SimulationError("the carla backend needs the rendered Scenic program "
                                  "(SimulationRequest.program is empty)")
        if self.settings.ads is not None:
            if self.settings.mode != "test":
                raise SimulationError(f"--ads {self.settings.ads!r} drives the ADS role in test mode only; "
                                      f"got --mode {self.settings.mode}")
            load_agent(self.settings.ads, self.settings.ads_params)  # fail before connecting, not mid-batch
        self.check_available()
        result = scenic_trace.run_scenes(self.name, request, self.settings, self.run_scene)
        if self.settings.mode == "test" and self.settings.ads is None:
            result.notes.append(f"carla: no --ads given, the ADS role {self.settings.ego_role!r} runs the "
                                f"program's Scenic behaviour")
        return result

    def compiled(self, program: str, map_file: Path):
        """The program compiled under Scenic's CARLA model (no server needed for this part)."""
        key = (program, str(Path(map_file).resolve()))
        if key not in self._compiled:
            params = {"render": 0, "address": self.settings.carla_host, "port": self.settings.carla_port,
                      "timestep": self.settings.dt, "carla_map": carla_town(map_file, program),
                      "timeout": CLIENT_TIMEOUT}
            self._compiled[key] = compile_program(program, map_file, model=CARLA_MODEL, extra_params=params)
        return self._compiled[key]

    def scenic_simulator(self, program: str, map_file: Path):
        """The Scenic CARLA simulator (a connection and a loaded world), created once per map."""
        town = carla_town(map_file, program)
        key = (town, str(Path(map_file).resolve()))
        if self._scenic_simulator is None or self._world_key != key:
            self.close()
            settings = self.settings
            try:
                self._scenic_simulator = _tracing_classes(self._carla or import_carla())(
                    town, str(map_file), address=settings.carla_host, port=settings.carla_port,
                    timeout=CLIENT_TIMEOUT, render=False, timestep=settings.dt)
            except RuntimeError as exc:  # Scenic wraps CARLA's load/connection errors in RuntimeError
                raise BackendUnavailable(f"CARLA at {settings.carla_host}:{settings.carla_port} could not load "
                                         f"the world for {map_file} (town {town or 'generated from OpenDRIVE'}): "
                                         f"{exc}") from exc
            self._world_key = key
        return self._scenic_simulator

    def close(self) -> None:
        if self._scenic_simulator is not None:
            self._scenic_simulator.destroy()
            self._scenic_simulator, self._world_key = None, None

    def run_scene(self, request: SimulationRequest, scene: SampledScene) -> scenic_trace.ScenicRun:
        """Run one scene in CARLA: its tracks and footprint contacts, or why it is invalid."""
        settings = self.settings
        steps = settings.steps
        program = request.program or ""
        scenario = self.compiled(program, request.map_file)
        with quiet_scenic():
            scenic_scene = generate_scenic_scene(scenario, scene.seed, scene.index)
        roles = scenic_trace.object_roles(scenic_scene.objects, scene)
        by_role = {actor.role: actor for actor in scene.actors}
        pins, drift = [], 0.0
        for obj, role in zip(scenic_scene.objects, roles):
            actor = by_role[role]
            pins.append((actor.x, actor.y, actor.yaw - scenic_trace.SCENIC_TO_YAW, actor.speed))
            drift = max(drift, math.hypot(float(obj.position[0]) - actor.x, float(obj.position[1]) - actor.y))
        mismatch = placement_mismatch(scenic_scene, scene, drift)
        if mismatch:
            return scenic_trace.failed_run(scene, steps, mismatch)
        agent, agent_index = None, None
        if settings.ads is not None and settings.mode == "test":
            agent = load_agent(settings.ads, settings.ads_params)
            agent_index = roles.index(settings.ego_role)
        ego_actor = by_role[settings.ego_role]

        def agent_setup(world, vehicle):
            agent.setup(world, vehicle, ego_actor, Path(request.map_file), settings.dt)

        simulator = self.scenic_simulator(program, request.map_file)
        simulator.prepare(pins, agent_index, agent, agent_setup)
        try:
            with seeded_globals(scene.seed, scene.index):
                simulation = simulator.simulate(scenic_scene, maxSteps=steps, verbosity=0)
        except Exception as exc:  # noqa: BLE001 - a spawn or behaviour failure invalidates this variation only
            return scenic_trace.failed_run(scene, steps, f"carla run failed: {type(exc).__name__}: {exc}")
        finally:
            if agent is not None:
                agent.teardown()
        if simulation is None:
            return scenic_trace.failed_run(scene, steps, "scenic rejected the simulation (a requirement was violated)")
        tracks = scenic_trace.pad_tracks(scenic_trace.tracks_from_trajectory(simulation.result.trajectory, roles),
                                         steps + 1)
        sizes = {actor.role: (actor.length, actor.width) for actor in scene.actors}
        return scenic_trace.ScenicRun(tracks, contacts=scenic_trace.find_contacts(tracks, sizes, settings.dt))
