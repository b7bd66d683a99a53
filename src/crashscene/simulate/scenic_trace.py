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


ROUTE_INTENTS = ("straight", "left", "right", "u_turn")  # intents RoadMap.route turns at junctions
LOST_GRIP = 0.8 * 9.81  # [m/s2] lateral acceleration beyond dry-road friction: the actor is skidding
LANE_CHANGE_RATE = 0.3  # [m/s] lateral speed across the lane above which an actor counts as changing lanes
# render's `controlled_by` (the DSL sign on the actor's approach) -> traces.CONTROLS
CONTROL_OF_DEVICE = {"traffic_light": "signal", "stop_sign": "stop", "yield_sign": "yield"}


def map_columns(scene: SampledScene, tracks: dict[str, Track], dt: float, map_file) -> dict[str, list]:
    """Map-derived TRACE_SCHEMA columns for the tracks, actors in the scene's order (see module doc).

    Uses the embedded backend's `RoadMap` (lane/junction raster, routes in (s, d)),
    so lane ids, stations and junction entries mean the same in every backend.
    Each actor's route starts at the start of its sampled lane and takes its
    route intent at the first junction, as the embedded backend's routes do.
    """
    from crashscene.simulate.roads import RoadMap

    road_map = RoadMap.load(map_file)
    out: dict[str, list] = {name: [] for name in (
        "lane_id", "route_s", "opposing_lane", "off_road", "centerline_marker", "centerline_intrusion",
        "in_junction", "junction_id", "maneuver", "control", "signal", "stop_line_dist", "speed_limit",
        "lane_change", "target_lane_id", "lost_control")}
    for actor in scene.actors:
        for name, values in _actor_map_columns(road_map, actor, tracks[actor.role], dt).items():
            out[name].extend(values)
    return out


def _actor_map_columns(road_map, actor: SampledActor, track: Track, dt: float) -> dict[str, list]:
    from crashscene.simulate.roads import STOP_LINE_SETBACK

    n = track.x.size
    lane_idx, junction_idx = road_map.lookup(track.x, track.y)
    lanes = road_map.lanes
    in_junction = junction_idx >= 0
    lane_yaw = np.full(n, np.nan)
    for k in np.unique(lane_idx[lane_idx >= 0]):
        mask = lane_idx == k
        lane_yaw[mask] = _polyline_heading(lanes[k].points, track.x[mask], track.y[mask])
    on_lane = lane_idx >= 0
    rel = wrap_angle(track.yaw - np.where(on_lane, lane_yaw, track.yaw))
    opposing = on_lane & ~in_junction & (np.cos(rel) < 0)
    lateral_speed = track.speed * np.sin(rel)
    changing = on_lane & ~in_junction & ~opposing & (np.abs(lateral_speed) > LANE_CHANGE_RATE)
    target = [None] * n
    for k in np.flatnonzero(changing):
        lane = lanes[lane_idx[k]]
        target[k] = lane.left if lateral_speed[k] > 0 else lane.right
    route = _actor_route(road_map, actor)
    columns: dict[str, list] = {
        "lane_id": [lanes[k].uid if k >= 0 else None for k in lane_idx],
        "opposing_lane": opposing.tolist(),
        "off_road": (~on_lane & ~in_junction).tolist(),
        "in_junction": in_junction.tolist(),
        "speed_limit": [lanes[k].speed_limit if k >= 0 else math.nan for k in lane_idx],
        "lane_change": [bool(c and t is not None) for c, t in zip(changing, target)],
        "target_lane_id": [t if c else None for c, t in zip(changing, target)],
        "lost_control": (np.abs(lateral_accel(track.speed, track.yaw, dt)) > LOST_GRIP).tolist(),
    }
    junction_uid = [road_map.junctions[j].uid if j >= 0 else None for j in junction_idx]
    if route is None:  # no lane to start from (off the map): nothing along a route is known
        columns.update({"route_s": [math.nan] * n, "centerline_marker": [None] * n,
                        "centerline_intrusion": [math.nan] * n, "junction_id": junction_uid,
                        "maneuver": ["none"] * n, "control": ["none"] * n, "signal": ["none"] * n,
                        "stop_line_dist": [math.nan] * n})
        return columns
    s, d, k = project_track(route.xy, track.x, track.y)
    route_lane = route.lane[k]
    columns["route_s"] = s.tolist()
    columns["centerline_marker"] = [lanes[i].marker if i >= 0 else None for i in route_lane]
    rel_route = wrap_angle(track.yaw - route.yaw[k])
    reach = actor.length / 2 * np.abs(np.sin(rel_route)) + actor.width / 2 * np.abs(np.cos(rel_route))
    columns["centerline_intrusion"] = (d + reach - route.centerline_offset[k]).tolist()  # NaN on one-way roads
    maneuver, control, stop_dist, approaching = ["none"] * n, ["none"] * n, [math.nan] * n, [None] * n
    exits = [_junction_exit(route, entry.s) for entry in route.entries]
    # the DSL's sign governs the approach to the scenario's junction, the first on the route
    first_control = CONTROL_OF_DEVICE.get(str(actor.properties.get("controlled_by")), "none")
    front = s + actor.length / 2
    for step in range(n):
        for number, (entry, exit_s) in enumerate(zip(route.entries, exits)):
            if s[step] - actor.length / 2 < exit_s:  # not yet clear of this junction
                maneuver[step] = entry.maneuver
                approaching[step] = road_map.junctions[entry.junction].uid
                control[step] = first_control if number == 0 else "none"
                if control[step] != "none":  # a stop line only where a device governs the approach
                    stop_dist[step] = float(entry.s - STOP_LINE_SETBACK - front[step])
                break
    columns["maneuver"] = maneuver
    columns["control"] = control
    # Scenic's simulators have no signal states: unknown (null) on signalised approaches
    columns["signal"] = [None if c == "signal" else "none" for c in control]
    columns["junction_id"] = [j if j is not None else a for j, a in zip(junction_uid, approaching)]
    columns["stop_line_dist"] = stop_dist
    return columns


def _actor_route(road_map, actor: SampledActor):
    """The embedded backend's route for the actor: from its sampled lane, its intent at the first junction."""
    lane_uid = actor.lane_id if actor.lane_id in road_map.by_uid else None
    if lane_uid is None:
        lane = road_map.lane_at(actor.x, actor.y, actor.yaw)
        if lane is None:
            return None
        lane_uid = lane.uid
    intent = actor.route_intent if actor.route_intent in ROUTE_INTENTS else "straight"
    return road_map.route(lane_uid, intent)


def _junction_exit(route, entry_s: float) -> float:
    """[m] station where the route leaves the junction it enters at `entry_s`."""
    from crashscene.simulate.roads import ROUTE_DS

    k = int(round(entry_s / ROUTE_DS))
    inside = np.flatnonzero(route.junction[k:] >= 0)
    if inside.size == 0:
        return float(entry_s)
    after = np.flatnonzero(route.junction[k + inside[0]:] < 0)
    last = k + inside[0] + (after[0] if after.size else route.junction.size - k - inside[0])
    return float(last * ROUTE_DS)


def _polyline_heading(points: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """[rad] heading of the polyline segment nearest to each point."""
    a, b = points[:-1], points[1:]
    seg = b - a
    rel = np.stack([x, y], axis=-1)[:, None, :] - a[None, :, :]
    u = np.clip(np.einsum("tkj,kj->tk", rel, seg) / np.maximum(np.einsum("kj,kj->k", seg, seg), 1e-12), 0, 1)
    foot = a[None] + seg[None] * u[..., None]
    k = np.argmin(np.hypot(*(np.stack([x, y], axis=-1)[:, None, :] - foot).transpose(2, 0, 1)), axis=1)
    return np.arctan2(seg[k, 1], seg[k, 0])


def project_track(route_xy: np.ndarray, x: np.ndarray, y: np.ndarray, window: float = 15.0):
    """Station s [m], lateral offset d [m] (left positive) and nearest route-sample index of each track point.

    Follows the track along the route: each step searches only near the previous
    station (within `window` [m] plus the distance moved), so a route that folds
    back on itself (a U-turn) does not make the station jump.
    """
    from crashscene.simulate.roads import ROUTE_DS

    a, seg = route_xy[:-1], np.diff(route_xy, axis=0)
    seg_len2 = np.maximum(np.einsum("ij,ij->i", seg, seg), 1e-12)
    n = x.size
    s, d, nearest = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    lo, hi = 0, len(seg)
    for step in range(n):
        if step:
            moved = math.hypot(x[step] - x[step - 1], y[step] - y[step - 1])
            reach = int((window + moved) / ROUTE_DS)
            centre = int(s[step - 1] / ROUTE_DS)
            lo, hi = max(0, centre - reach), min(len(seg), centre + reach + 1)
        rel = np.array([x[step], y[step]]) - a[lo:hi]
        u = np.clip(np.einsum("ij,ij->i", rel, seg[lo:hi]) / seg_len2[lo:hi], 0.0, 1.0)
        off = rel - seg[lo:hi] * u[:, None]
        dist = np.hypot(off[:, 0], off[:, 1])
        j = int(np.argmin(dist))
        cross = seg[lo + j, 0] * rel[j, 1] - seg[lo + j, 1] * rel[j, 0]
        s[step] = (lo + j + u[j]) * ROUTE_DS
        d[step] = math.copysign(dist[j], cross) if cross else 0.0
        nearest[step] = min(lo + j + int(round(u[j])), len(route_xy) - 1)
    return s, d, nearest
