"""The backend-neutral recorder: from each actor's states to every column of `crashscene.traces`.

The state protocol a backend fills is small: per scene, a `SceneRun` holding
one `Track` per actor role, the actor's centre x, y [m], yaw [rad] (0 = +x,
counter-clockwise) and speed [m/s] at each of the steps + 1 sample times
(the initial state included), plus the contacts it saw and why a run failed.
`record_tables` derives everything else from the map and the scenario, the
same way for every backend: routes from each actor's start lane and intent,
junction entries, traffic control from the DSL, signal phases from (seed,
variation), lane, junction and centre-line columns from the map (the map
columns are laid out by the embedded backend's batch set-up and recorder,
which this module alone calls). Contacts a backend does not report are found
from the footprints (`find_contacts`). A new backend is then one module that
produces `SceneRun`s (see `crashscene.simulate.dummy`).
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from crashscene.geometry import footprint_corners, footprints_overlap
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import BatchResult, SimulationRequest
from crashscene.units import G


@dataclass
class Track:
    """One actor's recorded states over the run, one entry per step [m, m, rad (yaw), m/s]."""

    role: str
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray


# ---------------------------------------------------------------- contacts from footprints

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


# ---------------------------------------------------------------- runs

LOST_GRIP = 0.8 * G  # [m/s2] lateral acceleration beyond dry-road friction: the actor is skidding
LATERAL_MOVE = 0.3  # [m/s] lateral speed off the route above which a lane changer counts as changing


@dataclass
class SceneRun:
    """What one run of a scene produced, in the state protocol: per-role tracks of steps + 1 states
    (or, when it failed, why), and the contacts the backend saw (else found from the footprints)."""

    tracks: dict[str, Track]
    invalid_reason: str | None = None
    contacts: list[dict] = field(default_factory=list)  # first contact per pair: actor_a, actor_b, step, t [s]


def still_track(actor: SampledActor, n: int) -> Track:
    """A track holding the actor at its sampled pose, at rest, for `n` steps (for runs that never started)."""
    return Track(role=actor.role, x=np.full(n, actor.x), y=np.full(n, actor.y), yaw=np.full(n, actor.yaw),
                 speed=np.zeros(n))


def failed_run(scene: SampledScene, steps: int, reason: str) -> SceneRun:
    """An invalid variation: every actor held at its sampled pose, flagged with `reason`."""
    return SceneRun({a.role: still_track(a, steps + 1) for a in scene.actors}, invalid_reason=reason)


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
               run_scene: Callable[[SimulationRequest, SampledScene], SceneRun]) -> BatchResult:
    """Run every scene of a request one by one (`run_scene` fills the state protocol) and record the tables."""
    start = time.perf_counter()
    scenes = list(request.scenes)
    runs = []
    for scene in scenes:
        runs.append(run_scene(request, scene))
        if request.progress is not None:
            request.progress(1)
    tables = record_tables(request.scenario, scenes, runs, settings, request.map_file)
    return BatchResult(backend=backend, tables=tables, seconds=time.perf_counter() - start)


def record_tables(scenario, scenes: Sequence[SampledScene], runs: Sequence[SceneRun], settings,
                  map_file) -> dict[str, pa.Table]:
    """The four tables of `crashscene.traces` for runs of any backend, every column filled.

    The scenes get the embedded backend's batch set-up (its routes from each
    actor's start lane and intent, junction entries, traffic control from the
    DSL, signal phase plans from (seed, variation)), the Scenic tracks are
    projected onto those routes step by step, and the embedded `Recorder`
    derives every map column. So a trace means the same whichever backend
    produced it; a backend whose vehicles ignore traffic lights (Scenic's) does
    not react to the signal states recorded for them.
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
        if run.invalid_reason is not None:  # the backend's failure is the first thing to fix
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


# ---------------------------------------------------------------- raw scene results (`Simulator.simulate_scene`)

def run_from_columns(scene: SampledScene, traces: dict[str, Sequence], valid: bool, invalid_reason: str | None,
                     collisions: Sequence[dict], steps: int, dt: float) -> SceneRun | None:
    """A `SceneRun` from raw trace columns holding every actor's x and y at every step, else None.

    yaw and speed come from the columns when given, else from the motion (the
    sampled pose and speed at step 0); contact rows gain their step from t.
    """
    if any(traces.get(name) is None for name in ("actor", "step", "x", "y")):
        return None
    roles = list(traces["actor"])
    step_of = np.asarray(traces["step"], dtype=np.int64)
    n = steps + 1
    tracks = {}
    for actor in scene.actors:
        rows = np.array([i for i, role in enumerate(roles) if role == actor.role], dtype=np.int64)
        if len(rows) != n or sorted(step_of[rows].tolist()) != list(range(n)):
            return None
        rows = rows[np.argsort(step_of[rows])]

        def column(name: str) -> np.ndarray | None:
            values = traces.get(name)
            return None if values is None else np.asarray(values, dtype=float)[rows]

        x, y, yaw, speed = column("x"), column("y"), column("yaw"), column("speed")
        dx, dy = np.diff(x, prepend=x[0]), np.diff(y, prepend=y[0])
        moved = np.hypot(dx, dy)
        if yaw is None:
            heading = np.where(moved > 1e-6, np.arctan2(dy, dx), np.nan)
            heading[0] = actor.yaw
            yaw = _hold(heading)
        if speed is None:
            speed = moved / dt
            speed[0] = actor.speed
        tracks[actor.role] = Track(actor.role, x, y, yaw, speed)
    contacts = [{**row, "step": int(round(row["t"] / dt))} for row in collisions]
    return SceneRun(tracks, invalid_reason=None if valid else (invalid_reason or "invalid"), contacts=contacts)


def _hold(values: np.ndarray) -> np.ndarray:
    """NaN entries replaced by the last finite one before them."""
    idx = np.where(np.isfinite(values), np.arange(len(values)), 0)
    return values[np.maximum.accumulate(idx)]


def record_scene_results(request: SimulationRequest, results: Sequence, settings) -> dict[str, pa.Table]:
    """The four tables from `simulate_scene` results: their pose through the recorder (every column filled)
    and the columns they give kept over the derived ones; results without a complete pose (x, y of every actor
    at every step) keep only what they give."""
    from crashscene.simulate.tables import assemble_scene_results

    scenes = list(request.scenes)
    runs = [run_from_columns(scene, r.traces, r.valid, r.invalid_reason, r.collisions, settings.steps, settings.dt)
            for scene, r in zip(scenes, results)]
    if not scenes or any(run is None for run in runs):
        return assemble_scene_results(scenes, results, settings)
    tables = record_tables(request.scenario, scenes, runs, settings, request.map_file)
    tables["traces"] = _overlay(tables["traces"], scenes, results)
    return tables


def _overlay(traces: pa.Table, scenes: Sequence[SampledScene], results: Sequence) -> pa.Table:
    """`traces` with the columns a backend gave written over the recorder's, row by (variation, actor, step)."""
    row_of = {key: i for i, key in enumerate(zip(traces.column("variation").to_pylist(),
                                                 traces.column("actor").to_pylist(),
                                                 traces.column("step").to_pylist()))}
    columns = {name: traces.column(name).to_pylist() for name in traces.column_names}
    for scene, result in zip(scenes, results):
        given = {name: list(values) for name, values in result.traces.items()
                 if values is not None and name not in ("variation", "actor", "step")}
        for k, key in enumerate(zip(result.traces["actor"], result.traces["step"])):
            at = row_of[(scene.index, key[0], int(key[1]))]
            for name, values in given.items():
                value = values[k]
                columns[name][at] = value.item() if isinstance(value, np.generic) else value
    return pa.table(columns, schema=traces.schema)
