"""Turning Scenic simulations (Newtonian, CARLA) into the tables of `crashscene.traces`.

Scenic keeps only positions in `result.trajectory`. `StateRecorder` is a mixin
for any Scenic `Simulation` class whose `currentState()` records, per object and
step, the centre, heading and speed; `tracks_from_trajectory` turns that into
per-actor arrays, and `find_contacts` detects footprint overlap (Scenic's
simulators do not). `record_tables` then lays the tracks of a batch out with
the embedded backend's own batch set-up and `Recorder` (its routes, junction
entries, traffic control and signal plans, its lane lookups), so every column
means the same whichever backend produced the trace.

Angles: Scenic heading is 0 = +y, counter-clockwise; crashscene yaw is
0 = +x (OpenDRIVE), so yaw = heading + pi/2, wrapped to [-pi, pi] (`geometry.wrap_angle`).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from crashscene.geometry import footprint_corners, footprints_overlap, wrap_angle
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import BatchResult, SimulationError, SimulationRequest
from crashscene.units import G

SCENIC_TO_YAW = math.pi / 2  # [rad] yaw = Scenic heading + pi/2


def yaw_from_heading(heading: np.ndarray | float) -> np.ndarray | float:
    """Scenic heading [rad] (0 = +y) -> crashscene yaw [rad] (0 = +x), wrapped to [-pi, pi]."""
    return wrap_angle(np.asarray(heading) + SCENIC_TO_YAW, exact=True)


class StateRecorder:
    """Mixin for a Scenic `Simulation` subclass: record (x, y, heading, speed) of every object each step.

    Put it first in the bases (`class T(StateRecorder, NewtonianSimulation)`) so
    this `currentState` wins; Scenic stores its return value in
    `simulation.result.trajectory`, one entry per step (the initial state included).
    """

    def currentState(self):
        states = []
        for obj in self.objects:
            speed = obj.speed
            if speed is None:  # some interfaces leave it unset before the first step
                speed = math.hypot(obj.velocity[0], obj.velocity[1])
            states.append((float(obj.position[0]), float(obj.position[1]), float(obj.heading), float(speed)))
        return tuple(states)


@dataclass
class Track:
    """One actor's recorded states over the run, one entry per step [m, m, rad (yaw), m/s]."""

    role: str
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray


def object_roles(objects: Sequence, scene: SampledScene) -> list[str]:
    """The DSL role of each Scenic object of a simulated scene, in object order.

    Rendered programs tag each object with a `cs_role` property (hand-written
    ones may use `role`); untagged objects are matched to the scene's actors in
    order, the ego object first, as Scenic lists them.
    """
    roles = [getattr(obj, "cs_role", None) or getattr(obj, "role", None) for obj in objects]
    known = {actor.role for actor in scene.actors}
    if all(isinstance(role, str) and role in known for role in roles):
        return roles
    if len(objects) != len(scene.actors):
        raise SimulationError(f"variation {scene.index}: the Scenic scene has {len(objects)} objects but the "
                              f"sampled scene has {len(scene.actors)} actors "
                              f"({', '.join(a.role for a in scene.actors)}); tag each object with `cs_role`")
    return [actor.role for actor in scene.actors]


def tracks_from_trajectory(trajectory: Sequence[Sequence[tuple[float, float, float, float]]],
                           roles: Sequence[str]) -> dict[str, Track]:
    """Per-role tracks from a `StateRecorder` trajectory (steps x objects x (x, y, heading, speed))."""
    states = np.asarray(trajectory, dtype=np.float64)  # (steps, objects, 4)
    if states.ndim != 3 or states.shape[1] != len(roles) or states.shape[2] != 4:
        raise SimulationError(f"unexpected Scenic trajectory shape {states.shape}; expected (steps, "
                              f"{len(roles)}, 4): was the simulation class built with StateRecorder?")
    return {role: Track(role=role, x=states[:, i, 0].copy(), y=states[:, i, 1].copy(),
                        yaw=yaw_from_heading(states[:, i, 2]), speed=np.abs(states[:, i, 3]))
            for i, role in enumerate(roles)}


# ---------------------------------------------------------------- footprints and contacts

def contact_point(a: Track, size_a: tuple[float, float], b: Track, size_b: tuple[float, float],
                  step: int) -> tuple[float, float]:
    """Estimate [m] of where two overlapping footprints touch: the centroid of their overlap at `step`."""
    import shapely

    pa_ = shapely.Polygon(footprint_corners(a.x[step], a.y[step], a.yaw[step], *size_a))
    pb_ = shapely.Polygon(footprint_corners(b.x[step], b.y[step], b.yaw[step], *size_b))
    overlap = pa_.intersection(pb_)
    if overlap.is_empty:  # touching edges only
        return (float((a.x[step] + b.x[step]) / 2), float((a.y[step] + b.y[step]) / 2))
    centroid = overlap.centroid
    return (float(centroid.x), float(centroid.y))


def find_contacts(tracks: dict[str, Track], sizes: dict[str, tuple[float, float]], dt: float) -> list[dict]:
    """First contact of every actor pair (its `step` and COLLISION_SCHEMA fields but `variation`), by time."""
    rows = []
    roles = list(tracks)
    for i, role_a in enumerate(roles):
        for role_b in roles[i + 1:]:
            a, b = tracks[role_a], tracks[role_b]
            hits = np.flatnonzero(footprints_overlap(a.x, a.y, a.yaw, *sizes[role_a], b.x, b.y, b.yaw, *sizes[role_b]))
            if hits.size == 0:
                continue
            k = int(hits[0])
            x, y = contact_point(a, sizes[role_a], b, sizes[role_b], k)
            rows.append({"step": k, "t": round(k * dt, 9), "actor_a": role_a, "actor_b": role_b,
                         "speed_a": float(a.speed[k]), "speed_b": float(b.speed[k]),
                         "yaw_a": float(a.yaw[k]), "yaw_b": float(b.yaw[k]), "x": x, "y": y})
    rows.sort(key=lambda row: (row["t"], row["actor_a"], row["actor_b"]))
    return rows


# ---------------------------------------------------------------- recording through the embedded backend

LOST_GRIP = 0.8 * G  # [m/s2] lateral acceleration beyond dry-road friction: the actor is skidding
LATERAL_MOVE = 0.3  # [m/s] lateral speed off the route above which a lane changer counts as changing


@dataclass
class ScenicRun:
    """What one Scenic run of a scene produced: per-role tracks of steps + 1 states, or why it failed."""

    tracks: dict[str, Track]
    invalid_reason: str | None = None
    contacts: list[dict] = field(default_factory=list)  # first contact per pair: actor_a, actor_b, step, t [s]


def still_track(actor: SampledActor, n: int) -> Track:
    """A track holding the actor at its sampled pose, at rest, for `n` steps (for runs that never started)."""
    return Track(role=actor.role, x=np.full(n, actor.x), y=np.full(n, actor.y), yaw=np.full(n, actor.yaw),
                 speed=np.zeros(n))


def failed_run(scene: SampledScene, steps: int, reason: str) -> ScenicRun:
    """An invalid variation: every actor held at its sampled pose, flagged with `reason`."""
    return ScenicRun({a.role: still_track(a, steps + 1) for a in scene.actors}, invalid_reason=reason)


def pad_tracks(tracks: dict[str, Track], n: int) -> dict[str, Track]:
    """Tracks of exactly `n` steps: a run that ended early (a Scenic `terminate`) holds its last pose at rest."""
    padded = {}
    for role, track in tracks.items():
        missing = n - track.x.size
        if missing <= 0:
            padded[role] = Track(role, track.x[:n], track.y[:n], track.yaw[:n], track.speed[:n])
            continue
        hold = np.full(missing, 1.0)
        padded[role] = Track(role, np.append(track.x, hold * track.x[-1]), np.append(track.y, hold * track.y[-1]),
                             np.append(track.yaw, hold * track.yaw[-1]), np.append(track.speed, np.zeros(missing)))
    return padded


def run_scenes(backend: str, request: SimulationRequest, settings,
               run_scene: Callable[[SimulationRequest, SampledScene], ScenicRun]) -> BatchResult:
    """Run every scene of a request one by one through a Scenic backend and record the trace tables."""
    start = time.perf_counter()
    scenes = list(request.scenes)
    runs = []
    for scene in scenes:
        runs.append(run_scene(request, scene))
        if request.progress is not None:
            request.progress(1)
    tables = record_tables(request.scenario, scenes, runs, settings, request.map_file)
    return BatchResult(backend=backend, tables=tables, seconds=time.perf_counter() - start)


def record_tables(scenario, scenes: Sequence[SampledScene], runs: Sequence[ScenicRun], settings,
                  map_file) -> dict[str, pa.Table]:
    """The four tables of `crashscene.traces` for Scenic runs, laid out by the embedded backend's recorder.

    The scenes get the embedded backend's batch set-up (its routes from each
    actor's start lane and intent, junction entries, traffic control from the
    DSL, signal phase plans from (seed, variation)), the Scenic tracks are
    projected onto those routes step by step, and the embedded `Recorder`
    derives every map column. So a trace means the same whichever backend
    produced it; the one difference is that Scenic's vehicles do not react to
    the signal states recorded for them.
    """
    from crashscene.simulate.embedded import setup as batch_setup
    from crashscene.simulate.embedded.record import Recorder
    from crashscene.simulate.embedded.simulator import _geometry
    from crashscene.simulate.roads import RoadMap

    scenes = list(scenes)
    roadmap = RoadMap.load(map_file)
    recorder = Recorder(roadmap, settings)
    if not scenes:
        return recorder.tables(scenes)
    batch = batch_setup.build(scenario, scenes, roadmap, settings)
    for v, run in enumerate(runs):
        if run.invalid_reason is not None:  # the Scenic failure is the first thing to fix
            batch.invalid[v] = run.invalid_reason
    roles = [column.role for column in batch.columns]
    n_t, n_v, n_a = settings.steps + 1, len(scenes), len(roles)

    def stack(attr: str) -> np.ndarray:  # (T, V, A)
        return np.stack([np.stack([getattr(run.tracks[role], attr)[:n_t] for role in roles], axis=-1)
                         for run in runs], axis=1)

    x, y, yaw, speed = stack("x"), stack("y"), stack("yaw"), stack("speed")
    accel = np.zeros_like(speed)
    accel[1:] = np.diff(speed, axis=0) / settings.dt  # as recorded by the embedded backend: over the last step
    yaw_rate = np.zeros_like(yaw)
    yaw_rate[1:] = np.diff(np.unwrap(yaw, axis=0), axis=0) / settings.dt
    lost = np.maximum.accumulate(np.abs(speed * yaw_rate) > LOST_GRIP, axis=0)
    contact_step = np.full((n_v, n_a, n_a), -1)
    contact_t = np.zeros((n_v, n_a, n_a))
    for a in range(n_a):  # footprints overlapping at spawn: the embedded recorder invalidates the variation
        for b in range(a + 1, n_a):
            spawn = footprints_overlap(x[0, :, a], y[0, :, a], yaw[0, :, a], batch.length[:, a], batch.width[:, a],
                                       x[0, :, b], y[0, :, b], yaw[0, :, b], batch.length[:, b], batch.width[:, b])
            contact_step[spawn, a, b] = 0
    for v, run in enumerate(runs):
        for row in run.contacts:
            a, b = sorted((roles.index(row["actor_a"]), roles.index(row["actor_b"])))
            contact_step[v, a, b] = row["step"]
            contact_t[v, a, b] = row["t"]

    state = _TrackState(batch)
    recorder.begin(batch)
    lateral_target = np.nan_to_num(batch.lateral_target)
    for step in range(n_t):
        t = step * settings.dt
        state.advance(x[step], y[step], yaw[step], speed[step], accel[step], yaw_rate[step], lost[step], t,
                      settings.dt)
        for a in range(n_a):
            for b in range(a + 1, n_a):
                hit = contact_step[:, a, b] == step
                if hit.any():
                    recorder.collision(hit, a, b, contact_t[:, a, b], state, step == 0)
        moving = np.abs(state.d - state.d_prev) / settings.dt > LATERAL_MOVE if step else np.zeros_like(state.d, bool)
        lat_cmd = np.where(moving, lateral_target, state.d)
        recorder.record(step, t, state, _geometry(batch, state, t), lat_cmd)
    recorder.end(batch, state)
    return recorder.tables(scenes)


class _TrackState:
    """The embedded simulator's `State` fields, filled from recorded tracks instead of its dynamics."""

    def __init__(self, batch):
        self.batch = batch
        self.s, self.d = batch.s0.copy(), batch.d0.copy()
        self.d_prev = self.d.copy()
        self.moved = np.zeros_like(self.s)
        self.gone_time = np.full(self.s.shape, np.nan)
        self.collided = np.zeros(self.s.shape, dtype=bool)
        self.x = self.y = self.yaw = self.v = self.a = self.yaw_rate = None
        self.lost = np.zeros(self.s.shape, dtype=bool)

    def advance(self, x, y, yaw, v, a, yaw_rate, lost, t: float, dt: float) -> None:
        routes, r = self.batch.routes, self.batch.route
        if self.x is not None:
            self.moved = self.moved + np.hypot(x - self.x, y - self.y)
            # follow the route from the last station: predict with the route heading, correct along the tangent
            _, _, ryaw = routes.point(r, self.s)
            s_pred = self.s + np.hypot(x - self.x, y - self.y) * np.cos(yaw - ryaw)
            self.d_prev = self.d
            self.s, self.d, _ = routes.local_coordinates(r, x, y, s_pred, iterations=3)
            end = routes.length[r] - self.batch.length / 2 - 0.5
            self.gone_time = np.where(np.isnan(self.gone_time) & (self.s >= end) & ~lost, t, self.gone_time)
        self.x, self.y, self.yaw, self.v, self.a, self.yaw_rate, self.lost = x, y, yaw, v, a, yaw_rate, lost
        self.d_ref = self.d
