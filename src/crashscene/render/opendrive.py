"""Render step 2, map (generated): OpenDRIVE maps built with scenariogeneration for the four DSL topologies.

Frame: the ego approaches along +x. Straight and curve: one road from x = 0;
the ego's direction is the road's right-hand lanes (OpenDRIVE ids -1, -2, ...),
the opposite direction its left-hand lanes; the anchor is at s = back_length
(the curve starts there). Junctions: one arm per side as the ego sees it
(ego = west, left = north, opposite = east, right = south), every arm attached
to the junction by its end, lanes linked one by one (lane -i -> lane i) so that
Scenic sees exactly one manoeuvre per (incoming lane, exit) and no bogus U-turns:
12 manoeuvres on a single-lane 4-way, 6 on a T.

Signals: traffic light type 1000001 (country OpenDRIVE), stop sign R1-1 and
yield sign R1-2 (country US, MUTCD), on the controlled arm's end and on every
connecting road leaving that arm (Scenic reads junction signals from the
connecting roads); a stop line (`<object type="roadMark" subtype="stopLine">`)
on each controlled approach. Each road carries `<type><speed>` with the posted limit.

Validity: the header declares OpenDRIVE 1.8 so that every checker of ASAM's bundle
applies (13 of its 23 rules are defined from 1.7 on), and the content follows the 1.8
schema (ISO 3166 alpha-2 country codes, an elevation record in every elevationProfile);
`qc_opendrive` reports no error and skips nothing on any topology (tests/render/test_maps.py).
"""
from __future__ import annotations

import math
from pathlib import Path

from scenariogeneration import xodr
from scenariogeneration.helpers import printToFile

from crashscene.geometry import LANE_WIDTH
from crashscene.render.plan import MapSpec

ARM_ANGLE = {"ego": math.pi, "left": math.pi / 2, "opposite": 0.0, "right": 3 * math.pi / 2}  # [rad] on the circle
OPENDRIVE_REVISION = ("1", "8")  # (major, minor) written to the header
SIGNAL_TYPE = {"traffic_light": ("OpenDRIVE", "1000001"), "stop_sign": ("US", "R1-1"), "yield_sign": ("US", "R1-2")}
SIGNAL_SIZE = {"traffic_light": (0.4, 1.0), "stop_sign": (0.75, 0.75), "yield_sign": (0.9, 0.8)}  # [m] width, height
STOP_LINE_LENGTH = 0.3  # [m] along the road
HEADER_DATE = "2026-01-01T00:00:00"  # fixed, so that the same spec gives the same bytes
MPH_55 = 24.5872  # [m/s]


class Signal(xodr.Signal):
    """scenariogeneration's signal, with the country code written as given (it upper-cases it, and the
    schema's generic catalogue is spelled `OpenDRIVE`)."""

    def get_attributes(self) -> dict:
        attributes = super().get_attributes()
        attributes["country"] = self.country
        return attributes


def center_mark(token: str, two_way: bool) -> xodr.RoadMark:
    """OpenDRIVE centre-line marking for a DSL road_marker token."""
    if not two_way:
        return xodr.RoadMark(xodr.RoadMarkType.solid, 0.15)  # the left edge of a one-way carriageway
    table = {
        "double_solid_line": xodr.std_roadmark_solid_solid,
        "solid_line": xodr.std_roadmark_solid,
        "broken_line": xodr.std_roadmark_broken,
        "solid_and_broken_line": xodr.std_roadmark_solid_broken,
        "not_mentioned": xodr.std_roadmark_broken,
    }
    if token == "none":
        return xodr.RoadMark(xodr.RoadMarkType.none)
    return table[token]()


def build_map(spec: MapSpec, path: Path) -> Path:
    """Write the OpenDRIVE map for `spec` to `path`."""
    odr = xodr.OpenDrive(f"crashscene_{spec.topology}", revMajor=OPENDRIVE_REVISION[0],
                         revMinor=OPENDRIVE_REVISION[1])
    if spec.topology in ("straight", "curve"):
        _road_map(odr, spec)
    else:
        _junction_map(odr, spec)
    path.parent.mkdir(parents=True, exist_ok=True)
    for road in odr.roads.values():
        road.add_elevation(s=0.0, a=0.0, b=0.0, c=0.0, d=0.0)  # flat; the schema wants an elevation record
    element = odr.get_element()
    element.find("header").set("date", HEADER_DATE)  # scenariogeneration writes the clock time
    for tag in ("signal", "object"):  # scenariogeneration numbers them with a process-wide counter
        for number, item in enumerate(element.iter(tag), 1):
            item.set("id", str(number))
    printToFile(element, str(path), True)
    return path


def _road_type(spec: MapSpec) -> xodr.RoadType:
    if spec.speed_limit and spec.speed_limit >= MPH_55 and spec.lanes_backward == 0:
        return xodr.RoadType.motorway
    if spec.speed_limit and spec.speed_limit >= 17.8:  # [m/s] 40 mph
        return xodr.RoadType.rural
    return xodr.RoadType.town


def _with_limit(road: xodr.Road, spec: MapSpec) -> xodr.Road:
    if spec.speed_limit:
        road.add_type(_road_type(spec), speed=round(spec.speed_limit, 3), speed_unit="m/s")
    return road


def _road_map(odr: xodr.OpenDrive, spec: MapSpec) -> None:
    if spec.topology == "curve":
        sign = 1.0 if spec.curve_direction == "left" else -1.0
        geometry = [xodr.Line(spec.back_length),
                    xodr.Arc(sign / spec.curve_radius, length=spec.curve_radius * spec.curve_angle),
                    xodr.Line(spec.ahead_length)]
    else:
        geometry = [xodr.Line(spec.back_length + spec.ahead_length)]
    road = xodr.create_road(geometry, id=1, left_lanes=spec.lanes_backward, right_lanes=spec.lanes_forward,
                            center_road_mark=center_mark(spec.center_mark, spec.lanes_backward > 0),
                            lane_width=LANE_WIDTH)
    odr.add_road(_with_limit(road, spec))
    odr.adjust_roads_and_lanes()


def _arm_lanes(spec: MapSpec, arm: str) -> tuple[int, int]:
    """(incoming, outgoing) lanes of an arm."""
    if arm == "ego":
        return spec.lanes_forward, spec.lanes_backward
    if arm == "opposite":
        return spec.lanes_backward, spec.lanes_forward
    return spec.cross_lanes, spec.cross_lanes


def _junction_map(odr: xodr.OpenDrive, spec: MapSpec) -> None:
    arms = spec.arms
    road_ids = {arm: i + 1 for i, arm in enumerate(arms)}
    widest = max(max(_arm_lanes(spec, arm)) for arm in arms)
    radius = widest * LANE_WIDTH + 6.0  # [m] junction half-size: room for the turning paths
    creator = xodr.CommonJunctionCreator(id=100, name="junction", startnum=100)
    roads = {}
    for arm in arms:
        incoming, outgoing = _arm_lanes(spec, arm)
        length = spec.back_length if arm == "ego" else spec.ahead_length
        two_way = incoming > 0 and outgoing > 0
        mark = center_mark(spec.center_mark, two_way) if arm in ("ego", "opposite") else center_mark(
            "not_mentioned", two_way)
        road = xodr.create_road(xodr.Line(length), id=road_ids[arm], left_lanes=outgoing, right_lanes=incoming,
                                center_road_mark=mark, lane_width=LANE_WIDTH)
        roads[arm] = _with_limit(road, spec)
        creator.add_incoming_road_circular_geometry(road, radius, ARM_ANGLE[arm], "successor")
    order = ["ego", "right", "opposite", "left"]  # counter-clockwise around the centre
    for a in arms:
        in_a, _ = _arm_lanes(spec, a)
        for b in arms:
            if a == b:
                continue
            _, out_b = _arm_lanes(spec, b)
            if in_a == 0 or out_b == 0:
                continue
            turn = (order.index(b) - order.index(a)) % 4  # 1 right, 2 straight, 3 left
            if turn == 2:
                pairs = [(-i, i) for i in range(1, min(in_a, out_b) + 1)]
            elif turn == 3:
                pairs = [(-1, 1)]
            else:
                pairs = [(-in_a, out_b)]
            for lane_a, lane_b in pairs:
                creator.add_connection(road_one_id=road_ids[a], road_two_id=road_ids[b],
                                       lane_one_id=lane_a, lane_two_id=lane_b)
    for road in roads.values():
        odr.add_road(road)
    odr.add_junction_creator(creator)
    _add_controls(spec, roads, creator, road_ids)
    odr.adjust_roads_and_lanes()


def _add_controls(spec: MapSpec, roads: dict[str, xodr.Road], creator: xodr.CommonJunctionCreator,
                  road_ids: dict[str, int]) -> None:
    by_id = {rid: arm for arm, rid in road_ids.items()}
    for arm, device in sorted(spec.controls.items()):
        road = roads[arm]
        incoming, _ = _arm_lanes(spec, arm)
        if incoming == 0:
            continue
        country, kind = SIGNAL_TYPE[device]
        length = spec.back_length if arm == "ego" else spec.ahead_length
        t_side = -(incoming * LANE_WIDTH + 1.0)  # [m] right of the incoming lanes
        dynamic = xodr.Dynamic.yes if device == "traffic_light" else xodr.Dynamic.no
        width, height = SIGNAL_SIZE[device]
        road.add_signal(Signal(s=length - 1.0, t=t_side, country=country, Type=kind,
                                    name=f"{device}_{arm}", dynamic=dynamic, orientation=xodr.Orientation.positive,
                                    width=width, height=height))
        road.add_object(xodr.Object(s=length - 0.5, t=-incoming * LANE_WIDTH / 2, Type=xodr.ObjectType.roadMark,
                                    subtype="stopLine", name=f"stop_line_{arm}", width=incoming * LANE_WIDTH,
                                    length=STOP_LINE_LENGTH, height=0.0, zOffset=0.0))
        for conn in creator.get_connecting_roads():
            if by_id.get(conn.predecessor.element_id) != arm:
                continue
            conn.add_signal(Signal(s=0.5, t=-LANE_WIDTH, country=country, Type=kind,
                                        name=f"{device}_{arm}", dynamic=dynamic,
                                        orientation=xodr.Orientation.positive, width=width, height=height))
    