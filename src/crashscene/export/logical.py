"""The logical scenario (`scenario.xosc`) and its parameter distribution (`distribution.xosc`).

scenario.xosc declares one parameter per program parameter (defaults: the values of a
reference scene, scene 0 of the export's seed) and builds:
- entities: one vehicle per DSL actor (model `$ROLE_MODEL` where Scenic draws it from a pool);
- init: each actor on its lane, its road coordinate s written as an expression of the
  placement parameters (`${s0 - ($EGO_INIT_DIST - d0)}`), so the position moves with them
  as the program's placement does (to first order on bends); its speed `$ROLE_SPEED`;
  a route (AssignRouteAction) through the junction to its exit for actors that cross one;
- storyboard: the DSL behaviour as actions with simulation-time triggers
  (`$ROLE_MANEUVER_TIME`, `$ROLE_STOP_DURATION`): lane change, centre-line crossing,
  overtaking and back, braking to a stop, stop-and-go, loss of control and leaving the
  road as lateral offsets; the stop trigger is the horizon.
distribution.xosc: a stochastic ParameterValueDistribution over scenario.xosc: a
UniformDistribution per ranged parameter (the program's VerifaiRange bounds) and a
ProbabilityDistributionSet (equal weights) per model pool.

Not expressible and left to the concrete variations: the choice among placement
candidates (which lane of a multi-lane approach; the reference scene's is used) and
`*_ARRIVAL_OFFSET` (the embedded simulator's conflict timing; declared and
distributed, not used by an action, as OpenSCENARIO synchronises positions, not time offsets).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from scenariogeneration import xosc

from crashscene.dsl.tokens import LANE_CHANGES, STANDING
from crashscene.export.errors import ExportError
from crashscene.export.program import ProgramSampling
from crashscene.export.roadframe import RoadFrame, RoadPoint
from crashscene.export.xosc_common import (
    AUTHOR,
    HEADER_DATE,
    OSC_MINOR,
    at_time,
    stop_after,
    vehicle,
)
from crashscene.geometry import LANE_WIDTH
from crashscene.render.plan import Placement, RenderPlan
from crashscene.scene import SampledActor, SampledScene

LANE_CHANGE_TIME = 3.0  # [s] sinusoidal lane change
OVERTAKE_HOLD = 3.0  # [s] in the opposing lane before returning (CsCrossCenterline back_after)
BRAKE_DECEL = 4.0  # [m/s2] CsBrakeForever(0.5)
PROCEED_ACCEL = 2.0  # [m/s2] stop-and-go pull-away
LOSS_DRIFT = 4.0  # [m] lateral drift per unit of held steering after control is lost
EXIT_DISTANCE = 30.0  # [m] route waypoint past the junction on the exit road
OFF_ROAD_MARGIN = 2.0  # [m] beyond the road edge for leave_road
MAX_OFF_LANE = 2.0  # [m] a start farther than this from every lane cannot be written as a lane position


@dataclass(frozen=True)
class Placed:
    """An actor's start in road coordinates and how its road s moves with the placement parameters."""

    actor: SampledActor
    point: RoadPoint
    ds: dict[str, float]  # parameter -> d(road s of the start)/d(parameter)


def prefix(role: str) -> str:
    return "EGO" if role == "ego" else role


def model_parameter(role: str) -> str:
    return f"{prefix(role)}_MODEL"


def _carrier_stations(plan: RenderPlan, scene: SampledScene) -> dict[str, tuple[str, dict[str, float]]]:
    """Per actor: the route its start is measured on (its own, or its reference's for side and oncoming
    placements: render.scenic_support projects a point of the reference's route), and how the start's station
    along that route moves with the placement parameters (the placement functions are sums of them)."""
    own: dict[str, dict[str, float]] = {}  # station along the actor's own route
    out: dict[str, tuple[str, dict[str, float]]] = {}
    plans = {a.role: a for a in plan.actors}
    for actor in scene.actors:
        ap = plans[actor.role]
        p = prefix(actor.role)
        sign = 1.0 if ap.along == "front" else -1.0
        ref = dict(own.get(ap.placement_ref, {})) if ap.placement_ref != actor.role else {}
        if ap.placement is Placement.ANCHOR:
            out[actor.role] = (actor.role, {f"{p}_INIT_DIST": sign})
        elif ap.placement is Placement.FOLLOW:
            out[actor.role] = (actor.role, {**ref, f"{p}_INIT_DIST": ref.get(f"{p}_INIT_DIST", 0.0) + sign})
        elif ap.placement in (Placement.SIDE_LEFT, Placement.SIDE_RIGHT):
            out[actor.role] = (ap.placement_ref, {**ref, f"{p}_SIDE_OFFSET": 1.0})
        elif ap.placement is Placement.ONCOMING:
            out[actor.role] = (ap.placement_ref, {**ref, f"{p}_INIT_DIST": sign})
        else:  # approach: INIT_DIST before its junction entry
            out[actor.role] = (actor.role, {f"{p}_INIT_DIST": -1.0})
        carrier, station = out[actor.role]
        own[actor.role] = station if ap.placement is not Placement.ONCOMING else {k: -v for k, v in station.items()}
    return out


def place(plan: RenderPlan, scene: SampledScene, frame: RoadFrame) -> list[Placed]:
    """Each actor's start on a lane, with d(road s)/d(parameter): a route station change moves the start by
    dir / (1 - curvature * t) in road s, t being the carrier lane's lateral offset (lanes are longer outside
    a bend), dir +1 on right-hand lanes (they run along +s)."""
    carriers = _carrier_stations(plan, scene)
    points = {}
    for actor in scene.actors:
        point = frame.locate(actor.x, actor.y)
        if point.distance > MAX_OFF_LANE:
            raise ExportError(f"{frame.path}: {actor.role} starts at ({actor.x:.1f}, {actor.y:.1f}) m, "
                              f"{point.distance:.1f} m off the nearest road's lanes; cannot express its start on a lane")
        points[actor.role] = point
    out = []
    for actor in scene.actors:
        point = points[actor.role]
        carrier_role, station = carriers[actor.role]
        carrier = points[carrier_role]
        if carrier.road == point.road:
            lane, t = carrier.lane, frame.lane_center(point.road, carrier.lane)
        else:  # reference on another road: the start's own lane stands in
            lane, t = point.lane, point.t
        scale = (1.0 if lane < 0 else -1.0) / (1.0 - frame.curvature(point.road, point.s) * t)
        out.append(Placed(actor, point, {k: v * scale for k, v in station.items()}))
    return out


def _s_expression(placed: Placed, values: dict[str, float | str]) -> str | float:
    """Road s of the actor's start as an OpenSCENARIO expression of the placement parameters."""
    terms = []
    for name, k in sorted(placed.ds.items()):
        if name not in values or k == 0.0:
            continue
        terms.append(f"{'+' if k > 0 else '-'} {_num(round(abs(k), 9))} * (${name} - {_num(float(values[name]))})")
    if not terms:
        return round(placed.point.s, 6)
    return "${" + _num(round(placed.point.s, 6)) + " " + " ".join(terms) + "}"


def _num(value: float) -> str:
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def build_logical(plan: RenderPlan, sampling: ProgramSampling, scene: SampledScene, map_path: Path,
                  map_ref: str = "map.xodr", network=None) -> xosc.Scenario:
    """The logical scenario for `plan`, placed like `scene` (the reference scene), on the map `map_path`."""
    frame = RoadFrame(map_path)
    values: dict[str, float | str] = {}
    params = xosc.ParameterDeclarations()
    scene_values = scene.params
    for par in sampling.parameters:
        value = float(scene_values.get(par.name, (par.low + par.high) / 2))
        values[par.name] = value
        params.add_parameter(xosc.Parameter(par.name, xosc.ParameterType.double, _num(value)))
    by_role = {a.role: a for a in scene.actors}
    for role in sampling.blueprint_pools:
        if role in by_role:
            params.add_parameter(xosc.Parameter(model_parameter(role), xosc.ParameterType.string,
                                                by_role[role].blueprint))
    placed = place(plan, scene, frame)

    entities = xosc.Entities()
    init = xosc.Init()
    story = xosc.Story("crash_sequence")
    act = xosc.Act("behaviours", at_time("act_start", 0.0))
    for item in placed:
        actor = item.actor
        name = f"${model_parameter(actor.role)}" if actor.role in sampling.blueprint_pools else actor.blueprint
        entities.add_scenario_object(actor.role, vehicle(name, actor.type, actor.length, actor.width,
                                                         actor.role == "ego"))
        lane_pos = xosc.LanePosition(_s_expression(item, values), 0.0, item.point.lane, item.point.road)
        init.add_init_action(actor.role, xosc.TeleportAction(lane_pos))
        speed = f"${prefix(actor.role)}_SPEED" if f"{prefix(actor.role)}_SPEED" in values else actor.speed
        if actor.behavior in STANDING:
            speed = 0.0
        init.add_init_action(actor.role, xosc.AbsoluteSpeedAction(
            speed, xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0.0)))
        route = _route(actor, item.point, frame, network)
        if route is not None:
            init.add_init_action(actor.role, xosc.AssignRouteAction(route))
        events = _behaviour_events(actor, item.point, frame, values)
        if events:
            maneuver = xosc.Maneuver(f"{actor.role}_{actor.behavior}")
            for event in events:
                maneuver.add_event(event)
            group = xosc.ManeuverGroup(f"{actor.role}_group")
            group.add_actor(actor.role)
            group.add_maneuver(maneuver)
            act.add_maneuver_group(group)
    if not act.maneuvergroup:
        group = xosc.ManeuverGroup("cruise_group")  # a storyboard needs one act with one group
        group.add_actor(placed[0].actor.role)
        group.add_maneuver(_hold_speed(placed[0].actor, values))
        act.add_maneuver_group(group)
    story.add_act(act)
    board = xosc.StoryBoard(init, stop_after(plan.horizon))
    board.add_story(story)
    return xosc.Scenario(
        f"crashscene {plan.scenario_id or 'scenario'} (logical)", AUTHOR, params, entities, board,
        xosc.RoadNetwork(map_ref), xosc.Catalog(), osc_minor_version=OSC_MINOR, creation_date=HEADER_DATE)


def _hold_speed(actor: SampledActor, values) -> xosc.Maneuver:
    maneuver = xosc.Maneuver(f"{actor.role}_cruise")
    event = xosc.Event(f"{actor.role}_keep_speed", xosc.Priority.override)
    speed = f"${prefix(actor.role)}_SPEED" if f"{prefix(actor.role)}_SPEED" in values else actor.speed
    event.add_action("keep_speed", xosc.AbsoluteSpeedAction(
        speed, xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0.0)))
    event.add_trigger(at_time(f"{actor.role}_start", 0.0))
    maneuver.add_event(event)
    return maneuver


def _route(actor: SampledActor, start: RoadPoint, frame: RoadFrame, network) -> xosc.Route | None:
    """Route through the junction: start lane -> exit road's lane, when the actor's route crosses a junction."""
    lanes = str(actor.properties.get("route_lanes") or "").split(",")
    roads = [uid.split("_", 1)[0] for uid in lanes if uid]
    if network is None or len(set(roads)) < 2:
        return None
    exit_uid = lanes[-1]
    try:
        exit_lane = network.elements[exit_uid]
        exit_road = str(exit_lane.road.uid).removeprefix("road")
        exit_id = int(exit_lane.sections[0].openDriveID)
    except (KeyError, AttributeError, IndexError, ValueError) as exc:
        raise ExportError(f"{actor.role}: route lane {exit_uid!r} is not on the map ({exc})") from exc
    if exit_road not in frame.roads or exit_road == start.road:
        return None
    length = frame.roads[exit_road][0]
    s_exit = length - EXIT_DISTANCE if exit_id > 0 else EXIT_DISTANCE  # left lanes run towards s = 0
    route = xosc.Route(f"{actor.role}_route")
    route.add_waypoint(xosc.LanePosition(round(start.s, 6), 0.0, start.lane, start.road), xosc.RouteStrategy.shortest)
    route.add_waypoint(xosc.LanePosition(round(min(max(s_exit, 0.0), length), 6), 0.0, exit_id, exit_road),
                       xosc.RouteStrategy.shortest)
    return route


def _event(name: str, action_name: str, action, start: float | str) -> xosc.Event:
    event = xosc.Event(name, xosc.Priority.override)
    event.add_action(action_name, action)
    event.add_trigger(at_time(f"{name}_time", start))
    return event


def _lane_change(role: str, lanes: int) -> xosc.RelativeLaneChangeAction:
    return xosc.RelativeLaneChangeAction(lanes, role, xosc.TransitionDynamics(
        xosc.DynamicsShapes.sinusoidal, xosc.DynamicsDimension.time, LANE_CHANGE_TIME))


def _behaviour_events(actor: SampledActor, start: RoadPoint, frame: RoadFrame, values) -> list[xosc.Event]:
    """The actor's DSL behaviour as timed OpenSCENARIO actions (none for cruising, turning, static)."""
    p, role, b = prefix(actor.role), actor.role, actor.behavior
    t_man = f"${p}_MANEUVER_TIME" if f"{p}_MANEUVER_TIME" in values else 0.0
    if b in LANE_CHANGES:
        return [_event(f"{role}_lane_change", "lane_change", _lane_change(role, 1 if b.endswith("left") else -1),
                       t_man)]
    if b == "cross_centerline":
        return [_event(f"{role}_cross_centerline", "cross_centerline", _lane_change(role, 1), t_man)]
    if b == "overtake":
        back = f"${{${p}_MANEUVER_TIME + {_num(LANE_CHANGE_TIME + OVERTAKE_HOLD)}}}" if isinstance(t_man, str) \
            else LANE_CHANGE_TIME + OVERTAKE_HOLD
        return [_event(f"{role}_pull_out", "pull_out", _lane_change(role, 1), t_man),
                _event(f"{role}_pull_back", "pull_back", _lane_change(role, -1), back)]
    if b == "decelerate":
        return [_event(f"{role}_brake", "brake", xosc.AbsoluteSpeedAction(0.0, xosc.TransitionDynamics(
            xosc.DynamicsShapes.linear, xosc.DynamicsDimension.rate, BRAKE_DECEL)), t_man)]
    if b == "stop":
        hold = f"${p}_STOP_DURATION" if f"{p}_STOP_DURATION" in values else 0.0
        proceed = f"${p}_PROCEED_SPEED" if f"{p}_PROCEED_SPEED" in values else max(actor.speed, 5.0)
        return [_event(f"{role}_go", "proceed", xosc.AbsoluteSpeedAction(proceed, xosc.TransitionDynamics(
            xosc.DynamicsShapes.linear, xosc.DynamicsDimension.rate, PROCEED_ACCEL)), hold)]
    if b == "lose_control":
        steer = f"${{${p}_LOSS_STEER * {_num(LOSS_DRIFT)}}}" if f"{p}_LOSS_STEER" in values else LOSS_DRIFT
        return [_event(f"{role}_lose_control", "drift", xosc.AbsoluteLaneOffsetAction(
            steer, xosc.DynamicsShapes.sinusoidal, maxlatacc=3.0, continuous=False), t_man)]
    if b == "leave_road":
        right = [w for lane, w in frame.roads[start.road][3 if start.lane < 0 else 2]]
        k = abs(start.lane)
        edge = sum(right[k:]) + (right[k - 1] / 2 if 0 < k <= len(right) else LANE_WIDTH / 2)
        return [_event(f"{role}_leave_road", "run_off", xosc.AbsoluteLaneOffsetAction(
            -(edge + OFF_ROAD_MARGIN), xosc.DynamicsShapes.sinusoidal, maxlatacc=3.0, continuous=False), t_man)]
    return []


def build_distribution(sampling: ProgramSampling, n: int, seed: int,
                       scenario_ref: str = "scenario.xosc") -> xosc.ParameterValueDistribution:
    """Stochastic distribution of the program's sampled parameters over `scenario_ref` (n runs, seed)."""
    stochastic = xosc.Stochastic(n, seed)
    count = 0
    for par in sampling.parameters:
        if par.sampled:
            stochastic.add_distribution(par.name, xosc.UniformDistribution(xosc.Range(par.low, par.high)))
            count += 1
    for role, pool in sampling.blueprint_pools.items():
        choice = xosc.ProbabilityDistributionSet()
        for model in pool:
            choice.add_set(model, 1.0)
        stochastic.add_distribution(model_parameter(role), choice)
        count += 1
    if count == 0:
        raise ExportError("the scenario samples no parameter: nothing to distribute")
    document = xosc.ParameterValueDistribution("crashscene parameter distribution (Scenic program ranges)", AUTHOR,
                                               scenario_ref, stochastic, osc_minor_version=OSC_MINOR)
    document.header.creation_date = HEADER_DATE
    return document


def build_parameter_sets(sampling: ProgramSampling, scenes: list[SampledScene],
                         scenario_ref: str = "scenario.xosc") -> xosc.ParameterValueDistribution:
    """Deterministic distribution: one ParameterValueSet per simulated scene (its drawn values), over `scenario_ref`.

    For players that run deterministic distributions only (esmini warns "Stochastic distributions not supported
    yet"): the logical scenario replayed with exactly the parameter values crashscene simulated.
    """
    if not scenes:
        raise ExportError("no simulated variation to list in parameter_sets.xosc")
    multi = xosc.DeterministicMultiParameterDistribution()
    for scene in scenes:
        values = xosc.ParameterValueSet()
        for par in sampling.parameters:
            if par.sampled:
                values.add_parameter(par.name, _num(float(scene.params.get(par.name, par.low))))
        blueprints = {a.role: a.blueprint for a in scene.actors}
        for role in sampling.blueprint_pools:
            if role in blueprints:
                values.add_parameter(model_parameter(role), blueprints[role])
        multi.add_value_set(values)
    deterministic = xosc.Deterministic()
    deterministic.add_multi_distribution(multi)
    document = xosc.ParameterValueDistribution("crashscene simulated parameter sets (one per exported variation)",
                                               AUTHOR, scenario_ref, deterministic, osc_minor_version=OSC_MINOR)
    document.header.creation_date = HEADER_DATE
    return document
