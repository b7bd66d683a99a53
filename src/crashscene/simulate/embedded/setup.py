"""Setting up one embedded batch: routes, traffic control, priorities, signal phases and timing plans.

Everything here is computed once per batch from the sampled scenes, before the
step loop. Per-variation random draws come from a generator seeded by
(seed, variation index) only, so a variation's plan never depends on which
chunk of a campaign it is simulated in.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from crashscene.dsl import Scenario
from crashscene.dsl.tokens import LANE_CHANGES, OPPOSING_PASSES
from crashscene.monitor.rules import Disposition, dispositions_of
from crashscene.geometry import LANE_WIDTH
from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import SimulationError, SimulationSettings
from crashscene.simulate.drivers.behaviors import EDGE_TARGETS, NO_YIELD_CODES
from crashscene.simulate.embedded import lockstep, skid, timing
from crashscene.simulate.embedded.control import control_tables, entry_before, priorities
from crashscene.simulate.embedded.arrivals import stop_dist, struck_offset
from crashscene.simulate.embedded.plan import PlanContext, VariationPlan, mph, prepare_skids, scene_param
from crashscene.simulate.embedded.pullout import PULL_OUT_TTA, PullOut, line_station
from crashscene.simulate.embedded.sync import Meeting
from crashscene.simulate.embedded.vehicles import VehicleLimits, limits_for
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import MARKERS, ROUTE_DS, Lane, RoadMap, Route, heading_near
from crashscene.simulate.tables import driver_dispositions, is_ads
from crashscene.units import MPH

JUNCTION_INTENTS = {"straight": "straight", "left": "left", "right": "right", "u_turn": "u_turn"}
BEHAVIOR_INTENTS = {"turn_left": "left", "turn_right": "right", "u_turn": "u_turn"}
OPPOSITE_HEADINGS = ("opposite_direction",)
ROUTE_SPEED = 40.0  # [m/s] routes are built long enough for this speed over the horizon (or to the map's end)
OFF_ROAD_MARGIN = 2.5  # [m] a vehicle leaving the road drifts this far past the edge of the lanes
STOP_APPROACH_DECEL = 2.5  # [m/s2] a driver approaching a stop sign is slowing down at most this hard


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

    @cached_property
    def traits(self) -> frozenset[Disposition]:
        """The driver traits its oracle codes inject (monitor.rules registry)."""
        return dispositions_of(self.dispositions)


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
    spin_rate: np.ndarray  # [rad/s] planned yaw rate of a loss of control, NaN: the driver's
    drift: np.ndarray  # [rad] planned veer of its velocity, NaN: the default
    spin_hold: np.ndarray  # [s] how long the planned spin is held before friction slows it, NaN: until rest
    unseen: np.ndarray  # (A, A) bool: driver a does not perceive actor b (unseen_partners)
    meeting: Meeting  # reproduce mode: who adjusts its speed to meet at the first written contact
    pullout: PullOut  # test mode: the NPC that waits at its line and pulls out in front of the ADS
    condition_factor: float  # [-] safe speed / posted limit for the weather, surface and light
    friction: float  # [-] tyre-road friction coefficient
    invalid: list[str | None]  # per variation, the first reason found at setup
    conflict_time: np.ndarray  # (V,) [s] the anchor's nominal arrival at its first conflict point, inf if none
    default_speed_limit: float  # [m/s] DSL posted limit, NaN if none
    lane_width_table: np.ndarray  # (n_lanes,) [m]
    lane_road: np.ndarray  # (n_lanes,) road ordinal
    lane_forward: np.ndarray  # (n_lanes,) bool
    lane_marker: np.ndarray  # (n_lanes,) marker ordinal
    plans: list[VariationPlan] = field(default_factory=list)  # per variation, the timing plan it was built from

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
          settings: SimulationSettings, plans: list[VariationPlan] | None = None) -> BatchSetup:
    """Everything the step loop needs, for these scenes: actor columns, routes, start coordinates, lateral
    targets, traffic control, timing plans (plan.VariationPlan), then the start poses and speeds they imply.
    `plans`: one plan per scene, planned already (refine's candidates), used as they are instead of planning."""
    columns, anchor = _columns(scenes, settings)
    start = _StartGrid.of(scenes)
    layout = _route_layout(scenario, scenes, columns, roadmap, start, settings)
    arrays = layout.arrays
    lane_width_table = np.array([lane.width for lane in roadmap.lanes])
    lane_width = _start_coordinates(layout, start, lane_width_table)
    _set_lateral_targets(columns, layout, start, lane_width)

    # ---- traffic control per junction entry, from the DSL
    # each variation's control tables come from its own layout (never from another scene of the chunk)
    route, s0 = layout.route, start.s0
    tables = control_tables(scenario, scenes, arrays, route, s0, anchor)
    vidx = np.arange(len(scenes))[:, None]
    entry_control = np.stack([t[0] for t in tables])[vidx, route]  # (V, A, J)
    entry_group = np.stack([t[1] for t in tables])[vidx, route]
    priority = priorities(arrays, route, tables)
    if settings.mode == "reproduce":
        _oracle_priority(scenario, columns, priority)

    factor = condition_factor(scenario, settings.conditions)
    plans = _timing_plans(scenario, scenes, columns, anchor, layout, start, tables, lane_width, factor, settings,
                          lanes_beside(roadmap), plans)
    pullout = _pullout(scenes, columns, anchor, arrays, route, s0, tables, priority, plans.hold, settings)
    _pull_out_to_touch(pullout, plans.pull_out, plans.hold)
    start_cap = _apply_plan_moves(arrays, route, start, plans)
    speed0 = _initial_speeds(columns, arrays, route, start, plans, tables, start_cap)
    limit = scenario.road_network.speed_limit_mph
    road_names = sorted({lane.road for lane in roadmap.lanes})
    return BatchSetup(
        scenario=scenario, settings=settings, roadmap=roadmap, scenes=scenes, columns=columns, anchor=anchor,
        routes=arrays, route=route, x=start.x, y=start.y, yaw=start.yaw, speed=speed0,
        cruise=plans.planned * plans.scale, length=start.length, width=start.width,
        s0=s0, d0=start.d0, lane_width=lane_width, entry_control=entry_control, entry_group=entry_group,
        priority=priority, phase=plans.phase, hold_until=plans.hold, trigger_time=plans.trigger,
        lateral_target=layout.lateral_target,
        spin_rate=plans.skids[..., 0], drift=plans.skids[..., 1], spin_hold=plans.skids[..., 2],
        unseen=unseen_partners(scenario, columns, settings.mode == "reproduce"),
        meeting=_meeting(scenario, columns, arrays, route, s0, start.length, plans.hold, tables, settings,
                         plans.touch_at, plans.pull_out, plans.slap_offset),
        pullout=pullout,
        condition_factor=factor, friction=friction(scenario, settings.conditions),
        invalid=layout.invalid, conflict_time=plans.conflict_time,
        default_speed_limit=limit * MPH if limit else math.nan,
        lane_width_table=lane_width_table,
        lane_road=np.array([road_names.index(lane.road) for lane in roadmap.lanes]),
        lane_forward=np.array([lane.forward for lane in roadmap.lanes]),
        lane_marker=np.array([MARKERS.index(lane.marker) for lane in roadmap.lanes]),
        plans=plans.built,
    )


def _columns(scenes: list[SampledScene], settings: SimulationSettings) -> tuple[list[ActorColumn], int]:
    """The actor columns of the batch (every scene must have the same roles) and the anchor's column."""
    if not scenes:
        raise SimulationError("no scenes to simulate")
    roles = [a.role for a in scenes[0].actors]
    for scene in scenes:
        if [a.role for a in scene.actors] != roles:
            raise SimulationError(f"scene {scene.index}: actors {[a.role for a in scene.actors]} differ from "
                                  f"scene {scenes[0].index}'s {roles}; a batch needs the same actors in every scene")
    anchor_role = settings.ego_role if settings.ego_role in roles else roles[0]
    columns = [ActorColumn(a.role, a.behavior, a.type, is_ads(a.role, settings),
                           frozenset(driver_dispositions(a, settings)), limits_for(a.type)) for a in scenes[0].actors]
    return columns, roles.index(anchor_role)


@dataclass
class _StartGrid:
    """(V, A) start poses and sizes of the sampled actors, then their route coordinates (`s0`, `d0` [m])."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray  # [m/s] sampled
    length: np.ndarray
    width: np.ndarray
    s0: np.ndarray
    d0: np.ndarray

    @classmethod
    def of(cls, scenes: list[SampledScene]) -> _StartGrid:
        def grid(attr: str) -> np.ndarray:
            return np.array([[getattr(a, attr) for a in scene.actors] for scene in scenes], dtype=float)

        shape = (len(scenes), len(scenes[0].actors))
        return cls(grid("x"), grid("y"), grid("yaw"), grid("speed"), grid("length"), grid("width"),
                   np.zeros(shape), np.zeros(shape))


@dataclass
class _RouteLayout:
    """Each actor's route per variation and what its start lane says about its lateral target."""

    routes: list[Route]
    arrays: RouteArrays
    route: np.ndarray  # (V, A) route index
    lateral_target: np.ndarray  # (V, A) [m]
    road_edge: np.ndarray  # (V, A) [m] signed offset of the road edge a leave_road actor drifts over, NaN if none
    relocated: np.ndarray  # (V, A) bool: placed in another lane of its approach
    invalid: list[str | None]  # per variation, the first reason found


def _route_layout(scenario: Scenario, scenes: list[SampledScene], columns: list[ActorColumn], roadmap: RoadMap,
                  start: _StartGrid, settings: SimulationSettings) -> _RouteLayout:
    """Routes: one per distinct (start lane, junction intent), plus synthetic ones for off-road starts; an
    actor whose written contact crosses a turner's path takes the lane of its approach that meets it as the
    class says."""
    n_v, n_a = start.x.shape
    invalid: list[str | None] = [None] * n_v
    # fixed by the settings, never by the batch, so that a variation's routes do not depend on its chunk
    min_length = 100.0 * math.ceil((ROUTE_SPEED * settings.horizon + 60.0) / 100.0)
    route_index: dict[tuple, int] = {}
    routes: list[Route] = []
    route = np.zeros((n_v, n_a), dtype=np.int64)
    lateral_target = np.zeros((n_v, n_a))
    lane_cache: dict[tuple, Lane | None] = {}
    start_lanes: dict[tuple[int, int], Lane] = {}
    road_edge = np.full((n_v, n_a), np.nan)
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
            start_lanes[v, a] = route_lane
            if actor.behavior in EDGE_TARGETS:
                road_edge[v, a] = _road_edge_offset(roadmap, lane, scenario)
            key = (route_lane.uid, _junction_intent(actor), min_length)
            if key not in route_index:
                route_index[key] = len(routes)
                routes.append(roadmap.route(route_lane.uid, _junction_intent(actor), min_length))
            route[v, a] = route_index[key]
    classes = contact_classes(scenario)
    crossing = _crossing_candidates(scenes, columns, classes, roadmap, start_lanes, route, route_index, routes,
                                    min_length)
    arrays = RouteArrays.pack(routes)
    relocated = _choose_crossing_lanes(crossing, arrays, route, start.x, start.y, classes, columns)
    return _RouteLayout(routes, arrays, route, lateral_target, road_edge, relocated, invalid)


def _start_coordinates(layout: _RouteLayout, start: _StartGrid, lane_width_table: np.ndarray) -> np.ndarray:
    """Fill the start's route coordinates (s0, d0); an actor placed in another lane of its approach starts on
    that lane's centre. Returns each actor's start lane width [m] (V, A)."""
    arrays, route = layout.arrays, layout.route
    for r, rt in enumerate(layout.routes):
        mask = route == r
        if mask.any():
            start.s0[mask], start.d0[mask] = rt.local_coordinates(start.x[mask], start.y[mask], first_lane=True)
    if layout.relocated.any():
        vv, aa = np.nonzero(layout.relocated)
        start.x[vv, aa], start.y[vv, aa], start.yaw[vv, aa] = arrays.point(route[vv, aa], start.s0[vv, aa])
        start.d0[vv, aa] = 0.0
    start_lane_idx = arrays.lane[route, np.clip((start.s0 / ROUTE_DS).astype(int), 0, arrays.lane.shape[1] - 1)]
    return np.where(start_lane_idx >= 0, lane_width_table[np.maximum(start_lane_idx, 0)], LANE_WIDTH)


def _set_lateral_targets(columns: list[ActorColumn], layout: _RouteLayout, start: _StartGrid,
                         lane_width: np.ndarray) -> None:
    """The lateral offset [m] each actor's behaviour steers to on its route (layout.lateral_target)."""
    co = layout.arrays.sample(layout.arrays.centerline_offset, layout.route, start.s0)
    target = layout.lateral_target
    for a, col in enumerate(columns):
        if col.behavior in EDGE_TARGETS:
            edge = np.where(np.isnan(layout.road_edge[:, a]), -lane_width[:, a] / 2.0, layout.road_edge[:, a])
            target[:, a] = edge + np.sign(edge) * OFF_ROAD_MARGIN
            continue
        target[:, a] = _lateral_target(col.behavior, target[:, a], co[:, a], lane_width[:, a], start.d0[:, a])


@dataclass
class _TimingPlans:
    """The batch's timing plans, (V, A) rows of each variation's plan.VariationPlan."""

    planned: np.ndarray  # [m/s] cruise speed before the timing scale
    scale: np.ndarray
    hold: np.ndarray
    trigger: np.ndarray
    moved: np.ndarray
    drifted: np.ndarray
    skids: np.ndarray  # (V, A, 3)
    phase: np.ndarray  # (V,)
    conflict_time: np.ndarray  # (V,)
    touch_at: np.ndarray  # (V, 2) [m] plan.VariationPlan.touch_at, NaN where the plan kept the routes' meeting
    pull_out: list  # (V,) plan.VariationPlan.pull_out, None where no actor waits at its line for the touch
    slap_offset: np.ndarray  # (V,) [m] plan.VariationPlan.slap_offset, NaN where no side slap is planned
    built: list[VariationPlan] = field(default_factory=list)  # (V,) the plans themselves

    @classmethod
    def empty(cls, n_v: int, n_a: int) -> _TimingPlans:
        return cls(planned=np.zeros((n_v, n_a)), scale=np.ones((n_v, n_a)), hold=np.zeros((n_v, n_a)),
                   trigger=np.full((n_v, n_a), np.inf), moved=np.zeros((n_v, n_a), dtype=bool),
                   drifted=np.zeros((n_v, n_a)), skids=np.full((n_v, n_a, 3), np.nan), phase=np.zeros(n_v),
                   conflict_time=np.full(n_v, np.inf), touch_at=np.full((n_v, 2), np.nan), pull_out=[None] * n_v,
                   slap_offset=np.full(n_v, np.nan))

    def put(self, v: int, plan: VariationPlan) -> None:
        self.built.append(plan)
        for name in ("planned", "scale", "hold", "trigger", "moved", "drifted", "skids", "phase", "conflict_time"):
            getattr(self, name)[v] = getattr(plan, name)
        if plan.touch_at is not None:
            self.touch_at[v] = plan.touch_at
        self.pull_out[v] = plan.pull_out
        if plan.slap_offset is not None:
            self.slap_offset[v] = plan.slap_offset


def _timing_plans(scenario: Scenario, scenes: list[SampledScene], columns: list[ActorColumn], anchor: int,
                  layout: _RouteLayout, start: _StartGrid, tables: list, lane_width: np.ndarray, factor: float,
                  settings: SimulationSettings, beside: np.ndarray | None = None,
                  given: list[VariationPlan] | None = None) -> _TimingPlans:
    """Timing plans and signal phases, per variation from its own generator (or `given`, planned already); the
    plans' starts (s0, d0) and lateral targets are written back into `start` and `layout`."""
    plans = _TimingPlans.empty(*start.x.shape)
    if given is not None:
        for v, plan in enumerate(given):
            start.s0[v], start.d0[v], layout.lateral_target[v] = plan.s0, plan.d0, plan.lateral_target
            plans.put(v, plan)
        return plans
    mu = friction(scenario, settings.conditions)
    ctx = PlanContext(columns=columns, anchor=anchor, arrays=layout.arrays, classes=contact_classes(scenario),
                      strikers=contact_strikers(scenario), first_pair=first_contact_pair(scenario),
                      reproduce=settings.mode == "reproduce",
                      runs_red=Disposition.RUNS_RED in columns[anchor].traits, cond=factor,
                      default_limit=mph(scenario.road_network.speed_limit_mph), friction=mu,
                      skid_paths=skid.SkidPaths(mu, settings.dt), contacts=contact_sequence(scenario),
                      lanes_beside=beside)
    prepare_skids(ctx, layout.route, start.s0, start.speed)
    median_lane_width = np.median(lane_width, axis=1).tolist()  # [m] per variation, one call for the batch

    def build(v: int) -> VariationPlan:
        scene = scenes[v]
        return VariationPlan.build(ctx, scene, variation_rng(scene.seed, scene.index), layout.route[v], start.s0[v],
                                   start.d0[v], start.speed[v], start.length[v], start.width[v], tables[v][0],
                                   layout.lateral_target[v], median_lane_width[v])

    # a reproduce plan of a crash sequence may integrate slides: the variations' plans in lockstep, so that their
    # slides are integrated at once (each plan reads only its own variation's rows)
    if ctx.reproduce and len(ctx.contacts) > 1:
        built = lockstep.run([functools.partial(build, v) for v in range(len(scenes))])
    else:
        built = map(build, range(len(scenes)))
    for v, plan in enumerate(built):
        start.s0[v], start.d0[v], layout.lateral_target[v] = plan.s0, plan.d0, plan.lateral_target
        plans.put(v, plan)
    return plans


def lanes_beside(roadmap: RoadMap) -> np.ndarray:
    """(n_lanes, 2) how many lanes of the same direction lie to the left and to the right of each lane of the map
    (RoadMap.side_lanes)."""
    return np.array([[len(roadmap.side_lanes(lane, side)) for side in ("left", "right")] for lane in roadmap.lanes],
                    dtype=np.int64).reshape(len(roadmap.lanes), 2)


def _apply_plan_moves(arrays: RouteArrays, route: np.ndarray, start: _StartGrid, plans: _TimingPlans) -> np.ndarray:
    """Start poses of the actors the plans moved: drifting across already, or advanced or moved back along their
    approach (on their lane centre there; a lane changer keeps its offset from the target lane's route).
    Returns the highest initial speed [m/s] (V, A) from which a moved actor can still take the curve ahead."""
    start_cap = np.full(route.shape, np.inf)
    x, y, yaw, s0, d0 = start.x, start.y, start.yaw, start.s0, start.d0
    if plans.drifted.any():
        vv, aa = np.nonzero(plans.drifted)
        _, _, ryaw = arrays.point(route[vv, aa], s0[vv, aa])
        x[vv, aa] -= np.sin(ryaw) * plans.drifted[vv, aa]
        y[vv, aa] += np.cos(ryaw) * plans.drifted[vv, aa]
    if plans.moved.any():
        vv, aa = np.nonzero(plans.moved)
        keep = (np.abs(d0[vv, aa]) > 1.0) | (plans.drifted[vv, aa] != 0.0)  # a planned offset stays
        d0[vv, aa] = np.where(keep, d0[vv, aa], 0.0)
        px, py, yaw[vv, aa] = arrays.point(route[vv, aa], s0[vv, aa])
        x[vv, aa] = px - np.sin(yaw[vv, aa]) * d0[vv, aa]
        y[vv, aa] = py + np.cos(yaw[vv, aa]) * d0[vv, aa]
        reach = np.full(len(vv), 60.0)
        entry_speed = arrays.curve_speed(route[vv, aa], s0[vv, aa], reach, 2.5, 2.0)
        start_cap[vv, aa] = np.maximum(entry_speed, 3.0)
    return start_cap


def _initial_speeds(columns: list[ActorColumn], arrays: RouteArrays, route: np.ndarray, start: _StartGrid,
                    plans: _TimingPlans, tables: list, start_cap: np.ndarray) -> np.ndarray:
    """[m/s] (V, A): the planned speed (slower when the plan slows it), 0 when held at the start; a driver who
    will stop at a stop sign close ahead is already slowing down for it."""
    planned, scale = plans.planned, plans.scale
    speed0 = np.where((plans.hold > 0) | (start.speed <= 0.0), 0.0,
                      np.minimum(planned * np.minimum(scale, 1.0), start_cap))
    for a, col in enumerate(columns):
        for v in range(route.shape[0]):
            stop = stop_dist(arrays, route[v, a], start.s0[v, a], tables[v][0], col)
            if stop is not None:
                speed0[v, a] = min(speed0[v, a], math.sqrt(2.0 * STOP_APPROACH_DECEL * max(stop - 1.0, 0.0)))
    return speed0


def contact_sequence(scenario: Scenario) -> tuple[tuple[str, str, str, str, str], ...]:
    """The written crash sequence (DSL `collisions`) as (striking, struck, class, striking area, struck area),
    in order."""
    def token(value) -> str:
        return str(getattr(value, "value", value))

    return tuple((str(c.striking), str(c.struck), token(c.class_), token(c.striking_area), token(c.struck_area))
                 for c in getattr(scenario, "collisions", None) or [])


def contact_classes(scenario: Scenario) -> dict[frozenset[str], str]:
    """The class of the first written contact of each actor pair (DSL `collisions`); empty when not written."""
    out: dict[frozenset[str], str] = {}
    for contact in getattr(scenario, "collisions", None) or []:
        pair = frozenset((str(contact.striking), str(contact.struck)))
        out.setdefault(pair, str(getattr(contact.class_, "value", contact.class_)))
    return out


def _oracle_priority(scenario: Scenario, columns: list[ActorColumn], priority: np.ndarray) -> None:
    """An actor the oracle charges with not yielding (a yield code) was the one to yield: its contact partners
    have priority over it whatever the map's signs say (reproduce mode)."""
    roles = [c.role for c in columns]
    for contact in getattr(scenario, "collisions", None) or []:
        pair = (str(contact.striking), str(contact.struck))
        if not all(r in roles for r in pair) or pair[0] == pair[1]:
            continue
        for x, y in (pair, pair[::-1]):
            if columns[roles.index(x)].dispositions & NO_YIELD_CODES:
                priority[:, roles.index(y), roles.index(x)] = False


def first_contact_pair(scenario: Scenario) -> frozenset[str] | None:
    """The two actors of the first written contact (DSL `collisions`), None when not written or empty."""
    contacts = getattr(scenario, "collisions", None) or []
    return frozenset((str(contacts[0].striking), str(contacts[0].struck))) if contacts else None


def contact_strikers(scenario: Scenario) -> dict[frozenset[str], str]:
    """The striking actor of the first written contact of each actor pair (DSL `collisions`)."""
    out: dict[frozenset[str], str] = {}
    for contact in getattr(scenario, "collisions", None) or []:
        out.setdefault(frozenset((str(contact.striking), str(contact.struck))), str(contact.striking))
    return out


def unseen_partners(scenario: Scenario, columns: list[ActorColumn], reproduce: bool) -> np.ndarray:
    """(A, A) True where driver a does not perceive actor b: in reproduce mode, the striking driver of a
    written contact never saw what it struck (an inattentive driver), so it does not brake for it."""
    roles = [c.role for c in columns]
    out = np.zeros((len(roles), len(roles)), dtype=bool)
    if not reproduce:
        return out
    for contact in getattr(scenario, "collisions", None) or []:
        a, b = str(contact.striking), str(contact.struck)
        if a in roles and b in roles and a != b and not columns[roles.index(a)].is_ads:
            out[roles.index(a), roles.index(b)] = True
    return out


def _pullout(scenes: list[SampledScene], columns: list[ActorColumn], anchor: int, arrays: RouteArrays,
             route: np.ndarray, s0: np.ndarray, tables: list, priority: np.ndarray, hold: np.ndarray,
             settings: SimulationSettings) -> PullOut:
    """Test mode: the NPC that must yield to the ADS at a stop or yield line and, by its oracle, does not
    (pullout.PullOut); it drives to its line instead of being held at its start, and pulls out at its sampled
    `PULL_OUT_TTA` when the scene has one."""
    n_v = route.shape[0]
    out = PullOut.none(n_v, columns[anchor].limits.brake_max)
    if settings.mode != "test" or not columns[anchor].is_ads:
        return out
    for a, col in enumerate(columns):
        if col.is_ads or not (col.dispositions & NO_YIELD_CODES) or col.behavior not in FREE_BEHAVIORS:
            continue
        for v in range(n_v):
            if out.npc[v] >= 0 or not priority[v, a, anchor]:
                continue
            r, ra = route[v, a], route[v, anchor]
            cs, cs_ads = arrays.conflict_s[r, ra], arrays.conflict_s[ra, r]
            j = entry_before(arrays, r, cs) if np.isfinite(cs) else None
            if j is None or int(tables[v][0][r, j]) not in (2, 3) or arrays.entry_s[r, j] <= s0[v, a]:
                continue
            out.npc[v], out.ads[v] = a, anchor
            out.tta[v] = scene_param(scenes[v].params, col.role, ("PULL_OUT_TTA",), PULL_OUT_TTA)
            out.line[v] = line_station(float(arrays.entry_s[r, j]))
            out.cs_npc[v], out.cs_ads[v] = cs, cs_ads
            hold[v, a] = 0.0
    return out


def _pull_out_to_touch(pullout: PullOut, planned: list, hold: np.ndarray) -> None:
    """Reproduce mode: the actor of a written contact on its turn out of a stop-controlled approach waits at its
    line and pulls out when its partner is as far in time from the touch as it takes to get there from rest
    (plan.VariationPlan.pull_out); no fairness applies."""
    for v, one in enumerate(planned):
        if one is None or pullout.npc[v] >= 0:
            continue
        pullout.npc[v], pullout.ads[v], pullout.line[v], pullout.cs_ads[v], pullout.tta[v] = \
            one.actor, one.partner, one.line, one.partner_front, one.tta
        pullout.rest[v], pullout.touch_speed[v] = one.rest, one.touch_speed
        pullout.fair[v] = False
        hold[v, one.actor] = 0.0


FREE_BEHAVIORS = ("go_forward", "accelerate", "turn_left", "turn_right", "u_turn")


def _meeting(scenario: Scenario, columns: list[ActorColumn], arrays: RouteArrays, route: np.ndarray, s0: np.ndarray,
             length: np.ndarray, hold: np.ndarray, tables: list, settings: SimulationSettings,
             touch_at: np.ndarray, pull_out: list, slap_offset: np.ndarray) -> Meeting:
    """The follower of the first written contact, per variation (sync.Meeting): the striker when it drives
    freely (a scripted driver, not held, not stopping at a sign first), else the struck actor; they meet at the
    routes' meeting point, or where the plan moved it (`touch_at` (V, 2) [m] on the striker's and the struck
    actor's routes, NaN: not moved); none where an actor waits at its line for the touch (`pull_out`). The struck
    centre is past the striker's path by `slap_offset` (V,) [m] where the plan placed the touch for a side slap to
    follow (slap), else by arrivals.struck_offset."""
    n_v = route.shape[0]
    meeting = Meeting.none(n_v)
    contacts = getattr(scenario, "collisions", None) or []
    roles = [c.role for c in columns]
    if settings.mode != "reproduce" or not contacts:
        return meeting
    first = contacts[0]
    if str(first.striking) not in roles or str(first.struck) not in roles:
        return meeting
    si, ti = roles.index(str(first.striking)), roles.index(str(first.struck))
    for v in range(n_v):
        if pull_out[v] is not None:
            continue  # the waiting actor's pull-out times the touch (_pull_out_to_touch)
        moved = bool(np.isfinite(touch_at[v, 0]))
        cs_s, cs_t = touch_at[v] if moved else (arrays.conflict_s[route[v, si], route[v, ti]],
                                                arrays.conflict_s[route[v, ti], route[v, si]])
        if not (np.isfinite(cs_s) and np.isfinite(cs_t)) or cs_s <= s0[v, si] + length[v, si] / 2 \
                or cs_t <= s0[v, ti] + length[v, ti] / 2:
            continue
        for f, l_ in ((si, ti), (ti, si)):
            col = columns[f]
            if col.is_ads or col.behavior not in FREE_BEHAVIORS or hold[v, f] > 0 \
                    or stop_dist(arrays, route[v, f], s0[v, f], tables[v][0], col) is not None:
                continue
            meeting.follower[v], meeting.leader[v] = f, l_
            meeting.cs_follower[v] = cs_s if f == si else cs_t
            meeting.cs_leader[v] = cs_t if f == si else cs_s
            meeting.follower_strikes[v] = f == si
            meeting.struck_offset[v] = 0.0 if moved else slap_offset[v] if np.isfinite(slap_offset[v]) else \
                struck_offset(arrays, route[v, ti], cs_t, route[v, si], cs_s, float(length[v, ti]),
                              str(getattr(first.class_, "value", first.class_)))
            stop = stop_dist(arrays, route[v, l_], s0[v, l_], tables[v][0], columns[l_])
            if stop is not None:
                meeting.leader_stop[v] = s0[v, l_] + stop
            # the sharpest curve on the leader's way to the conflict point: the speed it slows to for its turn
            k0 = int(s0[v, l_] / ROUTE_DS)
            k1 = max(k0 + 1, min(int(meeting.cs_leader[v] / ROUTE_DS) + 1, arrays.curvature.shape[1]))
            kappa = float(np.abs(arrays.curvature[route[v, l_], k0:k1]).max())
            meeting.leader_turn_speed[v] = math.sqrt(columns[l_].limits.lat_accel_comfort / max(kappa, 1e-4))
            break
    return meeting


# ------------------------------------------------------------------ placement: which lane meets as the report says
CLASS_CROSSING = {"angle": math.pi / 2}  # [rad] relative heading at a crossing conflict that gives the class
SPAWN_CLEARANCE = 8.0  # [m] an actor moved to another lane keeps this far from every other actor


def _crossing_candidates(scenes: list[SampledScene], columns: list[ActorColumn], classes: dict, roadmap: RoadMap,
                         start_lanes: dict, route: np.ndarray, route_index: dict, routes: list[Route],
                         min_length: float) -> dict[tuple[int, int, int], list[int]]:
    """For a straight-going actor whose written contact with a turning actor crosses its path, the routes
    from every same-direction lane of its approach: (v, a, partner) -> candidate route indices."""
    out: dict[tuple[int, int, int], list[int]] = {}
    roles = [c.role for c in columns]
    for a, col in enumerate(columns):
        for b, other in enumerate(columns):
            klass = classes.get(frozenset((col.role, other.role)))
            if b == a or klass not in CLASS_CROSSING:
                continue
            for v, scene in enumerate(scenes):
                mine, theirs = scene.actors[a], scene.actors[b]
                if _junction_intent(mine) != "straight" or _junction_intent(theirs) == "straight" \
                        or (v, a) not in start_lanes or mine.behavior not in ("go_forward", "accelerate"):
                    continue
                lanes = [start_lanes[v, a], *roadmap.side_lanes(start_lanes[v, a], "left"),
                         *roadmap.side_lanes(start_lanes[v, a], "right")]
                if len(lanes) < 2:
                    continue
                cands = []
                for lane in lanes:
                    key = (lane.uid, "straight", min_length)
                    if key not in route_index:
                        route_index[key] = len(routes)
                        routes.append(roadmap.route(lane.uid, "straight", min_length))
                    cands.append(route_index[key])
                out[v, a, b] = cands
    del roles
    return out


def _choose_crossing_lanes(candidates: dict, arrays: RouteArrays, route: np.ndarray, x: np.ndarray, y: np.ndarray,
                           classes: dict, columns: list[ActorColumn]) -> np.ndarray:
    """Route each candidate actor along the lane whose crossing with its partner's path is closest to the
    relative heading of the written contact's class; (V, A) True where an actor changed lane."""
    moved = np.zeros(route.shape, dtype=bool)
    for (v, a, b), cands in candidates.items():
        target = CLASS_CROSSING[classes[frozenset((columns[a].role, columns[b].role))]]
        best, best_miss = route[v, a], math.inf
        for rc in cands:
            angle = arrays.conflict_angle[rc, route[v, b]]
            if not np.isfinite(angle):
                continue
            xy = arrays.xy[rc]
            k = int(np.argmin(np.hypot(xy[:, 0] - x[v, a], xy[:, 1] - y[v, a])))
            px, py = xy[k]
            others = [c for c in range(route.shape[1]) if c != a]
            if any(math.hypot(px - x[v, c], py - y[v, c]) < SPAWN_CLEARANCE for c in others) and rc != route[v, a]:
                continue
            miss = abs(abs(float(angle)) - target)
            if miss < best_miss - 1e-6:
                best, best_miss = rc, miss
        if best != route[v, a]:
            route[v, a] = best
            moved[v, a] = True
    return moved


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
    return math.cos(heading_near(lane, actor.x, actor.y) - actor.yaw) > tolerance


def _junction_intent(actor: SampledActor) -> str:
    if actor.route_intent in JUNCTION_INTENTS:
        return JUNCTION_INTENTS[actor.route_intent]
    return BEHAVIOR_INTENTS.get(actor.behavior, "straight")


def _route_lane(roadmap: RoadMap, lane: Lane, actor: SampledActor) -> tuple[Lane, float]:
    """The lane the route follows and the lateral target on it [m] (lane changes follow the target lane)."""
    change = actor.route_intent if actor.route_intent.startswith("lane_change") else None
    if change is None and actor.behavior in LANE_CHANGES:
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
    w = lane.width
    right = -(w / 2.0 + len(roadmap.side_lanes(lane, "right")) * w)
    if lane.opposite is not None:
        return right  # two-way: leaving to the left means crossing the oncoming lanes first
    left = w / 2.0 + len(roadmap.side_lanes(lane, "left")) * w
    curve = scenario.road_network.curve_direction
    if scenario.road_network.road_type == "curve" and curve is not None:
        return left if str(curve) == "right" else right
    return left if left < -right else right


def _lateral_target(behavior: str, current: np.ndarray, centre_offset: np.ndarray, lane_width: np.ndarray,
                    d0: np.ndarray) -> np.ndarray:
    """Lateral offset [m] a behaviour steers to, on its route."""
    across = np.where(np.isnan(centre_offset), lane_width, 2.0 * centre_offset)
    if behavior in OPPOSING_PASSES:
        return across
    if behavior in EDGE_TARGETS:
        return -(lane_width / 2.0 + LANE_WIDTH)  # one lane's width beyond the road's edge
    if behavior in LANE_CHANGES:
        return np.where(np.isnan(current), across, current)
    return np.nan_to_num(current)


def _straight_route(key: tuple, actor: SampledActor, length: float) -> Route:
    s = np.arange(0.0, length + 1e-9, ROUTE_DS)
    xy = np.stack([actor.x + s * math.cos(actor.yaw), actor.y + s * math.sin(actor.yaw)], axis=1)
    n = len(s)
    return Route(key, xy, np.full(n, actor.yaw), np.zeros(n), np.full(n, -1, dtype=np.int32),
                 np.full(n, -1, dtype=np.int32), np.full(n, np.nan), np.full(n, np.nan), [])


def condition_factor(scenario: Scenario, conditions: dict[str, float] | None = None) -> float:
    """Safe-speed factor on the posted limit (rules.md rule 6; the monitor's CVC_22350 parameters, overridden
    by `conditions` from a rulebook)."""
    from crashscene.monitor.rules.speed import UnsafeSpeedParams, environment_factor

    env = scenario.environment
    params = UnsafeSpeedParams(**(conditions or {}))
    return environment_factor(str(env.weather), str(env.road_surface), str(env.time_of_day), params)[0]


def friction(scenario: Scenario, conditions: dict[str, float] | None = None) -> float:
    """Tyre-road friction coefficient [-] of the scenario's surface (as the monitor's CVC_22350 has it)."""
    from crashscene.monitor.rules.speed import UnsafeSpeedParams, surface_friction

    env = scenario.environment
    return surface_friction(str(env.weather), str(env.road_surface), UnsafeSpeedParams(**(conditions or {})))
