"""Setting up one embedded batch: routes, traffic control, priorities, signal phases and timing plans.

Everything here is computed once per batch from the sampled scenes, before the
step loop. Per-variation random draws come from a generator seeded by
(seed, variation index) only, so a variation's plan never depends on which
chunk of a campaign it is simulated in.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely

from crashscene.dsl import Scenario
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import SimulationError, SimulationSettings
from crashscene.simulate.drivers.behaviors import SPEEDING_CODES, speed_factor
from crashscene.simulate.embedded import signals, timing
from crashscene.simulate.embedded.vehicles import VehicleLimits, limits_for
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS, Lane, RoadMap, Route
from crashscene.simulate.tables import driver_dispositions, is_ads

MPH = 0.44704  # [m/s] per mph
LATERAL_BEHAVIORS = ("change_lane_left", "change_lane_right", "cross_centerline", "overtake", "lose_control",
                     "leave_road")
JUNCTION_INTENTS = {"straight": "straight", "left": "left", "right": "right", "u_turn": "u_turn"}
BEHAVIOR_INTENTS = {"turn_left": "left", "turn_right": "right", "u_turn": "u_turn"}
OPPOSITE_HEADINGS = ("opposite_direction",)
ROUTE_SPEED = 40.0  # [m/s] routes are built long enough for this speed over the horizon (or to the map's end)
OFF_ROAD_MARGIN = 2.5  # [m] a vehicle leaving the road drifts this far past the edge of the lanes
STOP_APPROACH_DECEL = 2.5  # [m/s2] a driver approaching a stop sign is slowing down at most this hard
ADVANCE_MARGIN = 3.0  # [m] an actor advanced by its timing plan stays this far before its junction entry


def variation_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of variation `index` of a batch seeded `seed` (independent of the chunking)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed) & 0xFFFFFFFF, int(index), 0x5EED]))


@dataclass
class ActorColumn:
    """What is common to one actor role across the batch."""

    role: str
    behavior: str
    actor_type: str
    is_ads: bool
    dispositions: frozenset[str]
    limits: VehicleLimits


@dataclass
class BatchSetup:
    """Arrays of shape (V, A) unless noted, V variations x A actors."""

    scenario: Scenario
    settings: SimulationSettings
    roadmap: RoadMap
    scenes: list[SampledScene]
    columns: list[ActorColumn]
    anchor: int  # actor column of the ADS under test (or the ego role in reproduce mode)
    routes: RouteArrays
    route: np.ndarray  # (V, A) route index
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray  # [m/s] initial
    cruise: np.ndarray  # [m/s] desired (after timing scale)
    length: np.ndarray
    width: np.ndarray
    s0: np.ndarray
    d0: np.ndarray
    lane_width: np.ndarray
    entry_control: np.ndarray  # (V, A, J) CONTROL code of each junction entry on each actor's route
    entry_group: np.ndarray  # (V, A, J) signal group (0 anchor axis, 1 cross axis)
    priority: np.ndarray  # (V, A, A) bool: a must yield to b
    phase: np.ndarray  # (V,) [s] signal phase
    hold_until: np.ndarray
    trigger_time: np.ndarray
    lateral_target: np.ndarray
    condition_factor: float  # [-] safe speed / posted limit for the weather, surface and light
    friction: float  # [-] tyre-road friction coefficient
    invalid: list[str | None]  # per variation, the first reason found at setup
    conflict_time: np.ndarray  # (V,) [s] the anchor's nominal arrival at its first conflict point, inf if none
    default_speed_limit: float  # [m/s] DSL posted limit, NaN if none
    lane_width_table: np.ndarray  # (n_lanes,) [m]
    lane_road: np.ndarray  # (n_lanes,) road ordinal
    lane_forward: np.ndarray  # (n_lanes,) bool
    lane_marker: np.ndarray  # (n_lanes,) marker ordinal
    notes: list[str] = field(default_factory=list)

    @property
    def lateral_rate(self) -> np.ndarray:
        """(A,) [m/s] how fast each actor's lateral reference moves toward its commanded offset."""
        return np.array([timing.lateral_rate(c.behavior) if not c.is_ads else timing.LATERAL_RATE
                         for c in self.columns])

    @property
    def n_variations(self) -> int:
        return self.x.shape[0]

    @property
    def n_actors(self) -> int:
        return self.x.shape[1]


def build(scenario: Scenario, scenes: list[SampledScene], roadmap: RoadMap,
          settings: SimulationSettings) -> BatchSetup:
    """Everything the step loop needs, for these scenes."""
    if not scenes:
        raise SimulationError("no scenes to simulate")
    roles = [a.role for a in scenes[0].actors]
    for scene in scenes:
        if [a.role for a in scene.actors] != roles:
            raise SimulationError(f"scene {scene.index}: actors {[a.role for a in scene.actors]} differ from "
                                  f"scene {scenes[0].index}'s {roles}; a batch needs the same actors in every scene")
    anchor_role = settings.ego_role if settings.ego_role in roles else roles[0]
    anchor = roles.index(anchor_role)
    first = scenes[0].actors
    columns = [ActorColumn(a.role, a.behavior, a.type, is_ads(a.role, settings),
                           frozenset(driver_dispositions(a, settings)), limits_for(a.type)) for a in first]
    n_v, n_a = len(scenes), len(roles)

    def grid(attr: str) -> np.ndarray:
        return np.array([[getattr(a, attr) for a in scene.actors] for scene in scenes], dtype=float)

    x, y, yaw, speed = grid("x"), grid("y"), grid("yaw"), grid("speed")
    length, width = grid("length"), grid("width")
    invalid: list[str | None] = [None] * n_v
    # fixed by the settings, never by the batch, so that a variation's routes do not depend on its chunk
    min_length = 100.0 * math.ceil((ROUTE_SPEED * settings.horizon + 60.0) / 100.0)

    # ---- routes: one per distinct (start lane, junction intent), plus synthetic ones for off-road starts
    route_index: dict[tuple, int] = {}
    routes: list[Route] = []
    route = np.zeros((n_v, n_a), dtype=np.int64)
    lateral_target = np.zeros((n_v, n_a))
    lane_cache: dict[tuple, Lane | None] = {}
    road_edge = np.full((n_v, n_a), np.nan)  # [m] signed offset of the road edge a leave_road actor drifts over
    for v, scene in enumerate(scenes):
        for a, actor in enumerate(scene.actors):
            lane = _start_lane(roadmap, actor, lane_cache)
            if lane is None:
                invalid[v] = invalid[v] or f"{actor.role} starts off the road network"
                key = ("synthetic", round(actor.x, 1), round(actor.y, 1), round(actor.yaw, 3))
                if key not in route_index:
                    route_index[key] = len(routes)
                    routes.append(_straight_route(key, actor, min_length))
                route[v, a] = route_index[key]
                continue
            route_lane, target = _route_lane(roadmap, lane, actor)
            lateral_target[v, a] = target
            if actor.behavior == "leave_road":
                road_edge[v, a] = _road_edge_offset(roadmap, lane, scenario)
            intent = _junction_intent(actor)
            key = (route_lane.uid, intent, min_length)
            if key not in route_index:
                route_index[key] = len(routes)
                routes.append(roadmap.route(route_lane.uid, intent, min_length))
            route[v, a] = route_index[key]
    arrays = RouteArrays.pack(routes)

    s0 = np.zeros((n_v, n_a))
    d0 = np.zeros((n_v, n_a))
    for r, rt in enumerate(routes):
        mask = route == r
        if mask.any():
            s0[mask], d0[mask] = _project_many(rt, x[mask], y[mask])

    lane_width_table = np.array([lane.width for lane in roadmap.lanes])
    start_lane_idx = arrays.lane[route, np.clip((s0 / ROUTE_DS).astype(int), 0, arrays.lane.shape[1] - 1)]
    lane_width = np.where(start_lane_idx >= 0, lane_width_table[np.maximum(start_lane_idx, 0)], 3.5)
    co = arrays.sample(arrays.centerline_offset, route, s0)
    for a, col in enumerate(columns):
        if col.behavior == "leave_road":
            edge = np.where(np.isnan(road_edge[:, a]), -lane_width[:, a] / 2.0, road_edge[:, a])
            lateral_target[:, a] = edge + np.sign(edge) * OFF_ROAD_MARGIN
            continue
        lateral_target[:, a] = _lateral_target(col.behavior, lateral_target[:, a], co[:, a], lane_width[:, a],
                                               d0[:, a])

    # ---- traffic control per junction entry, from the DSL
    # each variation's control tables come from its own layout (never from another scene of the chunk)
    tables = _control_tables(scenario, scenes, arrays, route, s0, anchor)
    vidx = np.arange(n_v)[:, None]
    entry_control = np.stack([t[0] for t in tables])[vidx, route]  # (V, A, J)
    entry_group = np.stack([t[1] for t in tables])[vidx, route]
    priority = _priorities(arrays, route, tables)

    # ---- timing plans and signal phases, per variation from its own generator
    hold = np.zeros((n_v, n_a))
    trigger = np.full((n_v, n_a), np.inf)
    scale = np.ones((n_v, n_a))
    phase = np.zeros(n_v)
    conflict_time = np.full(n_v, np.inf)
    planned = np.zeros((n_v, n_a))
    moved = np.zeros((n_v, n_a), dtype=bool)
    start_cap = np.full((n_v, n_a), np.inf)  # [m/s] highest initial speed (curve right ahead)
    drifted = np.zeros((n_v, n_a))  # [m] lateral head start of a swerve that began before t = 0
    runs_red = "CVC_21453" in columns[anchor].dispositions
    for v, scene in enumerate(scenes):
        rng = variation_rng(scene.seed, scene.index)
        _plan_variation(v, scene, rng, columns, anchor, arrays, route, s0, d0, speed, length, tables[v][0],
                        lateral_target, hold, trigger, scale, phase, conflict_time, runs_red,
                        condition_factor(scenario), _mph(scenario.road_network.speed_limit_mph), planned, moved,
                        settings.mode == "reproduce", drifted)
    if drifted.any():
        vv, aa = np.nonzero(drifted)
        _, _, ryaw = arrays.point(route[vv, aa], s0[vv, aa])
        x[vv, aa] -= np.sin(ryaw) * drifted[vv, aa]
        y[vv, aa] += np.cos(ryaw) * drifted[vv, aa]
    if moved.any():
        # actors advanced along their approach by the timing plan start on their lane centre there
        vv, aa = np.nonzero(moved)
        x[vv, aa], y[vv, aa], yaw[vv, aa] = arrays.point(route[vv, aa], s0[vv, aa])
        d0[vv, aa] = 0.0
        # ...at a speed from which it can still take the curve ahead
        reach = np.full(len(vv), 60.0)
        entry_speed = arrays.curve_speed(route[vv, aa], s0[vv, aa], reach, 2.5, 2.0)
        start_cap[vv, aa] = np.maximum(entry_speed, 3.0)
    # the cruise speed the driver holds is the planned one (capped at the limit unless speeding) times the
    # timing scale; it starts at that speed (slower when the plan slows it) unless held at its start
    cruise = planned * scale
    speed0 = np.where(hold > 0, 0.0, np.minimum(planned * np.minimum(scale, 1.0), start_cap))
    # a driver who will stop at a stop sign close ahead is already slowing down for it
    for a, col in enumerate(columns):
        for v in range(n_v):
            stop = _stop_dist(arrays, route[v, a], s0[v, a], tables[v][0], col)
            if stop is not None:
                speed0[v, a] = min(speed0[v, a], math.sqrt(2.0 * STOP_APPROACH_DECEL * max(stop - 1.0, 0.0)))
    limit = scenario.road_network.speed_limit_mph
    road_names = sorted({lane.road for lane in roadmap.lanes})
    from crashscene.simulate.roads import MARKERS

    return BatchSetup(
        scenario=scenario, settings=settings, roadmap=roadmap, scenes=scenes, columns=columns, anchor=anchor,
        routes=arrays, route=route, x=x, y=y, yaw=yaw, speed=speed0, cruise=cruise, length=length, width=width,
        s0=s0, d0=d0, lane_width=lane_width, entry_control=entry_control, entry_group=entry_group,
        priority=priority, phase=phase, hold_until=hold, trigger_time=trigger, lateral_target=lateral_target,
        condition_factor=condition_factor(scenario), friction=friction(scenario),
        invalid=invalid, conflict_time=conflict_time, default_speed_limit=limit * MPH if limit else math.nan,
        lane_width_table=lane_width_table,
        lane_road=np.array([road_names.index(lane.road) for lane in roadmap.lanes]),
        lane_forward=np.array([lane.forward for lane in roadmap.lanes]),
        lane_marker=np.array([MARKERS.index(lane.marker) for lane in roadmap.lanes]),
    )


# ------------------------------------------------------------------ routes
def _start_lane(roadmap: RoadMap, actor: SampledActor, cache: dict) -> Lane | None:
    if actor.lane_id and actor.lane_id in roadmap.by_uid:
        lane = roadmap.by_uid[actor.lane_id]
        if _heading_agrees(lane, actor):
            return lane
    lane_idx, _ = roadmap.lookup(np.array([actor.x]), np.array([actor.y]))
    if lane_idx[0] >= 0:
        lane = roadmap.lanes[int(lane_idx[0])]
        if _heading_agrees(lane, actor):
            return lane
    key = (round(actor.x, 1), round(actor.y, 1), round(actor.yaw, 2))
    if key not in cache:
        lane = roadmap.lane_at(actor.x, actor.y, actor.yaw)
        cache[key] = lane if lane is not None and _heading_agrees(lane, actor, tolerance=-0.2) else None
    return cache[key]


def _heading_agrees(lane: Lane, actor: SampledActor, tolerance: float = 0.5) -> bool:
    pts = lane.points
    k = int(np.argmin(np.hypot(pts[:, 0] - actor.x, pts[:, 1] - actor.y)))
    k2 = min(k + 1, len(pts) - 1)
    k1 = k2 - 1
    heading = math.atan2(pts[k2, 1] - pts[k1, 1], pts[k2, 0] - pts[k1, 0])
    return math.cos(heading - actor.yaw) > tolerance


def _junction_intent(actor: SampledActor) -> str:
    if actor.route_intent in JUNCTION_INTENTS:
        return JUNCTION_INTENTS[actor.route_intent]
    return BEHAVIOR_INTENTS.get(actor.behavior, "straight")


def _route_lane(roadmap: RoadMap, lane: Lane, actor: SampledActor) -> tuple[Lane, float]:
    """The lane the route follows and the lateral target on it [m] (lane changes follow the target lane)."""
    change = actor.route_intent if actor.route_intent.startswith("lane_change") else None
    if change is None and actor.behavior in ("change_lane_left", "change_lane_right"):
        change = "lane_change_" + actor.behavior.rsplit("_", 1)[1]
    if change == "lane_change_left":
        if lane.left:
            return roadmap.by_uid[lane.left], 0.0
        return lane, math.nan  # no lane to the left: the change crosses the centre line (set later)
    if change == "lane_change_right":
        if lane.right:
            return roadmap.by_uid[lane.right], 0.0
        return lane, -lane.width
    return lane, 0.0


def _road_edge_offset(roadmap: RoadMap, lane: Lane, scenario: Scenario) -> float:
    """Signed lateral offset [m] from the lane's centre to the road edge a vehicle leaving the road crosses.

    The right edge, past every same-direction lane to the right; on a one-way roadway the left edge
    instead when it is nearer, or when a right-hand curve throws the vehicle outward to the left
    (a left-hand curve throws it right).
    """
    def count(uid: str | None, side: str) -> int:
        n, seen = 0, set()
        while uid and uid not in seen and uid in roadmap.by_uid:
            seen.add(uid)
            n += 1
            uid = getattr(roadmap.by_uid[uid], side)
        return n

    w = lane.width
    right = -(w / 2.0 + count(lane.right, "right") * w)
    if lane.opposite is not None:
        return right  # two-way: leaving to the left means crossing the oncoming lanes first
    left = w / 2.0 + count(lane.left, "left") * w
    curve = scenario.road_network.curve_direction
    if scenario.road_network.road_type == "curve" and curve is not None:
        return left if str(curve) == "right" else right
    return left if left < -right else right


def _lateral_target(behavior: str, current: np.ndarray, centre_offset: np.ndarray, lane_width: np.ndarray,
                    d0: np.ndarray) -> np.ndarray:
    """Lateral offset [m] a behaviour steers to, on its route."""
    across = np.where(np.isnan(centre_offset), lane_width, 2.0 * centre_offset)
    if behavior in ("cross_centerline", "overtake"):
        return across
    if behavior == "leave_road":
        return -(lane_width / 2.0 + 3.5)
    if behavior in ("change_lane_left", "change_lane_right"):
        return np.where(np.isnan(current), across, current)
    return np.nan_to_num(current)


def _straight_route(key: tuple, actor: SampledActor, length: float) -> Route:
    s = np.arange(0.0, length + 1e-9, ROUTE_DS)
    xy = np.stack([actor.x + s * math.cos(actor.yaw), actor.y + s * math.sin(actor.yaw)], axis=1)
    n = len(s)
    return Route(key, xy, np.full(n, actor.yaw), np.zeros(n), np.full(n, -1, dtype=np.int32),
                 np.full(n, -1, dtype=np.int32), np.full(n, np.nan), np.full(n, np.nan), [])


def _project_many(route: Route, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(s, d) of many points on one route (s along the stitched polyline, d left positive)."""
    # actors start on the route's first lane: project onto that piece only (routes run for hundreds of metres)
    first = np.flatnonzero(route.lane != route.lane[0])
    end = int(first[0]) + 2 if len(first) else len(route.xy)
    line = shapely.LineString(route.xy[:max(end, 2)])
    s = shapely.line_locate_point(line, shapely.points(x, y))
    s = np.minimum(s, route.length)
    k = np.minimum((s / ROUTE_DS).astype(np.int64), len(route.xy) - 2)
    u = s / ROUTE_DS - k
    p0, p1 = route.xy[k], route.xy[k + 1]
    foot = p0 + (p1 - p0) * u[:, None]
    tangent = p1 - p0
    norm = np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-12)
    d = (tangent[:, 0] * (y - foot[:, 1]) - tangent[:, 1] * (x - foot[:, 0])) / norm
    return s, d


# ------------------------------------------------------------------ control and priority
def _entry_controls(scenario: Scenario, scene: SampledScene, arrays: RouteArrays, route0: np.ndarray,
                    s0: np.ndarray, anchor: int) -> tuple[np.ndarray, np.ndarray]:
    """CONTROL code and signal group of every junction entry of every route (from variation 0's layout)."""
    signs = {str(s) for s in scenario.road_network.traffic_signs}
    n_r, n_j = arrays.entry_s.shape
    control = np.zeros((n_r, n_j), dtype=np.int8)
    group = np.zeros((n_r, n_j), dtype=np.int8)

    def first_entry(a: int) -> int | None:
        r = int(route0[a])
        ahead = np.nonzero(arrays.entry_s[r] > s0[a] - 1.0)[0]
        return int(ahead[0]) if len(ahead) else None

    ego_col = next((a for a, act in enumerate(scene.actors) if act.role == "ego"), anchor)
    junctions: set[int] = set()
    roads: dict[str, set[str]] = {"stop_sign": set(), "yield_sign": set()}
    for a, actor in enumerate(scene.actors):
        j = first_entry(a)
        if j is None:
            continue
        r = int(route0[a])
        junctions.add(int(arrays.entry_junction[r, j]))
        if actor.reference in roads:
            roads[actor.reference].add(arrays.entry_road[r][j])
    for sign, controlled in roads.items():
        if sign in signs and not controlled:
            j = first_entry(ego_col)
            if j is not None:
                controlled.add(arrays.entry_road[int(route0[ego_col])][j])
    # the anchor's approach heading at each junction defines signal group 0
    anchor_heading: dict[int, float] = {}
    ra = int(route0[anchor])
    for j in range(n_j):
        if arrays.entry_junction[ra, j] >= 0:
            anchor_heading.setdefault(int(arrays.entry_junction[ra, j]),
                                      _heading_at(arrays, ra, arrays.entry_s[ra, j] - 2.0))
    for r in range(n_r):
        for j in range(n_j):
            junction = int(arrays.entry_junction[r, j])
            if junction < 0 or junction not in junctions:
                continue
            road = arrays.entry_road[r][j]
            if "traffic_light" in signs:
                control[r, j] = 1
            elif road in roads["stop_sign"]:
                control[r, j] = 2
            elif road in roads["yield_sign"]:
                control[r, j] = 3
            heading = _heading_at(arrays, r, arrays.entry_s[r, j] - 2.0)
            ref = anchor_heading.get(junction, heading)
            group[r, j] = 0 if abs(math.cos(heading - ref)) > 0.7 else 1
    return control, group


def _heading_at(arrays: RouteArrays, r: int, s: float) -> float:
    k = int(np.clip(s / ROUTE_DS, 0, arrays.yaw.shape[1] - 1))
    return float(arrays.yaw[r, k])


def _control_tables(scenario: Scenario, scenes: list[SampledScene], arrays: RouteArrays, route: np.ndarray,
                    s0: np.ndarray, anchor: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per variation, the (R, J) control and signal-group tables its own layout implies (memoised by layout)."""
    cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    out = []
    for v, scene in enumerate(scenes):
        firsts = []
        for a in range(route.shape[1]):
            ahead = np.nonzero(arrays.entry_s[route[v, a]] > s0[v, a] - 1.0)[0]
            firsts.append(int(ahead[0]) if len(ahead) else -1)
        key = (tuple(int(r) for r in route[v]), tuple(firsts), tuple(a.reference for a in scene.actors))
        if key not in cache:
            cache[key] = _entry_controls(scenario, scene, arrays, route[v], s0[v], anchor)
        out.append(cache[key])
    return out


def _priorities(arrays: RouteArrays, route: np.ndarray, tables: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """(V, A, A): actor a must yield to actor b at their conflict point."""
    n_v, n_a = route.shape
    cache: dict[tuple[int, int, int], bool] = {}
    out = np.zeros((n_v, n_a, n_a), dtype=bool)
    for v in range(n_v):
        control = tables[v][0]
        for a in range(n_a):
            for b in range(n_a):
                if a == b:
                    continue
                key = (int(route[v, a]), int(route[v, b]), id(control))
                if key not in cache:
                    cache[key] = _must_yield(arrays, key[0], key[1], control)
                out[v, a, b] = cache[key]
    return out


def _must_yield(arrays: RouteArrays, ra: int, rb: int, entry_control: np.ndarray) -> bool:
    cs = arrays.conflict_s[ra, rb]
    if np.isnan(cs):
        return False
    ja = _entry_before(arrays, ra, cs)
    jb = _entry_before(arrays, rb, arrays.conflict_s[rb, ra])
    if ja is None or jb is None:
        return False  # the conflict is not at a junction (merges are handled by the lane-change gap check)
    ca, cb = int(entry_control[ra, ja]), int(entry_control[rb, jb])
    minor_a, minor_b = ca in (2, 3), cb in (2, 3)
    if minor_a != minor_b:
        return minor_a
    ha = _heading_at(arrays, ra, arrays.entry_s[ra, ja] - 2.0)
    hb = _heading_at(arrays, rb, arrays.entry_s[rb, jb] - 2.0)
    rel = math.remainder(hb - ha, 2 * math.pi)
    oncoming = abs(rel) > 2.4
    a_left = arrays.entry_maneuver[ra, ja] in (2, 4)
    b_left = arrays.entry_maneuver[rb, jb] in (2, 4)
    if a_left and oncoming and not b_left:
        return True  # a left turn yields to oncoming traffic
    if ca == 1 and cb == 1:
        return False  # signals separate the other movements
    if oncoming:
        return False
    return rel > 0.6  # b travels to a's left, i.e. comes from a's right: yield to the right


def _entry_before(arrays: RouteArrays, r: int, s: float) -> int | None:
    """The junction entry at or before station s, if s lies within that junction (or just before it)."""
    entries = arrays.entry_s[r]
    idx = np.nonzero(entries <= s + 3.0)[0]
    if len(idx) == 0:
        return None
    j = int(idx[-1])
    k = int(np.clip(s / ROUTE_DS, 0, arrays.junction.shape[1] - 1))
    if arrays.junction[r, k] < 0 and s - entries[j] > 3.0:
        return None
    return j


# ------------------------------------------------------------------ timing
def _plan_variation(v: int, scene: SampledScene, rng: np.random.Generator, columns: list[ActorColumn], anchor: int,
                    arrays: RouteArrays, route: np.ndarray, s0: np.ndarray, d0: np.ndarray, speed: np.ndarray,
                    length: np.ndarray, entry_control: np.ndarray, lateral_target: np.ndarray, hold: np.ndarray,
                    trigger: np.ndarray, scale: np.ndarray, phase: np.ndarray, conflict_time: np.ndarray,
                    runs_red: bool, cond: float, default_limit: float, planned_out: np.ndarray,
                    moved: np.ndarray, reproduce: bool, drifted: np.ndarray) -> None:
    """Fill row v of the timing arrays (draws from rng in a fixed order)."""
    n_a = len(columns)
    planned = [_planned_speed(arrays, route[v, a], s0[v, a], speed[v, a], columns[a], cond, default_limit)
               for a in range(n_a)]
    planned_out[v] = planned
    draws = {"offset": rng.normal(timing.ARRIVAL_OFFSET_MEAN, timing.ARRIVAL_OFFSET_SD, n_a),
             "lead": rng.uniform(0.8, 2.0, n_a), "trigger": rng.uniform(1.0, 4.0, n_a),
             "green": rng.uniform(3.0, 15.0), "spin": rng.choice([-1.0, 1.0], n_a)}
    ra = route[v, anchor]
    va = planned[anchor]
    anchor_col = columns[anchor]
    anchor_stop = _stop_dist(arrays, ra, s0[v, anchor], entry_control, anchor_col)
    arrival_anchor = None
    for a, col in enumerate(columns):
        r = route[v, a]
        params = scene.params
        offset = float(np.clip(draws["offset"][a], -timing.ARRIVAL_OFFSET_MAX, timing.ARRIVAL_OFFSET_MAX))
        offset = _param(params, col.role, ("ARRIVAL_OFFSET",), offset)
        if reproduce:
            offset *= timing.REPRODUCE_OFFSET_SCALE
        if col.is_ads:
            continue
        if col.behavior in LATERAL_BEHAVIORS:
            partner = _partner(v, a, anchor, columns, scene, route, s0)
            if partner is None:
                trigger[v, a] = _param(params, col.role, ("TRIGGER_TIME", "MANEUVER_TIME"), draws["trigger"][a])
                if col.behavior == "lose_control":
                    lateral_target[v, a] = draws["spin"][a]
                continue
            gap, lateral = _relative(arrays, r, s0[v, a], scene.actors[partner].x, scene.actors[partner].y)
            opposite = math.cos(scene.actors[partner].yaw - scene.actors[a].yaw) < -0.3
            if col.behavior == "lose_control":
                lateral_target[v, a] = 1.0 if lateral >= 0 else -1.0
                dist = 2.5
            elif col.behavior == "cross_centerline" and opposite and lateral > lateral_target[v, a] > 0:
                # several opposing lanes: drift as far as the oncoming partner's lane
                lateral_target[v, a] = lateral
                dist = lateral - d0[v, a]
            else:
                dist = lateral_target[v, a] - d0[v, a]
            lead = _param(params, col.role, ("LEAD_TIME",), draws["lead"][a])
            if col.behavior == "lose_control":
                lead = (draws["lead"][a] - 1.4) / 1.2 * 0.6  # [-0.3, 0.3] s around reaching the partner's lane
            rate = timing.lateral_rate(col.behavior)
            p_col = columns[partner]
            if opposite and not p_col.is_ads and p_col.behavior not in LATERAL_BEHAVIORS and gap > 0:
                # too close to swerve in time: the oncoming partner comes a little slower (within its range)
                needed = abs(dist) / rate + lead
                closing = gap / needed
                if closing < planned[a] + planned[partner]:
                    scale[v, partner] = max(timing.SPEED_SCALE[0], (closing - planned[a]) / planned[partner])
                    planned[partner] *= scale[v, partner]
            if col.behavior == "lose_control":
                t_trig = timing.skid_trigger(gap, planned[a], planned[partner], lateral, timing.SPIN_RATE,
                                             opposite=opposite) - lead
            else:
                t_trig = timing.lateral_trigger(gap, planned[a], planned[partner], opposite, dist, lead, rate)
            if t_trig < 0 and col.behavior in ("cross_centerline", "overtake") and opposite:
                # too close for the whole manoeuvre: the actor is already drifting across at t = 0
                shift = float(np.clip(-t_trig * rate, 0.0, abs(dist) * 0.6)) * math.copysign(1.0, dist)
                d0[v, a] += shift
                drifted[v, a] = shift
            trigger[v, a] = max(0.0, t_trig)
            continue
        if col.behavior in ("decelerate", "stop"):
            trigger[v, a] = _param(params, col.role, ("TRIGGER_TIME", "MANEUVER_TIME"), draws["trigger"][a])
            continue
        if a == anchor or col.behavior == "static":
            continue
        cs_a = arrays.conflict_s[r, ra]
        cs_e = arrays.conflict_s[ra, r]
        if np.isnan(cs_a) or cs_a <= s0[v, a] or cs_e <= s0[v, anchor]:
            continue
        lat_a = 2.0 if col.is_ads else 2.5
        lat_e = 2.0 if anchor_col.is_ads else 2.5
        if arrival_anchor is None:
            if anchor_stop is None:
                arrival_anchor = arrays.travel_time(ra, s0[v, anchor], cs_e, va, lat_e, v0=va)
            else:
                v_eff = _effective_speed(arrays, ra, s0[v, anchor], cs_e, va, anchor_col)
                arrival_anchor = timing.arrival_time(cs_e - s0[v, anchor], v_eff, anchor_col.limits.accel_max,
                                                     stop_dist=anchor_stop)
        stop = _stop_dist(arrays, r, s0[v, a], entry_control, col)
        # a turning vehicle is struck on its side in its turn: it reaches the conflict point first
        turn_a = _turns_at(arrays, r, cs_a)
        turn_e = _turns_at(arrays, ra, cs_e)
        if turn_a and not turn_e:
            offset -= timing.TURNER_LEAD
        elif turn_e and not turn_a:
            offset += timing.TURNER_LEAD
        target = arrival_anchor + offset
        va_ = planned[a]
        if stop is not None:
            v_eff = _effective_speed(arrays, r, s0[v, a], cs_a, va_, col)
            sc, hd = timing.junction_plan(target, cs_a - s0[v, a], v_eff, col.limits.accel_max, stop_dist=stop)
            late = 0.0
        else:
            def t_at(k: float, s_start: float = s0[v, a], v_start: float | None = None) -> float:
                v_init = va_ * min(k, 1.0) if v_start is None else v_start
                return arrays.travel_time(r, s_start, cs_a, va_ * k, lat_a, v0=v_init)

            lo, hi = timing.SPEED_SCALE
            hd = 0.0
            if t_at(hi) > target:
                sc = hi
                late = t_at(hi) - target
            elif t_at(lo) < target:
                sc = lo
                late = 0.0
                hd = max(0.0, target - arrays.travel_time(r, s0[v, a], cs_a, va_ * lo, lat_a, v0=0.0))
            else:
                # travel time is nearly proportional to 1/speed: two secant corrections suffice
                sc = float(np.clip(t_at(1.0) / target, lo, hi))
                for _ in range(2):
                    sc = float(np.clip(sc * t_at(sc) / target, lo, hi))
                late = 0.0
        if late > 0.1 and stop is None:
            # even at its fastest the actor would come late: it has already been driving for a while,
            # so it starts further along its own approach (never closer than ADVANCE_MARGIN to the junction)
            entries = arrays.entry_s[r]
            first_entry = entries[np.isfinite(entries) & (entries > s0[v, a])]
            room = (first_entry[0] - s0[v, a] - ADVANCE_MARGIN) if len(first_entry) else 0.0
            if room > 0:
                best = s0[v, a]
                for cand in np.linspace(s0[v, a], s0[v, a] + room, 12)[1:]:
                    v_start = min(va_ * sc, max(float(arrays.curve_speed(np.array(r), np.array(cand),
                                                                         np.array(60.0), 2.5, 2.0)), 3.0))
                    best = cand
                    late = t_at(sc, cand, v_start) - target
                    if late <= 0.05:
                        break
                s0[v, a] = best
                moved[v, a] = True
            if late > 0.1 and not anchor_col.is_ads and anchor_col.behavior not in ("static", "stop") \
                    and anchor_stop is None and hold[v, anchor] == 0.0:
                # reproduce mode: the scripted anchor comes that much later instead (slower, else it waits)
                t_new = arrival_anchor + late
                lo, hi = timing.SPEED_SCALE[0], 1.0
                if arrays.travel_time(ra, s0[v, anchor], cs_e, va * lo, lat_e, v0=va * lo) < t_new:
                    scale[v, anchor] = lo
                    t_rest = arrays.travel_time(ra, s0[v, anchor], cs_e, va * lo, lat_e, v0=0.0)
                    hold[v, anchor] = max(0.0, t_new - t_rest)
                else:
                    for _ in range(8):
                        mid = (lo + hi) / 2
                        t_mid = arrays.travel_time(ra, s0[v, anchor], cs_e, va * mid, lat_e, v0=va * mid)
                        lo, hi = (lo, mid) if t_mid < t_new else (mid, hi)
                    scale[v, anchor] = (lo + hi) / 2
                arrival_anchor = t_new
        scale[v, a], hold[v, a] = sc, hd
        conflict_time[v] = min(conflict_time[v], arrival_anchor)
    # signal phase: green for the anchor's axis at its nominal arrival at its first junction
    entries = arrays.entry_s[ra]
    ahead = entries[np.isfinite(entries) & (entries > s0[v, anchor])]
    t_junction = (ahead[0] - s0[v, anchor]) / va if len(ahead) else 5.0
    green = float(scene.params.get("SIGNAL_GREEN_REMAINING", draws["green"]))
    phase[v] = float(signals.phase_for(np.array(t_junction), np.array(green), runs_red))


def _param(params: dict, role: str, names: tuple[str, ...], default: float) -> float:
    """A sampled scene parameter `<role>_<NAME>` (ego's spelled EGO_<NAME>), else `default`."""
    for name in names:
        for key in (f"{role}_{name}", f"{role.upper()}_{name}"):
            if key in params:
                try:
                    return float(params[key])
                except (TypeError, ValueError):
                    break
    return float(default)


def _mph(value: float | None) -> float:
    return value * MPH if value else math.nan


def _planned_speed(arrays: RouteArrays, r: int, s0: float, speed: float, col: ActorColumn, cond: float,
                   default_limit: float) -> float:
    """The cruise speed [m/s] the actor's driver will hold (capped at the condition-adjusted limit unless speeding)."""
    if col.dispositions & SPEEDING_CODES:
        return max(speed * speed_factor(col.dispositions), 0.5)
    limit = arrays.speed_limit[r, min(int(s0 / ROUTE_DS), arrays.speed_limit.shape[1] - 1)]
    if np.isnan(limit):
        limit = default_limit
    return max(min(speed, limit * cond) if np.isfinite(limit) else speed, 0.5)


def _effective_speed(arrays: RouteArrays, r: int, s0: float, s1: float, speed: float, col: ActorColumn) -> float:
    """Average speed [m/s] from s0 to s1, slowing in curves as the driver will (not when careless)."""
    if s1 <= s0 or "CVC_22350" in col.dispositions:
        return speed
    lat = 2.0 if col.is_ads else 2.5
    return (s1 - s0) / max(arrays.travel_time(r, s0, s1, speed, lat), 1e-3)


def _turns_at(arrays: RouteArrays, r: int, s: float) -> bool:
    """Whether route r turns (left, right, U) at the junction containing station s."""
    j = _entry_before(arrays, r, s)
    return j is not None and int(arrays.entry_maneuver[r, j]) in (2, 3, 4)


def _stop_dist(arrays: RouteArrays, r: int, s0: float, entry_control: np.ndarray, col: ActorColumn) -> float | None:
    """Distance [m] to the stop line of a stop-controlled first junction the actor will stop at, else None."""
    entries = arrays.entry_s[r]
    idx = np.nonzero(entries > s0)[0]
    if len(idx) == 0 or entry_control[r, idx[0]] != 2 or "CVC_22450" in col.dispositions:
        return None
    return float(entries[idx[0]] - s0 - 1.0)


def _partner(v: int, a: int, anchor: int, columns: list[ActorColumn], scene: SampledScene, route: np.ndarray,
             s0: np.ndarray) -> int | None:
    """The actor whose path a lateral manoeuvre of actor a is aimed at."""
    if a != anchor:
        return anchor
    me = scene.actors[a]
    behavior = columns[a].behavior
    best, best_dist = None, math.inf
    for b, other in enumerate(scene.actors):
        if b == a:
            continue
        opposite = math.cos(other.yaw - me.yaw) < -0.3
        if behavior in ("cross_centerline", "overtake", "lose_control") and not opposite:
            continue
        dist = math.hypot(other.x - me.x, other.y - me.y)
        if dist < best_dist:
            best, best_dist = b, dist
    if best is None and len(scene.actors) > 1:
        best = next(b for b in range(len(scene.actors)) if b != a)
    return best


def _relative(arrays: RouteArrays, r: int, s: float, x: float, y: float) -> tuple[float, float]:
    """(gap along route r from station s to the point, lateral offset of the point) [m]."""
    xy = arrays.xy[r]
    k = int(np.argmin(np.hypot(xy[:, 0] - x, xy[:, 1] - y)))
    yaw = arrays.yaw[r, k]
    dx, dy = x - xy[k, 0], y - xy[k, 1]
    lateral = -math.sin(yaw) * dx + math.cos(yaw) * dy
    return k * ROUTE_DS - s, lateral


def condition_factor(scenario: Scenario) -> float:
    """Safe-speed factor on the posted limit (rules.md rule 6): wet 0.85, fog 0.70, snow/ice 0.60, night 0.90."""
    env = scenario.environment
    weather, surface, light = str(env.weather), str(env.road_surface), str(env.time_of_day)
    factor = 1.0
    if surface == "wet" or weather == "rainy":
        factor *= 0.85
    if weather == "foggy":
        factor *= 0.70
    if weather == "snowy" or surface in ("snowy", "icy"):
        factor *= 0.60
    if light == "nighttime":
        factor *= 0.90
    return factor


def friction(scenario: Scenario) -> float:
    """Tyre-road friction coefficient [-] of the scenario's surface."""
    env = scenario.environment
    weather, surface = str(env.weather), str(env.road_surface)
    if surface == "icy":
        return 0.15
    if surface == "snowy" or weather == "snowy":
        return 0.3
    if surface == "wet" or weather == "rainy":
        return 0.5
    return 0.8
