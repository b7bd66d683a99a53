"""Closed vocabularies of the Extended Scenic DSL and the spellings readers accept.

Enum values are the canonical tokens written to file, so parsing and printing
share one table. ALIASES maps every accepted human spelling (already folded by
`fold`) to its canonical token, per field.
"""
from __future__ import annotations

import re
from enum import StrEnum


class Weather(StrEnum):
    CLEAR = "clear"
    CLOUDY = "cloudy"
    OVERCAST = "overcast"
    RAINY = "rainy"
    SNOWY = "snowy"
    FOGGY = "foggy"
    WINDY = "windy"
    NOT_MENTIONED = "not_mentioned"


class TimeOfDay(StrEnum):
    DAYTIME = "daytime"
    NIGHTTIME = "nighttime"
    DAWN = "dawn"
    DUSK = "dusk"
    NOT_MENTIONED = "not_mentioned"


class RoadSurface(StrEnum):
    DRY = "dry"
    WET = "wet"
    ICY = "icy"
    SNOWY = "snowy"
    NOT_MENTIONED = "not_mentioned"


class RoadType(StrEnum):
    STRAIGHT = "straight"
    CURVE = "curve"
    INTERSECTION = "intersection"
    T_INTERSECTION = "t_intersection"


class RoadMarker(StrEnum):
    DOUBLE_SOLID_LINE = "double_solid_line"
    SOLID_LINE = "solid_line"
    BROKEN_LINE = "broken_line"
    SOLID_AND_BROKEN_LINE = "solid_and_broken_line"
    NONE = "none"
    NOT_MENTIONED = "not_mentioned"


class Sign(StrEnum):
    """Traffic control devices; the declaration order is the canonical order on file."""

    STOP_SIGN = "stop_sign"
    YIELD_SIGN = "yield_sign"
    TRAFFIC_LIGHT = "traffic_light"
    SPEED_LIMIT_SIGN = "speed_limit_sign"


class CurveDirection(StrEnum):
    LEFT = "left"
    RIGHT = "right"


class ActorType(StrEnum):
    CAR = "car"
    TRUCK = "truck"
    MOTORCYCLE = "motorcycle"


class Behavior(StrEnum):
    GO_FORWARD = "go_forward"
    TURN_LEFT = "turn_left"
    TURN_RIGHT = "turn_right"
    U_TURN = "u_turn"
    CHANGE_LANE_LEFT = "change_lane_left"
    CHANGE_LANE_RIGHT = "change_lane_right"
    CROSS_CENTERLINE = "cross_centerline"
    OVERTAKE = "overtake"
    DECELERATE = "decelerate"
    STOP = "stop"
    STATIC = "static"
    LOSE_CONTROL = "lose_control"
    LEAVE_ROAD = "leave_road"


# the behaviours by what they do, as plain tokens (the simulator, monitor, extractor and exporters test these)
STANDING = (Behavior.STOP.value, Behavior.STATIC.value)  # the vehicle stands still (stopped or parked)
LANE_CHANGES = (Behavior.CHANGE_LANE_LEFT.value, Behavior.CHANGE_LANE_RIGHT.value)  # into an adjacent lane
OPPOSING_PASSES = (Behavior.CROSS_CENTERLINE.value, Behavior.OVERTAKE.value)  # into the opposing lane
JUNCTIONS = (RoadType.INTERSECTION.value, RoadType.T_INTERSECTION.value)  # road types whose crash is in a junction


class RoadElement(StrEnum):
    """Position references that are road elements rather than actors."""

    INTERSECTION = "intersection"
    STOP_SIGN = "stop_sign"
    YIELD_SIGN = "yield_sign"
    TRAFFIC_LIGHT = "traffic_light"
    CURVE = "curve"
    ROAD = "road"


class Relation(StrEnum):
    FRONT = "front"
    BEHIND = "behind"
    LEFT = "left"
    RIGHT = "right"


class Heading(StrEnum):
    SAME_DIRECTION = "same_direction"
    OPPOSITE_DIRECTION = "opposite_direction"
    FROM_LEFT = "from_left"
    FROM_RIGHT = "from_right"


class ImpactArea(StrEnum):
    """The side of a vehicle that takes part in a contact (dsl.md `collisions`)."""

    FRONT = "front"
    REAR = "rear"
    LEFT = "left"
    RIGHT = "right"


class CollisionClass(StrEnum):
    """Collision configurations (dsl.md `collisions`, rules.md collision classes)."""

    REAR_END = "rear_end"
    HEAD_ON = "head_on"
    ANGLE = "angle"
    SIDESWIPE = "sideswipe"


_ENDS = (ImpactArea.FRONT, ImpactArea.REAR)
_SIDES = (ImpactArea.LEFT, ImpactArea.RIGHT)

# Which pairs of areas (striking, struck; either order) each class admits (dsl.md section 3): front into rear,
# front into front, an end into a side, side against side or a glancing end along a side.
CLASS_AREAS: dict[CollisionClass, frozenset[frozenset[ImpactArea]]] = {
    CollisionClass.REAR_END: frozenset({frozenset({ImpactArea.FRONT, ImpactArea.REAR})}),
    CollisionClass.HEAD_ON: frozenset({frozenset({ImpactArea.FRONT})}),
    CollisionClass.ANGLE: frozenset(frozenset({end, side}) for end in _ENDS for side in _SIDES),
    CollisionClass.SIDESWIPE: frozenset(frozenset({a, b}) for a in ImpactArea for b in _SIDES),
}


def areas_fit_class(klass: CollisionClass, striking_area: ImpactArea, struck_area: ImpactArea) -> bool:
    """Whether a contact's two areas are consistent with its class."""
    return frozenset({ImpactArea(striking_area), ImpactArea(struck_area)}) in CLASS_AREAS[CollisionClass(klass)]


def monitored_codes() -> dict[str, str]:
    """The monitored rulebook: code -> violation token, in rulebook order.

    Derived from the monitor's rule registry (each rule class declares its
    code and token, `crashscene.monitor.rules`); imported on first use, since
    the monitor builds on the DSL. `MONITORED_CODES` is the same table.
    """
    from crashscene.monitor.rules import monitored_codes as registered

    return registered()


def __getattr__(name: str):
    if name == "MONITORED_CODES":  # derived on each use: rules registered later are monitored too
        return monitored_codes()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


CODE_PATTERN = re.compile(r"^CVC_[0-9]+[A-Za-z]?$")
NPC_PATTERN = re.compile(r"^npc[1-9][0-9]*$")
VIOLATION_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")


def fold(text: str) -> str:
    """Fold a human spelling towards token form: 'Same direction' -> 'same_direction'."""
    folded = re.sub(r"[\s\-/]+", "_", text.strip().lower())
    return re.sub(r"_+", "_", folded).strip("_")


_NOT_MENTIONED = {"not_mentioned": "not_mentioned", "none": "not_mentioned", "unknown": "not_mentioned",
                  "n_a": "not_mentioned", "unspecified": "not_mentioned", "not_stated": "not_mentioned"}

# Per field name: folded alias -> canonical token. Canonical tokens map to themselves implicitly.
ALIASES: dict[str, dict[str, str]] = {
    "weather": {**_NOT_MENTIONED, "sunny": "clear", "fair": "clear", "clear_sky": "clear",
                "no_adverse_conditions": "clear", "rain": "rainy", "raining": "rainy", "snow": "snowy",
                "snowing": "snowy", "fog": "foggy", "cloud": "cloudy", "wind": "windy"},
    "time_of_day": {**_NOT_MENTIONED, "day": "daytime", "daylight": "daytime", "day_time": "daytime",
                    "night": "nighttime", "dark": "nighttime", "night_time": "nighttime",
                    "dark_lighted": "nighttime", "dark_not_lighted": "nighttime", "dark_lit": "nighttime",
                    "dark_unlit": "nighttime"},
    "road_surface": {**_NOT_MENTIONED, "wet_road": "wet", "ice": "icy", "snow": "snowy",
                     "snow_covered": "snowy"},
    "road_type": {"t_intersection": "t_intersection", "t_junction": "t_intersection",
                  "tee_intersection": "t_intersection", "straight_road": "straight",
                  "curved": "curve", "curved_road": "curve", "curve_road": "curve",
                  "4_leg_intersection": "intersection", "four_way_intersection": "intersection",
                  "cross_intersection": "intersection"},
    "road_marker": {"not_mentioned": "not_mentioned", "unknown": "not_mentioned",
                    "double_solid": "double_solid_line", "double_yellow_line": "double_solid_line",
                    "double_line": "double_solid_line", "solid": "solid_line", "broken": "broken_line",
                    "dashed_line": "broken_line", "dashed": "broken_line",
                    "solid_and_broken": "solid_and_broken_line", "no_marking": "none",
                    "no_markings": "none"},
    "sign": {"stop": "stop_sign", "yield": "yield_sign", "traffic_signal": "traffic_light",
             "signal": "traffic_light", "traffic_lights": "traffic_light", "stop_light": "traffic_light",
             "speed_limit": "speed_limit_sign", "speed_limit_signs": "speed_limit_sign",
             "stop_signs": "stop_sign"},
    "curve_direction": {"curve_left": "left", "curves_left": "left", "curve_right": "right",
                        "curves_right": "right"},
    "type": {"sedan": "car", "suv": "car", "pickup": "car", "pickup_truck": "car", "van": "car",
             "minivan": "car", "utility_vehicle": "car", "sport_utility_vehicle": "car",
             "coupe": "car", "hatchback": "car", "wagon": "car", "passenger_car": "car",
             "vehicle": "car", "semi": "truck", "tractor_trailer": "truck", "bus": "truck",
             "box_truck": "truck", "hgv": "truck", "motorbike": "motorcycle"},
    "behavior": {"go_straight": "go_forward", "straight": "go_forward", "forward": "go_forward",
                 "going_forward": "go_forward", "left_turn": "turn_left", "right_turn": "turn_right",
                 "uturn": "u_turn", "u_turn": "u_turn", "lane_change_left": "change_lane_left",
                 "lane_change_right": "change_lane_right", "cross_center_line": "cross_centerline",
                 "cross_the_centerline": "cross_centerline", "crossing_centerline": "cross_centerline",
                 "overtaking": "overtake", "braking": "decelerate", "brake": "decelerate",
                 "slow_down": "decelerate", "stopped": "stop", "parked": "static", "stationary": "static",
                 "loss_of_control": "lose_control", "lost_control": "lose_control",
                 "run_off_road": "leave_road", "off_road": "leave_road", "ran_off_road": "leave_road"},
    "reference": {"ego_vehicle": "ego", "stop": "stop_sign", "yield": "yield_sign",
                  "traffic_signal": "traffic_light", "signal": "traffic_light", "junction": "intersection",
                  "t_intersection": "intersection"},
    "relation": {"ahead": "front", "in_front": "front", "in_front_of": "front", "rear": "behind",
                 "back": "behind", "left_side": "left", "right_side": "right"},
    "area": {"front_plane": "front", "frontal_plane": "front", "frontal": "front", "back": "rear",
             "back_plane": "rear", "rear_plane": "rear", "left_side": "left", "left_plane": "left",
             "right_side": "right", "right_plane": "right"},
    "class": {"rear_end": "rear_end", "front_to_rear": "rear_end", "rear_ended": "rear_end",
              "head_on": "head_on", "front_to_front": "head_on", "t_bone": "angle", "t_type": "angle",
              "broadside": "angle", "oblique": "angle", "side_swipe": "sideswipe", "sideswiped": "sideswipe"},
    "heading": {"same": "same_direction", "opposite": "opposite_direction", "oncoming": "opposite_direction",
                "from_the_left": "from_left", "from_the_right": "from_right"},
}


def actor_key(text: str) -> str:
    """Normalise an actor key: 'Ego vehicle' -> 'ego', 'Other actor 1' -> 'npc1', 'NPC 2' -> 'npc2'."""
    folded = fold(text)
    if folded in ("ego", "ego_vehicle", "ego_car"):
        return "ego"
    match = re.fullmatch(r"(?:other_actor|other_vehicle|actor|npc)_?([0-9]+)", folded)
    return f"npc{int(match.group(1))}" if match else folded
