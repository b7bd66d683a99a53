"""Placement helpers imported by every rendered Scenic program (`from crashscene.render.scenic_support import *`).

Routes are lane chains; an actor stands at arc length s [m] along its route.
Candidate placements (which lanes, which junction manoeuvres) are enumerated
once, when the program is compiled; sampling picks one candidate and evaluates
a few arc-length lookups, so scenes are cheap. These live in a Python module
rather than in each program because Scenic's parser is slow on long programs
(~1 s per 400 lines) and turns classes defined in programs into Scenic classes.

Scenic conventions here: headings 0 = +y, counter-clockwise [rad]; lengths [m].
"""
import itertools as _itertools
import math as _math
from types import SimpleNamespace as _NS

import shapely as _shapely
from scenic.core.distributions import distributionFunction as _distributionFunction
from scenic.core.vectors import Vector
from scenic.domains.driving.roads import ManeuverType as _ManeuverType

from crashscene.geometry import wrap_angle as _wrap_angle

_MIN_LANE = 30.0  # [m] shortest lane an actor may start on
_LEAD_IN = 60.0  # [m] route length wanted before a junction entry or curve start


def _route(lanes, anchor):
    """A chain of lanes: centreline, arc-length offset of each lane, anchor arc length [m]."""
    lanes = tuple(lanes)
    coords, starts, total = [], [], 0.0
    for lane in lanes:
        pts = [tuple(p[:2]) for p in lane.centerline.lineString.coords]
        if coords and _math.dist(coords[-1], pts[0]) < 1e-6:
            pts = pts[1:]
        starts.append(total)
        total += lane.centerline.length
        coords.extend(pts)
    line = _shapely.LineString(coords)
    return _NS(lanes=lanes, starts=starts, line=line, length=line.length, anchor=anchor)


def _clamp(route, s, margin=3.0):
    return min(max(s, margin), max(margin, route.length - margin))


def _r_xy(route, s):
    p = route.line.interpolate(_clamp(route, s))
    return Vector(p.x, p.y)


def _r_heading(route, s):
    s = _clamp(route, s)
    a = route.line.interpolate(max(0.0, s - 1.0))
    b = route.line.interpolate(min(route.length, s + 1.0))
    return _math.atan2(-(b.x - a.x), b.y - a.y)  # Scenic heading: 0 = +y, counter-clockwise


def _r_lane_at(route, s):
    s = _clamp(route, s)
    index = 0
    for i, start in enumerate(route.starts):
        if s >= start:
            index = i
    return route.lanes[index]


def _r_project(route, point):
    return route.line.project(_shapely.Point(point[0], point[1]))


def _end_heading(lane):
    pts = lane.centerline.lineString.coords
    (x0, y0), (x1, y1) = tuple(pts[-2])[:2], tuple(pts[-1])[:2]
    return _math.atan2(-(x1 - x0), y1 - y0)


def _lead_in(lane, wanted=_LEAD_IN, connecting=frozenset()):
    """Predecessor lanes (outside junctions) prepended until the chain is `wanted` [m] long."""
    chain = [lane]
    total = lane.centerline.length
    seen = {lane}
    while total < wanted:
        prev = chain[0]._predecessor
        if prev is None or prev in seen or not hasattr(prev, "centerline") or prev.road in connecting:
            break
        chain.insert(0, prev)
        seen.add(prev)
        total += prev.centerline.length
    return chain


def _follow_on(lanes, wanted):
    """Successor lanes appended until the chain extends `wanted` [m] past its last element."""
    chain = list(lanes)
    total = 0.0
    seen = set(chain)
    while total < wanted:
        nxt = chain[-1]._successor
        if nxt is None or nxt in seen or not hasattr(nxt, "centerline"):
            break
        chain.append(nxt)
        seen.add(nxt)
        total += nxt.centerline.length
    return chain


def _section(lane, s_local):
    point = lane.centerline.lineString.interpolate(min(max(s_local, 0.0), lane.centerline.length))
    sec = lane.sectionAt(Vector(point.x, point.y))
    return sec if sec is not None else lane.sections[0]


def _side_lane(lane, s_local, side, steps=1):
    """Same-direction lane `steps` lanes to the left/right of `lane`, or None."""
    sec = _section(lane, s_local)
    for _ in range(steps):
        nxt = sec._laneToLeft if side == "left" else sec._laneToRight
        if nxt is None or nxt.isForward != sec.isForward:
            return None
        sec = nxt
    return sec.lane


def _oncoming_lane(lane, s_local=0.0, index=None):
    """The opposite-direction lane nearest the ego's side: the opposite lane group's innermost lane (the one nearest
    `lane` at `s_local` [m]: a group's order of lanes is not its order across the road, Scenic lists a backward
    group of a generated map centre line first), else (divided roads, CARLA highways) the nearest lane within
    30 m running the other way, from `index`; or None."""
    group = lane.group
    opposite = group._opposite if group is not None else None
    line = lane.centerline.lineString
    p = line.interpolate(min(max(s_local, 0.0), line.length))
    if opposite is not None and opposite.lanes:
        return min(opposite.lanes, key=lambda other: other.centerline.lineString.distance(p))
    if index is None:
        return None
    q = line.interpolate(min(max(s_local, 0.0) + 2.0, line.length))
    own = _math.atan2(-(q.x - p.x), q.y - p.y)
    best, best_d = None, 30.0
    tree, lanes = index
    for k in tree.query(p.buffer(30.0)):
        other = lanes[int(k)]
        if other is lane:
            continue
        oline = other.centerline.lineString
        d = oline.distance(p)
        if d >= best_d:
            continue
        t = oline.project(p)
        a, b = oline.interpolate(max(0.0, t - 1.0)), oline.interpolate(min(oline.length, t + 1.0))
        if abs(_wrap_angle(_math.atan2(-(b.x - a.x), b.y - a.y) - own)) > 2.6:
            best, best_d = other, d
    return best


def _lane_index(lanes):
    lanes = list(lanes)
    return _shapely.STRtree([lane.centerline.lineString for lane in lanes]), lanes


def _same_dir_count(lane, s_local, side):
    n = 0
    while _side_lane(lane, s_local, side, n + 1) is not None:
        n += 1
    return n


def _ego_lane_ok(lane, ego_roads):
    """Generated maps pin the ego to its designed road and direction (ego_roads empty: any lane)."""
    if not ego_roads:
        return True
    return lane.road.uid in ego_roads and lane.group is lane.road.forwardLanes


def _road_lanes(network):
    connecting = set(network.connectingRoads)
    return [lane for lane in network.lanes if lane.road not in connecting]


def _curve_start(lane, sign, min_turn, step=2.0):
    """Arc length [m] where `lane` starts turning towards `sign` (+1 left, -1 right) by `min_turn` [rad] in all,
    or None. The centreline is resampled every `step` [m]: Scenic's polylines carry tiny backward kinks at
    geometry joints that would read as half-turns."""
    line = lane.centerline.lineString
    n = int(line.length // step)
    if n < 3:
        return None
    pts = [line.interpolate(i * step) for i in range(n + 1)]
    headings = [_math.atan2(-(b.x - a.x), b.y - a.y) for a, b in _itertools.pairwise(pts)]
    turn, start = 0.0, None
    for i in range(1, len(headings)):
        d = _wrap_angle(headings[i] - headings[i - 1]) * sign
        if start is None and d > 0.5 * step / 400.0:  # curvature above 1/800 [1/m] towards the side
            start = (i - 0.5) * step
        if start is not None:
            turn += d
    if start is None or turn < min_turn:
        return None
    return start


def _maneuvers(lane, kind):
    wanted = getattr(_ManeuverType, kind)
    found = [m for m in lane.maneuvers if m.type is wanted]
    if not found and kind == "LEFT_TURN":
        found = [m for m in lane.maneuvers if m.type is _ManeuverType.U_TURN]
    return found


def _maneuver_route(lane, man, follow, connecting=frozenset()):
    lead = _lead_in(lane, _LEAD_IN, connecting)
    chain = lead + [man.connectingLane, man.endLane] if man.connectingLane is not None else lead + [man.endLane]
    chain = _follow_on(chain, follow)
    entry = sum(l.centerline.length for l in lead)
    return _route(chain, entry)


@_distributionFunction
def _xy(combo, role, s):
    return _r_xy(combo.routes[role], s)


@_distributionFunction
def _heading(combo, role, s):
    return _r_heading(combo.routes[role], s)


@_distributionFunction
def _lane_uid(combo, role, s):
    return _r_lane_at(combo.routes[role], s).uid


@_distributionFunction
def _anchor_s(combo, role, dist, relation):
    route = combo.routes[role]
    if relation == "front":
        return route.anchor + combo.passed + dist
    return route.anchor - dist


@_distributionFunction
def _follow_s(combo, ref_s, dist, relation):
    return ref_s + dist if relation == "front" else ref_s - dist


@_distributionFunction
def _project_s(combo, role, ref, ref_s, along):
    """Arc length on `role`'s route of the point `along` [m] ahead of the reference (negative: behind)."""
    return _r_project(combo.routes[role], _r_xy(combo.routes[ref], ref_s + along))


@_distributionFunction
def _approach_s(combo, role, dist):
    return combo.routes[role].anchor - dist


@_distributionFunction
def _route_lanes(combo, role):
    """Comma-joined lane uids of the actor's route (its lane chain, junction connector included)."""
    return ",".join(lane.uid for lane in combo.routes[role].lanes)


@_distributionFunction
def _pick(combo, role):
    return combo.routes[role]


def _combo_ns(routes, passed=0.0, meta=None):
    """One candidate placement: role -> route, the ego's junction crossing length [m], junction facts."""
    return _NS(routes=dict(routes), passed=passed, meta=dict(meta or {}))


def _needs_ok(actor, route, s_local_lane, lane, index=None):
    need = actor["needs"]
    if need.get("left", 0) and _same_dir_count(lane, s_local_lane, "left") < need["left"]:
        return False
    if need.get("right", 0) and _same_dir_count(lane, s_local_lane, "right") < need["right"]:
        return False
    if need.get("centre", 0) and _same_dir_count(lane, s_local_lane, "left") > 0:
        return False
    return not (need.get("oncoming") and _oncoming_lane(lane, s_local_lane, index) is None)


def _local(route, s):
    lane = _r_lane_at(route, s)
    return lane, max(0.0, _clamp(route, s) - route.starts[route.lanes.index(lane)])


def _relative_routes(actor, combo, ref_route):
    """Candidate routes for an actor placed beside / oncoming to / behind its reference (roads and junctions)."""
    kind = actor["placement"]
    if kind == "follow":
        return [ref_route]
    lane, s_local = _local(ref_route, ref_route.anchor - 1.0)
    if kind in ("side_left", "side_right"):
        other = _side_lane(lane, s_local, "left" if kind == "side_left" else "right")
    else:
        other = _oncoming_lane(lane, s_local, combo.meta.get("index"))
    if other is None:
        return []
    chain = _mirror(ref_route, combo.meta) if kind == "oncoming" else None
    if chain is None:
        # oncoming lanes run backwards along the reference: their lead-in may cross junctions (CARLA towns link
        # lanes through connectors); _plausible rejects chains that leave the reference's side
        connecting = combo.meta.get("connecting", frozenset()) if kind != "oncoming" else frozenset()
        chain = _follow_on(_lead_in(other, _LEAD_IN + 200.0, connecting), 200.0)
    route = _route(chain, 0.0)
    route.anchor = _r_project(route, _r_xy(ref_route, ref_route.anchor))
    other_lane, other_local = _local(route, route.anchor)
    if not _needs_ok(actor, route, other_local, other_lane, combo.meta.get("index")):
        return []
    return [route]


def _mirror(ref_route, meta):
    """The reference's route driven the other way: the oncoming lane of each of its road lanes, in reverse order,
    joined through the junction connector that links them. None when a piece is missing (then the caller falls
    back to the oncoming lane's own predecessors)."""
    connecting = meta.get("connecting", frozenset())
    road_lanes = [lane for lane in ref_route.lanes if lane.road not in connecting]
    if len(road_lanes) < 2 or len(road_lanes) == len(ref_route.lanes):
        return None  # no junction on the route: the plain oncoming chain already mirrors it
    opposite = [_oncoming_lane(lane) for lane in reversed(road_lanes)]
    if any(lane is None for lane in opposite):
        return None
    chain = [opposite[0]]
    for lane in opposite[1:]:
        if chain[-1]._successor is lane:
            chain.append(lane)
            continue
        links = [m for m in chain[-1].maneuvers if m.endLane is lane and m.connectingLane is not None]
        if not links:
            return None
        chain += [links[0].connectingLane, lane]
    return _follow_on(_lead_in(chain[0], _LEAD_IN, connecting)[:-1] + chain, 200.0)


def _expand(actors, base, approach_candidates, cap):
    """Cartesian product of every NPC's candidates, in placement order, capped."""
    combos = [base]
    for actor in actors[1:]:
        grown = []
        for combo in combos:
            ref_route = combo.routes[actor["ref"]]
            if actor["placement"] == "approach":
                options = approach_candidates(actor, combo)
            else:
                options = _relative_routes(actor, combo, ref_route)
            for route in options[:3]:
                routes = dict(combo.routes)
                routes[actor["role"]] = route
                grown.append(_combo_ns(routes, combo.passed, combo.meta))
                if len(grown) >= cap:
                    break
        combos = grown
    return combos


def _road_combos(network, actors, topology, hint, curve_sign, ego_roads, room=(0.0, 0.0), cap=400):
    ego_spec = actors[0]
    combos = []
    connecting = frozenset(network.connectingRoads)
    lanes = _road_lanes(network)
    meta = {"connecting": connecting, "index": _lane_index(lanes)}
    routes = []
    for lane in lanes:
        if lane.centerline.length < _MIN_LANE or not _ego_lane_ok(lane, ego_roads):
            continue
        lead = _lead_in(lane, _LEAD_IN, connecting)
        before = sum(l.centerline.length for l in lead[:-1])
        if topology == "curve":
            start = _curve_start(lane, curve_sign, 0.5)
            if start is None:
                continue
            routes.append(_route(_follow_on(lead, 200.0), before + start))
        else:
            route = _route(_follow_on(lead, 200.0), before + min(hint, 0.5 * lane.centerline.length))
            if route.length >= room[0] + room[1]:  # slide the anchor so queued actors fit on the route
                route.anchor = min(max(route.anchor, room[0]), route.length - room[1])
            routes.append(route)
    if topology == "curve" and not routes and not ego_roads:
        routes = _turn_routes(network, curve_sign, connecting)  # towns whose bends are junction connectors
    for route in routes:
        lane0, s_local = _local(route, route.anchor - 1.0)
        if not _needs_ok(ego_spec, route, s_local, lane0, meta["index"]):
            continue
        combos.extend(_expand(actors, _combo_ns({"ego": route}, 0.0, meta), None, cap))
        if len(combos) >= cap:
            break
    return combos


def _turn_routes(network, sign, connecting):
    """Lead-in -> turning connector -> exit routes whose connector bends towards `sign` by 0.5 rad or more."""
    wanted = _ManeuverType.LEFT_TURN if sign > 0 else _ManeuverType.RIGHT_TURN
    routes = []
    for inter in network.intersections:
        for lane in inter.incomingLanes:
            for man in lane.maneuvers:
                if man.type is wanted and man.connectingLane is not None:
                    routes.append(_maneuver_route(lane, man, 200.0, connecting))
    return routes


def _junction_combos(network, actors, legs, ego_roads, cap=400):
    ego_spec = actors[0]
    combos = []
    connecting = frozenset(network.connectingRoads)
    index = _lane_index(_road_lanes(network))

    def approach_candidates(actor, combo):
        """Other approaches of the junction whose direction matches the actor's DSL heading (best first),
        taking the manoeuvre its behaviour asks for; manoeuvres crossing the ego's path preferred."""
        ego_lane, ego_man, inter = combo.meta["lane"], combo.meta["man"], combo.meta["inter"]
        found, conflicting = [], []
        for lane in inter.incomingLanes:
            if lane is ego_lane:
                continue
            rel = _wrap_angle(_end_heading(lane) - _end_heading(ego_lane))
            error = abs(_wrap_angle(rel - actor["heading"]))
            if error > 0.7:
                continue
            for man in _maneuvers(lane, actor["maneuver"]) or list(lane.maneuvers):
                route = _maneuver_route(lane, man, 200.0, connecting)
                crossing = man in ego_man.conflictingManeuvers or man.endLane is ego_man.endLane
                (conflicting if crossing else found).append((error, len(found) + len(conflicting), route))
        return [route for _, _, route in sorted(conflicting or found, key=lambda item: item[:2])]

    for inter in network.intersections:
        if (legs == 4 and not inter.is4Way) or (legs == 3 and not inter.is3Way):
            continue
        for lane in inter.incomingLanes:
            if not _ego_lane_ok(lane, ego_roads):
                continue
            for man in _maneuvers(lane, ego_spec["maneuver"]):
                route = _maneuver_route(lane, man, 200.0, connecting)
                lane0, s_local = _local(route, route.anchor - 1.0)
                if not _needs_ok(ego_spec, route, s_local, lane0, index):
                    continue
                passed = man.connectingLane.centerline.length if man.connectingLane is not None else 0.0
                base = _combo_ns({"ego": route}, passed, {"lane": lane, "man": man, "inter": inter,
                                                              "connecting": connecting, "index": index})
                for combo in _expand(actors, base, approach_candidates, cap):
                    combos.append(combo)
        if len(combos) >= cap:
            break
    return combos[:cap]


_STRAIGHT_TOLERANCE = 0.35  # [rad] heading spread allowed along a "straight" ego route window
_BESIDE = 12.0  # [m] furthest a beside/oncoming actor may stand from the point it was projected from
_HEADING_TOLERANCE = 0.4  # [rad] error allowed on the expected heading of a placed actor (nominal placement)


def _nominal_s(combo, actors, end):
    """Arc length of every actor with all distances at one `end` (0 low, 1 high) of their ranges, as the
    template's helpers compute it."""
    s_of = {}
    for actor in actors:
        role, kind = actor["role"], actor["placement"]
        dist = actor.get("dist", (15.0, 20.0))[end]  # programs rendered before "dist" existed: the defaults
        sign = -1.0 if actor.get("along") == "behind" else 1.0
        route = combo.routes[role]
        if kind == "anchor":
            s_of[role] = route.anchor + combo.passed + dist if sign > 0 else route.anchor - dist
        elif kind == "follow":
            s_of[role] = s_of[actor["ref"]] + sign * (dist + actor.get("gap", 0.0))
        elif kind == "approach":
            s_of[role] = route.anchor - dist
        else:
            along = sign * dist if kind == "oncoming" else 0.0
            s_of[role] = _r_project(route, _r_xy(combo.routes[actor["ref"]], s_of[actor["ref"]] + along))
    return s_of


def _plausible(combo, actors, topology, room):
    """Compile-time check of a candidate at nominal distances: a straight ego window on straight roads, and every
    actor facing the way its DSL heading says relative to the ego (CARLA towns bend where generated maps do not)."""
    ego_route = combo.routes["ego"]
    if topology == "straight":
        h0 = _r_heading(ego_route, ego_route.anchor)
        s = ego_route.anchor - room[0]
        while s <= ego_route.anchor + room[1]:
            if abs(_wrap_angle(_r_heading(ego_route, s) - h0)) > _STRAIGHT_TOLERANCE:
                return False
            s += 5.0
    for end in (0, 1):
        s_of = _nominal_s(combo, actors, end)
        ego_heading = _r_heading(ego_route, s_of["ego"])
        for actor in actors[1:]:
            route = combo.routes[actor["role"]]
            if actor["placement"] in ("oncoming", "side_left", "side_right"):
                # the projection must land beside the reference point, not at a clamped end of the route
                dist = actor.get("dist", (15.0, 20.0))[end]
                along = (dist if actor.get("along") != "behind" else -dist) \
                    if actor["placement"] == "oncoming" else 0.0
                target = _r_xy(combo.routes[actor["ref"]], s_of[actor["ref"]] + along)
                if _math.dist(_r_xy(route, s_of[actor["role"]]), target) > _BESIDE:
                    return False
            if topology == "curve":
                continue  # headings change along a bend by design
            rel = _wrap_angle(_r_heading(route, s_of[actor["role"]]) - ego_heading)
            if abs(_wrap_angle(rel - actor["heading"])) > _HEADING_TOLERANCE:
                return False
    return True


_MOVES = {"STRAIGHT": "go straight", "LEFT_TURN": "turn left", "RIGHT_TURN": "turn right"}
_PLACED = {"side_left": "beside {ref} on its left", "side_right": "beside {ref} on its right",
           "oncoming": "oncoming to {ref}", "follow": "in {ref}'s lane", "approach": "on another approach",
           "anchor": "at the anchor"}


def _combos(network, actors, topology, hint, curve_sign, ego_roads, room):
    if topology in ("intersection", "t_intersection"):
        return _junction_combos(network, actors, 4 if topology == "intersection" else 3, ego_roads)
    return _road_combos(network, actors, topology, hint, curve_sign, ego_roads, room)


def _where(actor):
    """`actors.<role>.position (...)` and `actors.<role>.behavior (...)` of one actor spec, for messages."""
    role = actor["role"]
    placed = _PLACED.get(actor["placement"], actor["placement"]).format(ref=actor.get("ref"))
    return (f"actors.{role}.position ({placed}) and actors.{role}.behavior ({actor.get('behavior')}, "
            f"{_MOVES.get(actor.get('maneuver'), actor.get('maneuver'))} at the junction)"
            if actor["placement"] == "approach" else
            f"actors.{role}.position ({placed}) and actors.{role}.behavior ({actor.get('behavior')})")


def _no_place(network, actors, topology, hint, curve_sign, ego_roads, room):
    """Which DSL fields keep the scenario off this map (compile time, only when no candidate fits): the ego's
    own manoeuvre, the lanes its lane must offer to the actors placed beside or oncoming to it, or the first
    actor, in placement order, that finds no place once those before it are placed."""
    ego = actors[0]
    args = (topology, hint, curve_sign, ego_roads, room)
    bare = dict(ego, needs={"left": 0, "right": 0, "oncoming": 0})
    move = _MOVES.get(ego.get("maneuver"), "drive")
    if not _combos(network, [bare], *args):
        return (f"actors.ego.behavior ({ego.get('behavior')}) and road_network.road_type ({topology}): the map has "
                f"no lane where the ego can {move}")
    if not _combos(network, [ego], *args):
        need = ego.get("needs", {})
        offers = [f"{need[side]} same-direction lane(s) on its {side}" for side in ("left", "right")
                  if need.get(side)] + (["an oncoming lane"] if need.get("oncoming") else [])
        by = [a for a in actors[1:] if a.get("ref") == "ego"
              and a["placement"] in ("side_left", "side_right", "oncoming")]
        who = " and ".join(_where(a) for a in by) or "its own behavior"
        return (f"actors.ego.behavior ({ego.get('behavior')}): no lane the ego can {move} from also has "
                f"{' and '.join(offers)}, which {who} {'need' if len(by) > 1 else 'needs'}; allowed: those actors "
                "placed on the other side, ahead or behind, or another ego behavior")
    for k in range(2, len(actors) + 1):
        if not _combos(network, actors[:k], *args):
            actor = actors[k - 1]
            return f"{_where(actor)}: no place for {actor['role']} once " + ", ".join(
                a["role"] for a in actors[:k - 1]) + " are placed"
    return "lanes, junction legs or manoeuvres missing"


def candidates(network, actors, topology, hint, curve_sign, ego_roads=(), map_name="map", room=(0.0, 0.0)):
    """Every placement candidate of the program's actors on `network` (compile time).

    `room` = (behind, ahead) [m] of road the ego's route should offer around the anchor for the actors queued
    on it; candidates without it are dropped unless none has it (then actors may be clamped to route ends).
    """
    found = _combos(network, actors, topology, hint, curve_sign, ego_roads, room)
    if not found and any(a.get("needs", {}).get("centre") for a in actors):
        # the lane beside the centre line is a preference (plan._centre_lanes): without it where none can have it
        actors = [dict(a, needs={k: v for k, v in a["needs"].items() if k != "centre"}) for a in actors]
        found = _combos(network, actors, topology, hint, curve_sign, ego_roads, room)
    roomy = [c for c in found if c.routes["ego"].anchor >= room[0]
             and c.routes["ego"].length - c.routes["ego"].anchor >= room[1]]
    found = roomy or found
    plausible = [c for c in found if _plausible(c, actors, topology, room)]
    found = plausible or found
    if not found:
        raise RuntimeError(f"crashscene: no place on map {map_name!r} fits this {topology} scenario: "
                           + _no_place(network, actors, topology, hint, curve_sign, ego_roads, room))
    return found


place_xy, place_heading, lane_uid, anchor_s, follow_s, project_s, approach_s, route_of, route_lanes = (
    _xy, _heading, _lane_uid, _anchor_s, _follow_s, _project_s, _approach_s, _pick, _route_lanes)
__all__ = [
    "anchor_s",
    "approach_s",
    "candidates",
    "follow_s",
    "lane_uid",
    "place_heading",
    "place_xy",
    "project_s",
    "route_lanes",
    "route_of",
]
