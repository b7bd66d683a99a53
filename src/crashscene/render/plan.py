"""Render step 1, plan: DSL -> `RenderPlan`, the middleware between a validated scenario and the Scenic template.

Everything the report leaves open is decided here, from the tables at the top of
this module (the only place defaults live): speeds, vehicle models, time of day,
weather presets, initial distances and timing windows. The result, `RenderPlan`,
holds only closed-vocabulary tokens and numbers, so the template can print it
into a program without ever touching free text.

Geometry words used below: every actor drives along a *route* (a lane, or a
lane -> junction connector -> lane chain); the *anchor* is the point on the ego's
route the DSL positions are measured against (junction entry, curve start, or a
reference point on a straight road).
"""
from __future__ import annotations

import hashlib
import itertools
import math
import re
from enum import StrEnum

from pydantic import BaseModel, ConfigDict, Field

from crashscene.dsl.model import Actor, Scenario
from crashscene.dsl.tokens import (
    JUNCTIONS,
    OPPOSING_PASSES,
    Behavior,
    Heading,
    Relation,
    RoadElement,
    RoadType,
    Sign,
    TimeOfDay,
    Weather,
)
from crashscene.monitor.rules import Disposition, dispositions_of
from crashscene.monitor.rules.speed import unposted_limit
from crashscene.render.errors import RenderError
from crashscene.units import MPH

# ---------------------------------------------------------------- defaults (the one table)

HORIZON = 20.0  # [s] default simulation horizon; maps are long enough for it
SPEED_SPREAD = 2.0  # [m/s] half-width of the speed range around the nominal speed (VerifaiRange(8, 12))
SPEED_SPREAD_FRACTION = 0.1  # half-width as a fraction of a stated speed, when larger than SPEED_SPREAD
MIN_MOVING_SPEED = 2.0  # [m/s] lower bound of any moving actor's speed range
INIT_DIST = (15.0, 20.0)  # [m] EGO_INIT_DIST / NPC_INIT_DIST: distance to the anchor or to the reference actor
ONCOMING_DIST = (50.0, 80.0)  # [m] gap to an oncoming actor on a road (closing speed is the sum of both)
SIDE_OFFSET = (-3.0, 6.0)  # [m] longitudinal offset of an actor in the adjacent lane, + = ahead
ARRIVAL_OFFSET = (-1.0, 1.0)  # [s] NPC arrival at the conflict point minus the ego's
MANEUVER_TIME = (1.0, 3.0)  # [s] when a lane change, braking, loss of control or run-off starts
STOP_DURATION = (2.0, 4.0)  # [s] how long a stopping actor stays stopped before it may proceed
# Timing choices the embedded simulator draws per variation; a search (`render(..., search_ads=ROLE)`)
# declares them as sampled parameters instead, over the same ranges, so that it can steer them.
LEAD_TIME = (0.8, 2.0)  # [s] a lateral manoeuvre aimed at another vehicle is under way this long before they meet
SIGNAL_GREEN = (3.0, 15.0)  # [s] green left for the anchor's axis (test mode: the ADS's) at its junction
SKID_ROTATION = (0.0, 1.0)  # [-] where in its range a planned skid's rotation at contact falls
PULL_OUT_TTA_RANGE = (1.5, 4.0)  # [s] test mode: the ADS's time to the conflict point when a stop- or yield-controlled
# NPC that does not yield pulls out (never below the ADS's reaction plus braking time: simulate.embedded.pullout)
LATERAL_BEHAVIORS = frozenset({Behavior.CHANGE_LANE_LEFT, Behavior.CHANGE_LANE_RIGHT, Behavior.CROSS_CENTERLINE,
                               Behavior.OVERTAKE, Behavior.LOSE_CONTROL, Behavior.LEAVE_ROAD})
PULL_OUT_BEHAVIORS = frozenset({Behavior.GO_FORWARD, Behavior.TURN_LEFT, Behavior.TURN_RIGHT, Behavior.U_TURN})
# [s] a vehicle standing in the ego's lane ahead is placed this many seconds away at the ego's top sampled
# speed: room for a prudent driver to stop (0.5 s reaction + 6 m/s2 braking needs ~2.6 s at 25 m/s), so a
# test-mode ADS is not handed an unavoidable crash, while a driver charged with CVC_22350 still strikes it.
STANDING_LEAD_TIME = (3.5, 5.0)
STRAIGHT_BACK = 60.0  # [m] road behind the anchor on generated straight roads (room for followers)
CURVE_ANGLE = 1.3  # [rad] heading change of a generated curve (~75 deg)
CURVE_LATERAL_ACC = 2.0  # [m/s2] design lateral acceleration at the speed limit -> curve radius
CURVE_RADIUS_RANGE = (60.0, 400.0)  # [m]

EGO_BLUEPRINT = "vehicle.lincoln.mkz_2017"  # the ego's body when it is a car (CARLA's usual ego vehicle); an ego of
# another type (a truck, a motorcycle) is drawn from its type's pool like any actor: its body is the report's
BLUEPRINT_POOLS: dict[str, tuple[str, ...]] = {
    "car": ("vehicle.nissan.patrol", "vehicle.tesla.model3", "vehicle.dodge.charger_2020",
            "vehicle.toyota.prius", "vehicle.mercedes.coupe_2020", "vehicle.audi.a2"),
    "truck": ("vehicle.carlamotors.european_hgv",),
    "motorcycle": ("vehicle.yamaha.yzf", "vehicle.kawasaki.ninja", "vehicle.harley-davidson.low_rider"),
}
# [m] (length, width) per blueprint, from CARLA 0.9.16 bounding boxes (Scenic's blueprint data)
BLUEPRINT_DIMS: dict[str, tuple[float, float]] = {
    "vehicle.lincoln.mkz_2017": (4.90, 2.13),
    "vehicle.nissan.patrol": (5.59, 2.15),
    "vehicle.tesla.model3": (4.79, 2.16),
    "vehicle.dodge.charger_2020": (5.01, 1.88),
    "vehicle.toyota.prius": (4.51, 2.01),
    "vehicle.mercedes.coupe_2020": (4.67, 1.81),
    "vehicle.audi.a2": (3.71, 1.79),
    "vehicle.carlamotors.european_hgv": (7.94, 2.89),
    "vehicle.yamaha.yzf": (2.19, 0.87),
    "vehicle.kawasaki.ninja": (2.04, 0.80),
    "vehicle.harley-davidson.low_rider": (2.35, 0.77),
}

TIME_OF_DAY_HOUR: dict[TimeOfDay, float] = {  # [h] local clock time
    TimeOfDay.DAYTIME: 12.0, TimeOfDay.NIGHTTIME: 22.0, TimeOfDay.DAWN: 6.0, TimeOfDay.DUSK: 19.0,
    TimeOfDay.NOT_MENTIONED: 12.0,
}
# Weather x light -> CARLA weather preset; light is Noon (day), Sunset (dawn, dusk) or Night.
WEATHER_PRESET: dict[Weather, str] = {
    Weather.CLEAR: "Clear", Weather.CLOUDY: "Cloudy", Weather.OVERCAST: "Cloudy", Weather.RAINY: "Wet",
    Weather.SNOWY: "WetCloudy", Weather.FOGGY: "Cloudy", Weather.WINDY: "Cloudy", Weather.NOT_MENTIONED: "Clear",
}
LIGHT_SUFFIX: dict[TimeOfDay, str] = {
    TimeOfDay.DAYTIME: "Noon", TimeOfDay.NIGHTTIME: "Night", TimeOfDay.DAWN: "Sunset", TimeOfDay.DUSK: "Sunset",
    TimeOfDay.NOT_MENTIONED: "Noon",
}
CARLA_TOWNS = {"straight": "Town02", "straight_multilane": "Town04", "curve": "Town02",
               "intersection": "Town05", "t_intersection": "Town05"}

# Behaviour -> route intent (sampled scenes) and junction manoeuvre (Scenic ManeuverType name).
ROUTE_INTENT: dict[Behavior, str] = {
    Behavior.GO_FORWARD: "straight", Behavior.TURN_LEFT: "left", Behavior.TURN_RIGHT: "right",
    Behavior.U_TURN: "u_turn", Behavior.CHANGE_LANE_LEFT: "lane_change_left",
    Behavior.CHANGE_LANE_RIGHT: "lane_change_right", Behavior.CROSS_CENTERLINE: "lane_change_left",
    Behavior.OVERTAKE: "lane_change_left", Behavior.DECELERATE: "straight", Behavior.STOP: "straight",
    Behavior.STATIC: "none", Behavior.LOSE_CONTROL: "straight", Behavior.LEAVE_ROAD: "none",
}
MANEUVER: dict[Behavior, str] = {
    Behavior.TURN_LEFT: "LEFT_TURN", Behavior.TURN_RIGHT: "RIGHT_TURN", Behavior.U_TURN: "LEFT_TURN",
}  # every other behaviour goes straight through a junction
STANDING_BEHAVIORS = {Behavior.STOP, Behavior.STATIC}  # initial speed 0 [m/s]
# Relative heading of each DSL heading token [rad], counter-clockwise from the ego's direction of travel.
HEADING_ANGLE: dict[Heading, float] = {
    Heading.SAME_DIRECTION: 0.0, Heading.FROM_RIGHT: 1.5707963267948966,
    Heading.OPPOSITE_DIRECTION: 3.141592653589793, Heading.FROM_LEFT: -1.5707963267948966,
}
OPPOSITE_COS = -0.5  # [-] cosine of the relative heading below which two actors travel in opposite directions
# (beyond 120 deg: HEADING_ANGLE's opposite_direction, not a crossing from the left or right)
JUNCTION_ELEMENTS = {RoadElement.INTERSECTION, RoadElement.STOP_SIGN, RoadElement.YIELD_SIGN,
                     RoadElement.TRAFFIC_LIGHT}

TOKEN = re.compile(r"^[A-Za-z0-9_.\-]{1,64}$")


# ---------------------------------------------------------------- plan models


class Placement(StrEnum):
    """How an actor is placed relative to its reference (see module docstring)."""

    ANCHOR = "anchor"  # the ego: EGO_INIT_DIST before (behind) or after (front) the anchor
    FOLLOW = "follow"  # same route as the reference actor, ahead (+) or behind (-) by NPC_INIT_DIST
    SIDE_LEFT = "side_left"  # adjacent lane to the left, same direction, small longitudinal offset
    SIDE_RIGHT = "side_right"
    ONCOMING = "oncoming"  # nearest opposite-direction lane, ahead of the reference by ONCOMING_DIST
    APPROACH = "approach"  # another approach of the junction, NPC_INIT_DIST before its entry


class Range(BaseModel):
    """A sampled parameter: uniform on [low, high] (low == high: a constant)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    low: float
    high: float


class ActorPlan(BaseModel):
    model_config = ConfigDict(extra="forbid")

    role: str
    label: str | None = Field(description="report label when it is a plain token, else None")
    type: str
    behavior: str
    blueprints: list[str] = Field(description="pool the blueprint is drawn from (one entry: fixed)")
    reference: str
    relation: str
    heading_relation: str | None
    placement: Placement
    placement_ref: str = Field(description="actor the placement is relative to (ego for the anchor itself)")
    along: str = Field(description="front | behind: direction of the placement distance along the route")
    relative_heading: float = Field(description="[rad] expected heading relative to the ego, CCW")
    maneuver: str = Field(description="junction manoeuvre: STRAIGHT | LEFT_TURN | RIGHT_TURN")
    route_intent: str
    speed: Range = Field(description="[m/s] initial and cruise speed")
    init_dist: Range = Field(description="[m] distance to the anchor / reference actor")
    side_offset: Range = Field(description="[m] longitudinal offset when beside the reference")
    arrival_offset: Range | None = Field(default=None, description="[s] conflict-point timing offset vs the ego")
    maneuver_time: Range = Field(description="[s] start of the behaviour's manoeuvre")
    stop_duration: Range = Field(description="[s] how long a stopping actor waits")
    dispositions: list[str]
    controlled_by: str | None = Field(default=None, description="traffic control device on the actor's approach")
    centre_lane: bool = Field(default=False, description="starts in the lane beside the centre line: it crosses "
                                                         "the centre line, or meets head-on one that does")


class MapSpec(BaseModel):
    """What the generated map must provide (also hashed into the map cache key)."""

    model_config = ConfigDict(extra="forbid")

    topology: str
    lanes_forward: int = Field(description="lanes in the ego's direction")
    lanes_backward: int = Field(description="lanes in the opposite direction")
    cross_lanes: int = Field(default=1, description="lanes per direction on crossing roads")
    center_mark: str
    speed_limit: float | None = Field(description="[m/s]")
    curve_direction: str | None = None
    curve_radius: float | None = Field(default=None, description="[m]")
    curve_angle: float | None = Field(default=None, description="[rad]")
    back_length: float = Field(description="[m] road before the anchor")
    ahead_length: float = Field(description="[m] road after the anchor")
    arms: list[str] = Field(default_factory=list,
                            description="junction arms by side as the ego approaches: ego, left, right, opposite")
    controls: dict[str, str] = Field(default_factory=dict, description="arm -> stop_sign | yield_sign | traffic_light")


class RenderPlan(BaseModel):
    model_config = ConfigDict(extra="forbid")

    scenario_id: str | None
    topology: str
    weather: str
    time_of_day: str
    road_surface: str
    carla_weather: str
    hour: float
    speed_limit: float | None = Field(description="[m/s]")
    number_of_ways: int
    number_of_lanes: int
    road_marker: str
    traffic_signs: list[str]
    curve_direction: str | None
    horizon: float = Field(description="[s]")
    map: MapSpec
    actors: list[ActorPlan]
    notes: list[str] = Field(default_factory=list, description="decisions the converter took (comments only)")


# ---------------------------------------------------------------- conversion


def convert(scenario: Scenario, horizon: float = HORIZON) -> RenderPlan:
    """Decide everything the template needs; raises RenderError on a scenario that cannot be placed."""
    rn = scenario.road_network
    env = scenario.environment
    topology = rn.road_type.value
    junction = rn.road_type in JUNCTIONS
    notes: list[str] = []
    speed_limit = rn.speed_limit_mph * MPH if rn.speed_limit_mph else None
    dispositions: dict[str, list[str]] = {}
    for entry in scenario.oracle:
        dispositions.setdefault(entry.actor, [])
        if entry.code not in dispositions[entry.actor]:
            dispositions[entry.actor].append(entry.code)
    for name in dispositions:
        if name not in scenario.actors:
            notes.append(f"oracle names {name}, which is not an actor; its codes are not attributed")

    basis = speed_basis(speed_limit, junction, rn.number_of_ways, rn.number_of_lanes)
    approach = speed_basis(speed_limit, False, rn.number_of_ways, rn.number_of_lanes)
    actors = [_actor_plan(name, actor, scenario, junction, (basis, approach), dispositions.get(name, []), notes)
              for name, actor in scenario.actors.items()]
    _queue(actors)
    _standing_leads(actors, notes)
    _check_references(actors)
    _centre_lanes(actors, scenario)
    plan_map = _map_spec(scenario, actors, speed_limit, basis, horizon, notes)
    for actor in actors:
        actor.controlled_by = plan_map.controls.get(_arm_of(actor)) if junction else None
    return RenderPlan(
        scenario_id=scenario.scenario_id if scenario.scenario_id and TOKEN.match(scenario.scenario_id) else None,
        topology=topology, weather=env.weather.value, time_of_day=env.time_of_day.value,
        road_surface=env.road_surface.value, carla_weather=carla_weather(env.weather, env.time_of_day,
                                                                        env.road_surface.value),
        hour=TIME_OF_DAY_HOUR[env.time_of_day], speed_limit=speed_limit, number_of_ways=rn.number_of_ways,
        number_of_lanes=rn.number_of_lanes, road_marker=rn.road_marker.value,
        traffic_signs=[s.value for s in rn.traffic_signs],
        curve_direction=rn.curve_direction.value if rn.curve_direction else None,
        horizon=horizon, map=plan_map, actors=actors, notes=notes)


def carla_weather(weather: Weather, time_of_day: TimeOfDay, surface: str = "not_mentioned") -> str:
    """CARLA weather preset name, e.g. clear + nighttime -> ClearNight, rainy + daytime -> WetNoon."""
    base = WEATHER_PRESET[weather]
    if base == "Clear" and surface in ("wet", "icy", "snowy"):
        base = "Wet"
    return base + LIGHT_SUFFIX[time_of_day]


def speed_basis(speed_limit: float | None, junction: bool, number_of_ways: int, number_of_lanes: int) -> float:
    """[m/s] the limit unstated speeds are sampled by: the posted one, else the one the speed rules apply where
    none is posted (`unposted_limit`: in the junction when `junction`), so that the traffic a report is silent
    about drives as fast as the monitor allows on that road (a rural two-lane road at 55 mph, not 22)."""
    return speed_limit or unposted_limit(number_of_ways, number_of_lanes, in_junction=junction)


def speed_range(actor: Actor, limits: tuple[float, float], codes: list[str] | tuple[str, ...] = ()) -> Range:
    """[m/s] stated speed +-SPEED_SPREAD (or 10 %); else, by the limits (`speed_basis`: where the actor drives, and
    on its approach), up to the first for a law-abiding actor ([limit - 2 spread, limit]) and around the second for
    one the oracle charges with a code whose rule injects speeding (CVC_22349, CVC_22350: `Rule.disposition`): a
    speeder is judged on its approach too, where no junction limit applies."""
    if actor.behavior in STANDING_BEHAVIORS:
        return Range(low=0.0, high=0.0)
    speeding = Disposition.SPEEDING in dispositions_of(codes)
    speed_limit = limits[1] if speeding else limits[0]
    nominal = actor.speed_mph * MPH if actor.speed_mph else speed_limit
    spread = max(SPEED_SPREAD, SPEED_SPREAD_FRACTION * nominal)
    if not actor.speed_mph and not speeding:
        return Range(low=round(max(MIN_MOVING_SPEED, speed_limit - 2 * spread), 3), high=round(speed_limit, 3))
    return Range(low=round(max(MIN_MOVING_SPEED, nominal - spread), 3), high=round(nominal + spread, 3))


def _actor_plan(name: str, actor: Actor, scenario: Scenario, junction: bool, limits: tuple[float, float],
                codes: list[str], notes: list[str]) -> ActorPlan:
    pos = actor.position
    heading = pos.heading
    if name == "ego":
        placement, ref, heading = Placement.ANCHOR, "ego", None
    else:
        if heading is None:
            heading = Heading.OPPOSITE_DIRECTION  # reference pipeline default
            notes.append(f"{name}: no heading given; opposite_direction assumed")
        placement, ref = _placement(name, pos.reference, pos.relation, heading, junction, scenario, notes)
    label = actor.label if actor.label and TOKEN.match(actor.label) else None
    maneuver = MANEUVER.get(actor.behavior, "STRAIGHT")
    if actor.behavior is Behavior.U_TURN and junction:
        notes.append(f"{name}: u_turn has no junction manoeuvre on lane-linked maps; left turn path used")
    arrival = Range(low=ARRIVAL_OFFSET[0], high=ARRIVAL_OFFSET[1]) if placement is Placement.APPROACH else None
    dist = ONCOMING_DIST if placement is Placement.ONCOMING else INIT_DIST
    return ActorPlan(
        role=name, label=label, type=actor.type.value, behavior=actor.behavior.value,
        blueprints=blueprint_pool(name, actor),
        reference=pos.reference, relation=pos.relation.value,
        heading_relation=pos.heading.value if pos.heading else None, placement=placement, placement_ref=ref,
        along=_along(name, pos.relation),
        relative_heading=HEADING_ANGLE[heading] if heading else 0.0, maneuver=maneuver,
        route_intent=ROUTE_INTENT[actor.behavior], speed=speed_range(actor, limits, codes),
        init_dist=Range(low=dist[0], high=dist[1]), side_offset=Range(low=SIDE_OFFSET[0], high=SIDE_OFFSET[1]),
        arrival_offset=arrival, maneuver_time=Range(low=MANEUVER_TIME[0], high=MANEUVER_TIME[1]),
        stop_duration=Range(low=STOP_DURATION[0], high=STOP_DURATION[1]), dispositions=codes)


def blueprint_pool(name: str, actor: Actor) -> list[str]:
    """The blueprints an actor's body is drawn from: the ego car's fixed one, else its type's pool (a truck ego is
    a truck's size, not the ego car's)."""
    if name == "ego" and actor.type.value == "car":
        return [EGO_BLUEPRINT]
    return list(BLUEPRINT_POOLS[actor.type.value])


def _along(name: str, relation: Relation) -> str:
    """front | behind along the route. The ego approaching a road element from its left or right is behind it
    (dsl.md: left|right = approaching it from that side); an NPC beside or oncoming counts as ahead."""
    if name == "ego":
        return "front" if relation is Relation.FRONT else "behind"
    return "behind" if relation is Relation.BEHIND else "front"


def _placement(name: str, reference: str, relation: Relation, heading: Heading, junction: bool,
               scenario: Scenario, notes: list[str]) -> tuple[Placement, str]:
    """Placement kind and the actor it is relative to, from the DSL position of an NPC."""
    is_actor = reference == "ego" or reference in scenario.actors
    if reference != "ego" and reference.startswith("npc") and reference not in scenario.actors:
        raise RenderError(f"actors.{name}.position.reference: {reference!r} is not an actor of this scenario "
                          f"(allowed: {', '.join(scenario.actors)}, or a road element)")
    if reference == name:
        raise RenderError(f"actors.{name}.position.reference: an actor cannot be placed relative to itself")
    ref = reference if is_actor else "ego"
    crossing = heading in (Heading.FROM_LEFT, Heading.FROM_RIGHT)
    if junction and (crossing or (heading is Heading.OPPOSITE_DIRECTION and relation is Relation.FRONT)
                     or (not is_actor and heading is Heading.OPPOSITE_DIRECTION)):
        return Placement.APPROACH, "ego"
    if crossing:
        notes.append(f"{name}: {heading.value} on a {scenario.road_network.road_type.value} road has no crossing "
                     f"approach; placed in the adjacent lane on that side")
        return (Placement.SIDE_LEFT if heading is Heading.FROM_LEFT else Placement.SIDE_RIGHT), ref
    if heading is Heading.OPPOSITE_DIRECTION:
        return Placement.ONCOMING, ref
    if relation is Relation.LEFT:
        return Placement.SIDE_LEFT, ref
    if relation is Relation.RIGHT:
        return Placement.SIDE_RIGHT, ref
    return Placement.FOLLOW, ref


def _queue(actors: list[ActorPlan]) -> None:
    """Actors sharing a slot (two followers behind the ego, two vehicles in the lane on its right, two oncoming)
    queue up in that lane instead of being drawn on top of each other: each is placed behind or ahead of the
    previous one. Overtakers queue last, behind the vehicle they pass."""
    groups: dict[tuple[str, str, str], list[ActorPlan]] = {}
    for actor in actors:
        if actor.placement in (Placement.FOLLOW, Placement.SIDE_LEFT, Placement.SIDE_RIGHT, Placement.ONCOMING):
            key = (actor.placement_ref, actor.placement.value,
                   actor.along if actor.placement is Placement.FOLLOW else "")
            groups.setdefault(key, []).append(actor)
    for (_, kind, _), members in groups.items():
        members.sort(key=lambda a: a.behavior == Behavior.OVERTAKE.value)
        for previous, actor in itertools.pairwise(members):
            actor.placement_ref = previous.role
            if kind == Placement.ONCOMING.value:
                actor.placement, actor.along = Placement.FOLLOW, "behind"
                actor.init_dist = Range(low=INIT_DIST[0], high=INIT_DIST[1])
            elif kind != Placement.FOLLOW.value:
                actor.placement, actor.along = Placement.FOLLOW, "front"


def _standing_leads(actors: list[ActorPlan], notes: list[str]) -> None:
    """A stopped or parked vehicle directly ahead of the ego is placed STANDING_LEAD_TIME away rather than
    INIT_DIST: 15-20 m at highway speed is a crash no driver could avoid, which tests nothing."""
    ego = next(a for a in actors if a.role == "ego")
    for actor in actors:
        standing = actor.behavior in (Behavior.STOP.value, Behavior.STATIC.value)
        if standing and actor.placement is Placement.FOLLOW and actor.placement_ref == "ego" and actor.along == "front":
            low = max(INIT_DIST[0], round(STANDING_LEAD_TIME[0] * ego.speed.high, 1))
            high = max(INIT_DIST[1], round(STANDING_LEAD_TIME[1] * ego.speed.high, 1))
            actor.init_dist = Range(low=low, high=high)
            notes.append(f"{actor.role}: standing ahead of the ego; placed {low:g}-{high:g} m ahead "
                         f"({STANDING_LEAD_TIME[0]:g}-{STANDING_LEAD_TIME[1]:g} s at the ego's top speed)")


def _centre_lanes(actors: list[ActorPlan], scenario: Scenario) -> None:
    """Mark the actors that start in the lane beside the centre line (`centre_lane`). A driver crosses the centre
    line from the lane next to it, into the nearest opposing lane (dsl.md: `cross_centerline` enters the opposing
    lanes, `overtake` passes through the opposing lane); and two vehicles travelling in opposite directions, neither
    turning, meet only across the centre line (one crosses it, or is pushed or skids over it), so both of a written
    contact between them travel in the lanes beside it, the fewest lanes apart. Without this, a road with more lanes
    than two may start either in an outer lane, one or more lanes away from where the crossing happens. A follower
    shares its reference's lane, so the reference takes the mark as well. Only a preference:
    `scenic_support.candidates` drops it where no placement can honour it (e.g. an actor written beside another on
    its left)."""
    by_role = {a.role: a for a in actors}
    centre = {a.role for a in actors if a.behavior in OPPOSING_PASSES}
    for contact in scenario.collisions or ():
        one, other = by_role.get(contact.striking), by_role.get(contact.struck)
        if one is None or other is None or one.behavior in MANEUVER or other.behavior in MANEUVER:
            continue  # a turn at a junction crosses the other's path from any lane (setup._choose_crossing_lanes)
        if math.cos(one.relative_heading - other.relative_heading) < OPPOSITE_COS:
            centre |= {one.role, other.role}
    grown = True
    while grown:
        followed = {a.placement_ref for a in actors if a.role in centre and a.placement is Placement.FOLLOW}
        grown = not followed <= centre
        centre |= followed
    for actor in actors:
        actor.centre_lane = actor.role in centre


def _check_references(actors: list[ActorPlan]) -> None:
    """Actors must be placeable in order: each reference placed before the actor (no cycles)."""
    placed = {"ego"}
    pending = [a for a in actors if a.role != "ego"]
    while pending:
        ready = [a for a in pending if a.placement_ref in placed]
        if not ready:
            raise RenderError("actors reference each other in a cycle: "
                              + ", ".join(f"{a.role} -> {a.placement_ref}" for a in pending))
        for actor in ready:
            placed.add(actor.role)
            pending.remove(actor)


def search_parameters(plan: RenderPlan, actor: ActorPlan, prefix: str,
                      is_ads: bool) -> list[tuple[str, Range, str]]:
    """(name, range, unit note) of the choices the embedded simulator or Scenic would draw per variation for
    `actor` (its parameters' prefix: EGO, npc1, ...), declared as sampled parameters for a search: unless the ADS
    drives it, a lateral manoeuvre's `<prefix>_LEAD_TIME`, a loss of control's `<prefix>_SKID_ROTATION` and a
    pull-out's `<prefix>_PULL_OUT_TTA` (a stop- or yield-controlled actor charged with not yielding); for any
    actor whose vehicle model Scenic draws from a pool, `<prefix>_MODEL_INDEX` (the pool in `model_pool` order
    at the value's integer part: a uniform value draws each model as often as the plain program does); on the
    ADS, the green its axis has left when it reaches a signalised junction (`SIGNAL_GREEN_REMAINING`)."""
    out: list[tuple[str, Range, str]] = []
    behavior = Behavior(actor.behavior)
    if behavior in LATERAL_BEHAVIORS and not is_ads:
        out.append((f"{prefix}_LEAD_TIME", Range(low=LEAD_TIME[0], high=LEAD_TIME[1]),
                    "[s] the manoeuvre is under way this long before meeting its partner"))
    if behavior is Behavior.LOSE_CONTROL and not is_ads:
        out.append((f"{prefix}_SKID_ROTATION", Range(low=SKID_ROTATION[0], high=SKID_ROTATION[1]),
                    "[-] where in its range the skid's rotation at contact falls"))
    if actor.controlled_by in (Sign.STOP_SIGN.value, Sign.YIELD_SIGN.value) and behavior in PULL_OUT_BEHAVIORS \
            and Disposition.NO_YIELD in dispositions_of(actor.dispositions) and not is_ads:
        out.append((f"{prefix}_PULL_OUT_TTA", Range(low=PULL_OUT_TTA_RANGE[0], high=PULL_OUT_TTA_RANGE[1]),
                    "[s] test mode: pulls out when the ADS is this far in time from the conflict point"))
    if len(actor.blueprints) > 1:
        out.append((f"{prefix}_MODEL_INDEX", Range(low=0.0, high=float(len(actor.blueprints))),
                    "[-] vehicle model: the pool, smallest first, at the integer part of the value"))
    if is_ads and Sign.TRAFFIC_LIGHT.value in plan.traffic_signs \
            and plan.topology in JUNCTIONS:
        out.append(("SIGNAL_GREEN_REMAINING", Range(low=SIGNAL_GREEN[0], high=SIGNAL_GREEN[1]),
                    "[s] green left for the ADS's axis when it reaches the junction"))
    return out


def model_pool(blueprints: list[str]) -> list[str]:
    """A blueprint pool ordered by footprint area [m2] (its size lengthwise and crosswise at once: a longer or a
    wider body meets another vehicle's path earlier), as a search's `<prefix>_MODEL_INDEX` indexes it, so that
    neighbouring values are vehicles of similar size."""
    return sorted(blueprints, key=lambda bp: (BLUEPRINT_DIMS[bp][0] * BLUEPRINT_DIMS[bp][1], bp))


def placement_order(actors: list[ActorPlan]) -> list[ActorPlan]:
    """Actors sorted so that every reference comes before the actors placed against it."""
    order, placed, pending = [], set(), list(actors)
    while pending:
        for actor in list(pending):
            if actor.role == "ego" or actor.placement_ref in placed:
                order.append(actor)
                placed.add(actor.role)
                pending.remove(actor)
    return order


def _arm_of(actor: ActorPlan) -> str:
    """Junction arm an actor approaches from, as the ego sees it."""
    if actor.placement is not Placement.APPROACH:
        return "ego"
    return {0.0: "ego", 3.141592653589793: "opposite", 1.5707963267948966: "right",
            -1.5707963267948966: "left"}[actor.relative_heading]


def _map_spec(scenario: Scenario, actors: list[ActorPlan], speed_limit: float | None, basis: float, horizon: float,
              notes: list[str]) -> MapSpec:
    """The map: `speed_limit` the posted limit [m/s] it carries (None: none posted), `basis` the one speeds and the
    curve's radius are chosen by (`speed_basis`)."""
    rn = scenario.road_network
    ways, lanes = rn.number_of_ways, rn.number_of_lanes
    forward = lanes if ways == 1 else max(1, (lanes + 1) // 2)
    backward = 0 if ways == 1 else max(1, lanes - forward)
    need_left, need_right = _side_lanes_needed(actors)
    if need_left + need_right + 1 > forward:
        notes.append(f"{forward} lane(s) in the ego's direction cannot hold the side placements "
                     f"({need_left} left, {need_right} right); generated map widened")
        forward = need_left + need_right + 1
    oncoming = any(a.placement is Placement.ONCOMING or a.behavior in OPPOSING_PASSES
                   or (a.placement is Placement.APPROACH and a.relative_heading == 3.141592653589793)
                   for a in actors)
    if backward == 0 and oncoming:
        notes.append("one-way roadway with an oncoming actor or a centre-line crossing; generated map adds the "
                     "opposing carriageway")
        backward = forward
    v_max = max([a.speed.high for a in actors] + [basis])
    run = v_max * horizon  # [m] distance one actor can cover in the horizon
    farthest = max([ONCOMING_DIST[1]] + [a.init_dist.high for a in actors])
    reach = farthest + SIDE_OFFSET[1] + 2 * INIT_DIST[1] + 20.0  # [m] furthest initial placement
    back = STRAIGHT_BACK + INIT_DIST[1] * 2
    ahead = run + reach
    if oncoming:
        back = max(back, run)  # oncoming actors drive past the ego's start
    spec = {"topology": rn.road_type.value, "lanes_forward": forward, "lanes_backward": backward,
            "center_mark": rn.road_marker.value, "speed_limit": speed_limit, "back_length": round(back, 1),
            "ahead_length": round(ahead, 1)}
    if rn.road_type is RoadType.CURVE:
        radius = min(max(basis ** 2 / CURVE_LATERAL_ACC, CURVE_RADIUS_RANGE[0]), CURVE_RADIUS_RANGE[1])
        direction = rn.curve_direction.value if rn.curve_direction else "left"
        if rn.curve_direction is None:
            notes.append("curve_direction not stated; left assumed")
        spec.update(curve_direction=direction, curve_radius=round(radius, 1), curve_angle=CURVE_ANGLE)
    if rn.road_type in JUNCTIONS:
        spec.update(arms=_junction_arms(rn.road_type, actors, notes),
                    controls=_controls(scenario, actors), ahead_length=round(run + reach, 1),
                    back_length=round(max(back, run + reach), 1))
        spec["controls"] = {arm: dev for arm, dev in spec["controls"].items() if arm in spec["arms"]}
    return MapSpec(**spec)


def _side_lanes_needed(actors: list[ActorPlan]) -> tuple[int, int]:
    """Same-direction lanes the ego's lane needs on its left and right."""
    left = right = 0
    by_role = {a.role: a for a in actors}
    ego = by_role["ego"]
    if ego.behavior == Behavior.CHANGE_LANE_LEFT.value:
        left = 1
    if ego.behavior == Behavior.CHANGE_LANE_RIGHT.value:
        right = 1
    for actor in actors:
        if actor.placement_ref != "ego":
            continue
        if actor.placement is Placement.SIDE_LEFT:
            left = max(left, 1 + (actor.behavior == Behavior.CHANGE_LANE_LEFT.value))
        if actor.placement is Placement.SIDE_RIGHT:
            right = max(right, 1 + (actor.behavior == Behavior.CHANGE_LANE_RIGHT.value))
    return left, right


def _junction_arms(road_type: RoadType, actors: list[ActorPlan], notes: list[str]) -> list[str]:
    """Arms of the generated junction; for a T, the layout that serves every actor's approach and turn."""
    if road_type is RoadType.INTERSECTION:
        return ["ego", "left", "opposite", "right"]
    layouts = [["ego", "opposite", "right"], ["ego", "opposite", "left"], ["ego", "left", "right"]]

    def score(arms: list[str]) -> int:
        ok = 0
        for actor in actors:
            arm = _arm_of(actor)
            if arm not in arms:
                continue
            exits = _exits(arm, arms)
            need = {"STRAIGHT": "straight", "LEFT_TURN": "left", "RIGHT_TURN": "right"}[actor.maneuver]
            ok += 2 + (need in exits)
        return ok

    best = max(layouts, key=score)
    if score(best) < 3 * len(actors):
        notes.append("no T layout serves every actor's approach and turn; closest layout used: " + ",".join(best))
    return best


def _exits(arm: str, arms: list[str]) -> set[str]:
    """Manoeuvres available from `arm` (ego-relative sides) on a junction with these arms."""
    order = ["ego", "right", "opposite", "left"]  # counter-clockwise sequence of arm positions around the centre
    i = order.index(arm)
    out = set()
    for other in arms:
        if other == arm:
            continue
        d = (order.index(other) - i) % 4
        out.add({1: "right", 2: "straight", 3: "left"}[d])
    return out


def _controls(scenario: Scenario, actors: list[ActorPlan]) -> dict[str, str]:
    """Arm -> control device, per the DSL rule: a device controls the approach of every actor that names it,
    else the ego's; a traffic light signals every approach."""
    signs = set(scenario.road_network.traffic_signs)
    controls: dict[str, str] = {}
    if Sign.TRAFFIC_LIGHT in signs:
        return {arm: "traffic_light" for arm in ("ego", "left", "opposite", "right")}
    for sign in (Sign.STOP_SIGN, Sign.YIELD_SIGN):
        if sign not in signs:
            continue
        naming = [a for a in actors if a.reference == sign.value]
        arms = {_arm_of(a) for a in naming} or {"ego"}
        for arm in arms:
            controls[arm] = sign.value
    return controls


def scenario_hash(scenario: Scenario, **options: object) -> str:
    """Stable hash of the canonical DSL text plus render options (16 hex chars)."""
    from crashscene.dsl import dumps

    text = dumps(scenario) + "\n" + "\n".join(f"{k}={options[k]}" for k in sorted(options))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
