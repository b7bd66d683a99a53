"""Rules extractor: actor positions (dsl.md convention 7) from travel directions, lanes and devices,
and stated travel speeds.
"""
from __future__ import annotations

import re

from crashscene.dsl.tokens import LANE_CHANGES, OPPOSING_PASSES, STANDING
from crashscene.extract.narrative import COMPASS, around, clip, label_at
from crashscene.extract.rules_state import RulesState, Vehicle, has_cross_traffic, relative_heading
from crashscene.units import KMH_PER_MPH


def decide_actors(state: RulesState, road: dict) -> dict:
    """The `actors` mapping: ego = V1, npc1 = V2, ... with type, behaviour, position and any stated speed."""
    ego = state.vehicles["V1"]
    at_junction = road["road_type"] in ("intersection", "t_intersection")
    devices = set(road["traffic_signs"]) - {"speed_limit_sign"}
    actors: dict = {}
    for label, vehicle in state.vehicles.items():
        if vehicle.role == "ego":
            reference, relation = _ego_reference(state, road, devices, at_junction)
            position = {"reference": reference, "relation": relation}
        else:
            position = _npc_position(state, ego, vehicle, devices, at_junction, state.t.text,
                                     road["number_of_ways"] == 1)
        actors[vehicle.role] = {"label": label, "type": vehicle.type, "behavior": vehicle.behavior,
                                "position": position}
        speed = _stated_speed(state, label) if state.uses("rules_positions.stated_speed") else None
        if speed is not None:
            actors[vehicle.role]["speed_mph"] = speed
            state.speeds[label] = speed
    return actors


_SPEED_VALUE = r"(\d{1,3})\s*(mph|mi/h|miles per hour|km/h|kmph|km/hr|kph)"


def _stated_speed(state: RulesState, label: str) -> float | None:
    """A travel speed the report states for the vehicle ('V2 was traveling at approximately 60 mph') [mph]."""
    text = state.t.text
    for match in re.finditer(rf"(?:travel(?:l?ing|l?ed)?|going|driving|driven|moving)\s+"
                             rf"(?:(?:north|south|east|west)(?:bound)?\s+)?(?:at\s+)?(?:a\s+)?"
                             rf"(?:(?:an\s+)?(?:estimated|approximate(?:ly)?|about|roughly|reported(?:ly)?|"
                             rf"calculated|travel)\s+)*(?:speed\s+of\s+)?{_SPEED_VALUE}|"
                             rf"(?:estimated|calculated|reported|pre-?crash|travel)\s+speed\s+(?:of\s+|was\s+)?"
                             rf"(?:approximately\s+|about\s+)?{_SPEED_VALUE}", text, re.I):
        start = max(0, match.start() - 30)
        if state.uses("rules_positions.limit_words_in_the_same_sentence"):  # "limit was 45 mph. V1 was traveling"
            start = max(start, text.rfind(". ", 0, match.start()))
        if re.search(r"limit|posted", text[start:match.start()], re.I):
            continue
        if label_at(text, match.start()) != label:
            continue
        number = int(match.group(1) or match.group(3))
        unit = (match.group(2) or match.group(4)).lower()
        if unit.startswith("k"):
            after = re.match(r"\s*\((\d{1,3})\s*mph\)", text[match.end():])
            mph = float(after.group(1)) if after else round(number / KMH_PER_MPH)
        else:
            mph = float(number)
        if 0 < mph <= 200:
            state.note(f"actors.{state.vehicles[label].role}.speed_mph", around(text, match))
            return mph
    return None


def _ego_reference(state: RulesState, road: dict, devices: set[str], at_junction: bool) -> tuple[str, str]:
    """The device controlling V1's approach, else the element V1 is at (approaching it: `behind`)."""
    if at_junction:
        if "traffic_light" in devices:
            return "traffic_light", "behind"
        if "stop_sign" in devices and ("V1" in state.stop_controlled or not (state.stop_controlled or
                                                                            has_cross_traffic(state))):
            return "stop_sign", "behind"
        if "yield_sign" in devices and "V1" in state.yield_controlled:
            return "yield_sign", "behind"
        return "intersection", "behind"
    if road["road_type"] == "curve":
        return "curve", "behind"
    return "road", "behind"


def _npc_position(state: RulesState, ego: Vehicle, npc: Vehicle, devices: set[str], at_junction: bool,
                  text: str, one_way: bool = False) -> dict:
    """Crossing traffic against the junction or its device (side from the travel directions); traffic on V1's
    road against the ego (convention 7)."""
    heading = relative_heading(ego, npc) or _guess_heading(state, ego, npc, at_junction, text, one_way)
    label = npc.label
    if heading in ("from_left", "from_right"):
        side = "left" if heading == "from_left" else "right"
        if "traffic_light" in devices:
            reference = "traffic_light"
        elif "stop_sign" in devices and (label in state.stop_controlled or "V1" not in state.stop_controlled):
            reference = "stop_sign"
        elif "yield_sign" in devices and (label in state.yield_controlled or "V1" not in state.yield_controlled):
            reference = "yield_sign"
        else:
            reference = "intersection"
        return {"reference": reference, "relation": side, "heading": heading}
    if heading == "opposite_direction":
        return {"reference": "ego", "relation": "front", "heading": heading}
    relation = _same_direction_relation(state, ego, npc, text)
    return {"reference": "ego", "relation": relation, "heading": heading}


def _guess_heading(state: RulesState, ego: Vehicle, npc: Vehicle, at_junction: bool, text: str,
                   one_way: bool = False) -> str:
    """A heading when the report gives no travel direction: from the manoeuvres and the impact."""
    label = npc.label
    if npc.behavior in OPPOSING_PASSES or ego.behavior == "cross_centerline":
        return "opposite_direction"
    if state.uses("rules_positions.stated_opposite_direction") and re.search(
            rf"\b{label}\b[^.]{{0,60}}\b(?:in the opposite direction|oncoming|opposing direction)", text, re.I):
        return "opposite_direction"
    side = re.search(rf"\b{label}\b[^.]{{0,100}}\b(?:on|from) the (north|south|east|west) side of the "
                     rf"(?:road|roadway|street|highway)", text, re.I)
    if side and ego.direction and at_junction and state.uses("rules_positions.access_side"):
        origin = (COMPASS[side.group(1).lower()] - COMPASS[ego.direction]) % 360  # where it comes from
        if origin in (90, 270):
            return "from_right" if origin == 90 else "from_left"
    if state.uses("rules_positions.same_direction_on_one_carriageway") and not at_junction and (
            one_way or npc.behavior.startswith("change_lane")):
        return "same_direction"  # one carriageway (divided, one-way) or a lane change: traffic goes V1's way
    rear_end = state.uses("rules_positions.rear_end_is_same_direction") and re.search(
        rf"(?:rear|back)(?: plane| end)? of {label}|{label}\b[^.]{{0,80}}\b(?:rear|back)[- ]end|"
                         rf"front of {label} struck the (?:rear|back)|{label}\b[^.]{{0,40}}\bbehind", text, re.I)
    if rear_end or (npc.behavior in ("stop", "decelerate", "static") and
                    state.uses("rules_positions.rear_end_is_same_direction")):
        return "same_direction"
    return "from_left" if at_junction else "opposite_direction"


def _same_direction_relation(state: RulesState, ego: Vehicle, npc: Vehicle, text: str) -> str:
    """Beside (lane sides, lane numbers, where it is parked, the side a lane changer leaves), behind, or ahead."""
    label = npc.label
    if npc.behavior == "static" and state.uses("rules_positions.parked_on_the_shoulder_side") and re.search(
            rf"\b{label}\b[^.]{{0,120}}\b(?:parked|stopped|disabled)\b[^.]{{0,40}}"
                                              rf"\b(?:shoulder|curb|roadside|side of the road)", text, re.I):
        side = re.search(rf"\b{label}\b[^.]{{0,160}}\b(left|median|inside)\b[^.]{{0,10}}shoulder", text, re.I)
        return "left" if side else "right"
    if npc.behavior in LANE_CHANGES and not (ego.lane_side and npc.lane_side) and \
            state.uses("rules_positions.lane_changer_comes_from_the_side_it_leaves"):
        return "right" if npc.behavior == "change_lane_left" else "left"  # it comes from the side it leaves
    if ego.lane_side and npc.lane_side and ego.lane_side != npc.lane_side and "middle" not in (ego.lane_side,
                                                                                               npc.lane_side):
        if not re.search(rf"{label}\b[^.]{{0,60}}\bbehind|behind V1|following V1", text, re.I) or \
                ego.behavior.startswith("change_lane") or npc.behavior.startswith("change_lane"):
            return npc.lane_side
    behind = state.uses("rules_positions.behind_words") and re.search(
        rf"\b{label}\b[^.]{{0,80}}\b(?:behind|following)\b[^.]{{0,20}}V1|"
                       rf"\bfront (?:plane )?of {label}\b[^.]{{0,40}}\b(?:struck|impacted|contacted)\b[^.]{{0,20}}"
                       rf"(?:rear|back)|"
                       rf"(?:rear|back)(?: plane)? of V1\b[^.]{{0,40}}(?:struck|impacted) by[^.]{{0,30}}{label}|"
                       rf"\b{label}\b[^.]{{0,100}}\b(?:struck|striking|strike|impacted|hit|rear-ended)\s+(?:the\s+)?"
                       rf"(?:rear|back)(?:\s+plane|\s+end)?\s+of\s+V1|\b{label}\b[^.]{{0,80}}\bapproaching V1\b|"
                       rf"\b{label}\b[^.]{{0,40}}slightly behind", text, re.I)
    if behind:
        return "behind"
    if not _position_stated(text, label):
        state.unstated_positions.add(label)
    return "front"


_POSITION_WORDS = r"\b(?:ahead|in front|behind|follow\w*|lead\w*|preced\w*|trail\w*)\b"


def _position_stated(text: str, label: str) -> bool:
    """Whether a sentence names the vehicle and V1 with a word placing one along the lane of the other."""
    return any(re.search(rf"\b{label}\b", sentence) and re.search(r"\bV1\b", sentence) and
               re.search(_POSITION_WORDS, sentence, re.I) for sentence in re.split(r"(?<=[.!?])\s+", text))


KEEPS_ITS_LANE = ("go_forward", "decelerate", *STANDING)  # manoeuvres that keep the vehicle in its lane


def struck_in_turn(chain: list[tuple[str, str]]) -> dict[str, list[str]]:
    """Each striker of `chain` ((striker, struck) pairs in sequence order) with the vehicles it strikes, in the
    order it strikes them: a vehicle struck again straight after itself once, struck again after another one
    again (which places it both behind and ahead of that one: `order_along_one_lane` finds the contradiction)."""
    met: dict[str, list[str]] = {}
    for striker, struck in chain:
        turn = met.setdefault(striker, [])
        if not turn or turn[-1] != struck:
            turn.append(struck)
    return met


def order_along_one_lane(chain: list[tuple[str, str]]) -> set[tuple[str, str]] | None:
    """The pairs (x, y), x behind y along one lane, that rear-end contacts between lane-keeping vehicles entail:
    `chain` is their (striker, struck) pairs in sequence order. A striker is behind what it rear-ends, and of two
    vehicles one striker rear-ends, the one struck earlier is behind the one struck later (`struck_in_turn`); the
    pairs are chained (x behind y behind z: x behind z). None when the contacts contradict each other (a cycle)."""
    behind = set(chain)
    for turn in struck_in_turn(chain).values():
        behind.update((earlier, later) for k, earlier in enumerate(turn) for later in turn[k + 1:] if earlier != later)
    closure = set(behind)
    while True:
        more = {(x, z) for x, y in closure for y2, z in closure if y == y2 and x != z} - closure
        if not more:
            break
        closure |= more
    return None if any((y, x) in closure for x, y in closure) else closure


def revise_positions_by_the_sequence(state: RulesState, actors: dict, collisions: list[dict]) -> None:
    """Places along one lane that the crash sequence entails, for vehicles the text does not place.

    Derived from three spec sentences, no phrasing: the crash sequence lists "the contacts between actors, in the
    order they happen" (dsl.md section 1 and convention 11); a `rear_end` contact is "front into rear, same
    direction" (dsl.md section 3), a vehicle "struck from behind" (rules.md); and an actor referencing another is
    "ahead of / behind it along its lane" (dsl.md section 3 position, convention 7). So a striker is behind every
    vehicle it rear-ends, and a striker travelling along one lane (it keeps its lane: go_forward, decelerate,
    stop) meets the vehicles in that lane in the order of their positions: of two it rear-ends, the one struck
    earlier is behind the one struck later. Any number of vehicles, any labels: the places are chained (X behind
    Y behind Z) and an NPC's relation to V1 is revised only when the chain settles it, the NPC travels V1's way
    and references V1, and the text does not place it (`_same_direction_relation` placed it ahead by default).
    Contacts between vehicles on stated different lanes, or involving a vehicle that leaves its lane, turns or
    loses control, are not read (`order_along_one_lane`, which the LLM backends' review also reads). Written for
    3-C1-2018-003 (rule_sources.SESSION_7_DEDUCTIONS)."""
    if not state.unstated_positions or not state.uses("rules_positions.struck_in_the_order_of_their_positions"):
        return
    roles = {vehicle.role: vehicle for vehicle in state.vehicles.values()}
    chain = []
    for contact in collisions:
        striker, struck = roles[contact["striking"]], roles[contact["struck"]]
        if contact["class"] == "rear_end" and contact["struck_area"] == "rear" and \
                striker.behavior in KEEPS_ITS_LANE and struck.behavior in KEEPS_ITS_LANE and \
                not (striker.lane_side and struck.lane_side and striker.lane_side != struck.lane_side):
            chain.append((striker.label, struck.label))
    closure = order_along_one_lane(chain)
    if closure is None:
        return  # the sequence contradicts itself: it places nothing
    chains = "; ".join(f"{striker} rear-ended {', then '.join(struck)}"
                       for striker, struck in struck_in_turn(chain).items())
    for label in sorted(state.unstated_positions):
        position = actors[state.vehicles[label].role]["position"]
        if position.get("reference") != "ego" or position.get("heading") != "same_direction":
            continue
        relation = "behind" if (label, "V1") in closure else "front" if ("V1", label) in closure else None
        if relation and relation != position["relation"]:
            position["relation"] = relation
            state.evidence[f"actors.{state.vehicles[label].role}.position"] = clip(
                f"from the crash sequence ({chains}): {label} is {relation} V1 along one lane")
