"""Turning a Scenic simulation (Newtonian, CARLA) into the trace columns of `crashscene.traces`.

Scenic keeps only positions in `result.trajectory`. `StateRecorder` is a mixin
for any Scenic `Simulation` class whose `currentState()` records, per object and
step, the centre, heading and speed; `tracks_from_trajectory` turns that into
per-actor arrays, `find_contacts` detects footprint overlap (Scenic's
simulators do not), and `scene_traces` lays out the TRACE_SCHEMA columns,
map-derived ones (lane, junction, stop line...) included, through the embedded
backend's road lookups so every backend describes the map the same way.

Angles: Scenic heading is 0 = +y, counter-clockwise; crashscene yaw is
0 = +x (OpenDRIVE), so yaw = heading + pi/2, wrapped to (-pi, pi].
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import SimulationError

SCENIC_TO_YAW = math.pi / 2  # [rad] yaw = Scenic heading + pi/2


def wrap_angle(angle: np.ndarray | float) -> np.ndarray | float:
    """Wrap [rad] to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(angle), 2 * np.pi)


def yaw_from_heading(heading: np.ndarray | float) -> np.ndarray | float:
    """Scenic heading [rad] (0 = +y) -> crashscene yaw [rad] (0 = +x), wrapped to (-pi, pi]."""
    return wrap_angle(np.asarray(heading) + SCENIC_TO_YAW)


class StateRecorder:
    """Mixin for a Scenic `Simulation` subclass: record (x, y, heading, speed) of every object each step.

    Put it first in the bases (`class T(StateRecorder, NewtonianSimulation)`) so
    this `currentState` wins; Scenic stores its return value in
    `simulation.result.trajectory`, one entry per step (the initial state included).
    """

    def currentState(self):  # noqa: N802 (Scenic's hook name)
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

    Rendered programs tag each object with a `role` property; objects without
    it (hand-written Scenic) are matched to the scene's actors in order, the
    ego object first, as Scenic lists them.
    """
    roles = [getattr(obj, "role", None) for obj in objects]
    known = {actor.role for actor in scene.actors}
    if all(isinstance(role, str) and role in known for role in roles):
        return roles
    if len(objects) != len(scene.actors):
        raise SimulationError(f"variation {scene.index}: the Scenic scene has {len(objects)} objects but the "
                              f"sampled scene has {len(scene.actors)} actors "
                              f"({', '.join(a.role for a in scene.actors)}); tag each object with `role`")
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

def footprint_corners(x, y, yaw, length: float, width: float) -> np.ndarray:
    """Corners [m] of oriented rectangles centred at (x, y): shape (..., 4, 2), counter-clockwise."""
    x, y, yaw = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(yaw, float))
    c, s = np.cos(yaw), np.sin(yaw)
    hl, hw = length / 2, width / 2
    local = np.array([(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)])  # front-left first
    cx = x[..., None] + local[:, 0] * c[..., None] - local[:, 1] * s[..., None]
    cy = y[..., None] + local[:, 0] * s[..., None] + local[:, 1] * c[..., None]
    return np.stack([cx, cy], axis=-1)


def footprints_overlap(a: Track | tuple, size_a: tuple[float, float], b: Track | tuple,
                       size_b: tuple[float, float]) -> np.ndarray:
    """Separating-axis test of two oriented rectangles at every step: bool array, True = overlap.

    `a`/`b` are Tracks or (x, y, yaw) tuples of arrays; sizes are (length, width) [m].
    """
    xa, ya, ta = (a.x, a.y, a.yaw) if isinstance(a, Track) else a
    xb, yb, tb = (b.x, b.y, b.yaw) if isinstance(b, Track) else b
    dx, dy = np.asarray(xb) - np.asarray(xa), np.asarray(yb) - np.asarray(ya)
    (la, wa), (lb, wb) = size_a, size_b
    separated = np.zeros(np.broadcast(dx, np.asarray(ta), np.asarray(tb)).shape, dtype=bool)
    axes = [(np.cos(ta), np.sin(ta)), (-np.sin(ta), np.cos(ta)), (np.cos(tb), np.sin(tb)), (-np.sin(tb), np.cos(tb))]
    for ux, uy in axes:
        # half extent of each rectangle projected on the axis
        ra = la / 2 * np.abs(np.cos(ta) * ux + np.sin(ta) * uy) + wa / 2 * np.abs(-np.sin(ta) * ux + np.cos(ta) * uy)
        rb = lb / 2 * np.abs(np.cos(tb) * ux + np.sin(tb) * uy) + wb / 2 * np.abs(-np.sin(tb) * ux + np.cos(tb) * uy)
        separated |= np.abs(dx * ux + dy * uy) > ra + rb
    return ~separated


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
    """First contact of every actor pair, as COLLISION_SCHEMA rows (without `variation`), ordered by time."""
    rows = []
    roles = list(tracks)
    for i, role_a in enumerate(roles):
        for role_b in roles[i + 1:]:
            a, b = tracks[role_a], tracks[role_b]
            hits = np.flatnonzero(footprints_overlap(a, sizes[role_a], b, sizes[role_b]))
            if hits.size == 0:
                continue
            k = int(hits[0])
            x, y = contact_point(a, sizes[role_a], b, sizes[role_b], k)
            rows.append({"t": round(k * dt, 9), "actor_a": role_a, "actor_b": role_b,
                         "speed_a": float(a.speed[k]), "speed_b": float(b.speed[k]),
                         "yaw_a": float(a.yaw[k]), "yaw_b": float(b.yaw[k]), "x": x, "y": y})
    rows.sort(key=lambda row: (row["t"], row["actor_a"], row["actor_b"]))
    return rows


# ---------------------------------------------------------------- kinematic columns

def longitudinal_accel(speed: np.ndarray, dt: float) -> np.ndarray:
    """[m/s2] acceleration applied over each step (forward difference; the last step repeats the previous)."""
    if speed.size < 2:
        return np.zeros_like(speed)
    accel = np.diff(speed) / dt
    return np.append(accel, accel[-1])


def lateral_accel(speed: np.ndarray, yaw: np.ndarray, dt: float) -> np.ndarray:
    """[m/s2] speed x yaw rate, the yaw rate by forward difference of the unwrapped yaw."""
    if yaw.size < 2:
        return np.zeros_like(yaw)
    rate = np.diff(np.unwrap(yaw)) / dt
    rate = np.append(rate, rate[-1])
    return speed * rate


def still_track(actor: SampledActor, n: int) -> Track:
    """A track holding the actor at its sampled pose, at rest, for `n` steps (for runs that never started)."""
    return Track(role=actor.role, x=np.full(n, actor.x), y=np.full(n, actor.y), yaw=np.full(n, actor.yaw),
                 speed=np.zeros(n))


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


# ---------------------------------------------------------------- one scene's trace columns

def scene_result(scene: SampledScene, tracks: dict[str, Track], dt: float, map_file=None):
    """A `SceneResult` (trace columns + collisions) for one simulated scene, actors in the scene's order.

    Kinematic columns come from the tracks; map columns (lane, junction, signal,
    stop line...) from the embedded backend's road lookups on `map_file` when
    given, else they stay null/NaN (the monitor marks the rules needing them
    not_applicable).
    """
    from crashscene.simulate.backend import SceneResult

    actors: list[SampledActor] = list(scene.actors)
    steps = next(iter(tracks.values())).x.size if tracks else 0
    columns: dict[str, list | np.ndarray] = {}
    parts: dict[str, list[np.ndarray]] = {name: [] for name in
                                          ("actor", "step", "t", "x", "y", "yaw", "speed", "accel", "lat_accel")}
    for actor in actors:
        track = tracks[actor.role]
        parts["actor"].append(np.full(steps, actor.role, dtype=object))
        parts["step"].append(np.arange(steps, dtype=np.int32))
        parts["t"].append(np.round(np.arange(steps) * dt, 9))
        parts["x"].append(track.x)
        parts["y"].append(track.y)
        parts["yaw"].append(track.yaw)
        parts["speed"].append(track.speed)
        parts["accel"].append(longitudinal_accel(track.speed, dt))
        parts["lat_accel"].append(lateral_accel(track.speed, track.yaw, dt))
    for name, chunks in parts.items():
        columns[name] = np.concatenate(chunks) if chunks else np.array([])
    columns["actor"] = list(columns["actor"])
    if map_file is not None and actors:
        columns.update(map_columns(scene, tracks, dt, map_file))
    sizes = {actor.role: (actor.length, actor.width) for actor in actors}
    collisions = find_contacts({a.role: tracks[a.role] for a in actors}, sizes, dt)
    return SceneResult(traces=columns, collisions=collisions)


def map_columns(scene: SampledScene, tracks: dict[str, Track], dt: float, map_file) -> dict[str, list]:
    """Map-derived TRACE_SCHEMA columns for the tracks, actors in the scene's order (see module doc)."""
    return {}
