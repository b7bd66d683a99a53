"""Rules extractor: the number of through lanes of V1's roadway (dsl.md convention 3).

Two-way roads count both directions; a divided or one-way roadway counts V1's carriageway. Turn-only lanes
("the far-left lane being a U-turn lane", "a two-way left turn lane", the middle lane of a "five-lane" road)
are not through lanes; an acceleration lane counts when a merge is part of the crash.
"""
from __future__ import annotations

import re

from crashscene.extract.narrative import DIR, NUM, around, count_word
from crashscene.extract.rules_state import RulesState

_PLAIN_WORD = r"(?!(?:north|south|east|west)bound\b)(?![\w-]*way\b)[\w-]+"  # not a direction, not "two-way"


def count_lanes(state: RulesState, road_text: str, ways: int) -> int:
    """Through lanes of V1's roadway: all directions when two-way, V1's carriageway when divided or one-way."""
    ego = state.vehicles["V1"]
    per_direction: dict[str, int] = {}
    quote = None

    def put(direction: str, number: int, match: re.Match, override: bool = False) -> None:
        nonlocal quote
        if number and (override or direction not in per_direction):
            per_direction[direction] = number
            quote = quote or around(road_text, match)

    # "two lanes northbound ... two lanes southbound", "three northbound lanes and four southbound lanes"
    if state.uses("rules_lanes.lanes_per_direction_phrases"):
        per_direction_count = (rf"\b{NUM}\s+(?:straight\s+)?(?:through\s+)?(?:travel\s+)?(?:lanes?\s+)?{DIR}bound"
                               rf"(?:\s+(?:through\s+|travel\s+)?lanes?)?|\b{NUM}\s+(?:travel\s+)?lanes?\s+{DIR}bound")
    elif state.uses("rules_lanes.through_lanes_per_direction"):
        # the specs' words alone (dsl.md section 3: "counts the through lanes of that roadway in both directions"):
        # a count of (through) lanes for one direction of travel, "two northbound lanes", "two lanes southbound"
        per_direction_count = (rf"\b{NUM}\s+(?:through\s+)?{DIR}bound\s+(?:through\s+)?lanes?\b|"
                               rf"\b{NUM}\s+(?:through\s+)?lanes?\s+{DIR}bound\b")
    else:
        per_direction_count = None
    for match in () if per_direction_count is None else re.finditer(per_direction_count, road_text, re.I):
        groups = [g for g in match.groups() if g]
        put(groups[1].lower(), count_word(groups[0]), match)
    # "the southbound traffic-way consisted of a six-lane roadway", "the westbound roadway has three travel lanes"
    for match in () if not state.uses("rules_lanes.carriageway_lane_phrases") else re.finditer(
            rf"(?<![/-]){DIR}(?:bound)?\s+(?:roadway|lanes|traffic-?way|carriageway|side)\b"
                             rf"[^.]{{0,60}}?"
                             rf"\b{NUM}[- ](?:{_PLAIN_WORD}\s+){{0,3}}?lanes?\b", road_text, re.I):
        put(match.group(1).lower(), count_word(match.group(2)), match, override=True)
    # "the two-way east/west roadway consisted of two travel lanes": a total for the road on V1's axis
    axis = "north/south" if ego.direction in ("north", "south") else "east/west" if ego.direction else None
    for match in () if not state.uses("rules_lanes.carriageway_lane_phrases") else re.finditer(
            rf"\b(north[/-]south|east[/-]west)\s+(?:roadway|road|street|highway|trafficway)\b"
                             rf"[^.]{{0,60}}?\b{NUM}[- ](?:{_PLAIN_WORD}\s+){{0,3}}?lanes?\b", road_text, re.I):
        if axis and match.group(1).lower().replace("-", "/") == axis and not any(
                d in per_direction for d in axis.split("/")):
            put("_axis", count_word(match.group(2)), match)
    # explicit through-lane breakdowns and "three lanes continue westbound" override totals that hold turn lanes
    breakdown = state.uses("rules_lanes.through_lane_breakdown")
    for match in re.finditer(rf"{DIR}bound lanes (?:are|were) composed of ([^.]*)", road_text if breakdown else "",
                             re.I):
        through = re.search(rf"{NUM}\s+(?:straight\s+)?through", match.group(2), re.I)
        if through:
            put(match.group(1).lower(), count_word(through.group(1)), match, override=True)
            per_direction.setdefault("_breakdown", 0)
    for match in re.finditer(rf"\b{NUM}\s+(?:through\s+)?lanes\s+continu\w*(?:[^.]{{0,30}}?{DIR})?",
                             road_text if breakdown else "", re.I):
        direction = (match.group(2) or ego.direction or "").lower()
        if direction:
            put(direction, count_word(match.group(1)), match, override=True)
    if "_breakdown" in per_direction:
        del per_direction["_breakdown"]
    elif state.uses("rules_lanes.turn_lane_named_in_a_count"):
        # "six southbound lanes, with the far-left lane being a U-turn lane and the adjacent one a left turn lane"
        for turn in re.finditer(r"\b(?:being|is|was|as)\s+an?\s+(?:dedicated\s+)?(?:u-turn|left[- ]turn(?:[- ]only)?|"
                                r"right[- ]turn(?:[- ]only)?)\s+lane", road_text, re.I):
            direction = re.findall(rf"{DIR}bound", road_text[: turn.start()], re.I)
            key = direction[-1].lower() if direction else None
            if key in per_direction and per_direction[key] > 1:
                per_direction[key] -= 1
    each = re.search(r"one (?:travel )?lane in each direction|single lane in each direction", road_text, re.I) \
        if state.uses("rules_lanes.one_lane_in_each_direction") else None
    if each:
        per_direction = {"a": 1, "b": 1}
        quote = around(road_text, each)
    elif state.uses("rules_lanes.lanes_in_each_direction"):
        # "three lanes in each direction", "two travel lanes per direction"
        each = re.search(rf"\b{NUM}\s+(?:through\s+|travel\s+)?lanes?\s+(?:in\s+each|per|for\s+each|each)\s+"
                         r"(?:direction|way)\b",
                         road_text, re.I)
        if each and count_word(each.group(1)) and not per_direction:
            number = count_word(each.group(1))
            per_direction = {"a": number, "b": number}
            quote = around(road_text, each)
    if axis:  # counts of the crossing road do not describe V1's roadway
        per_direction = {d: n for d, n in per_direction.items() if d in axis.split("/") or d in ("a", "b", "_axis")}
    lanes = None
    if "_axis" in per_direction:
        total = per_direction["_axis"]
        lanes = total if ways == 2 else max(1, total // 2)
    elif per_direction:
        if ways == 1:
            lanes = per_direction.get(ego.direction or "") or (
                next(iter(per_direction.values())) if len(per_direction) == 1 else max(per_direction.values()))
        else:
            lanes = sum(per_direction.values()) if len(per_direction) > 1 else 2 * next(iter(per_direction.values()))
    else:
        match = re.search(rf"\b{NUM}[- ]lane\b", road_text, re.I) if state.uses("rules_lanes.n_lane_road") else None
        if match:  # convention 3: "a 'two-lane, two-way road' is 2"
            total = count_word(match.group(1))
            quote = around(road_text, match)
            if ways == 2:
                # an odd count on a two-way road holds a centre turn lane ("five-lane ... middle left-turn lane")
                odd = total >= 3 and total % 2 and (state.uses("rules_lanes.odd_total_holds_a_turn_lane") or (
                    state.uses("rules_lanes.a_named_centre_turn_lane_is_not_a_through_lane") and re.search(
                        r"(?:cent(?:er|re)|middle|two-way)\s+(?:two-way\s+)?(?:left[- ])?turn(?:ing)?\s+lane|\bTWLTL\b",
                        road_text, re.I)))  # convention 3: not turn lanes, two-way left-turn lanes
                lanes = total - 1 if odd else total
            elif state.divided and total >= 4 and total % 2 == 0 and not re.search(r"one[- ]way", road_text, re.I) \
                    and state.uses("rules_lanes.divided_total_is_halved"):
                lanes = total // 2  # "a four-lane divided highway": two lanes each way
            else:
                lanes = total
    if lanes is None:
        lanes = 2 if ways == 2 else 1
        quote = "no lane count stated: one lane per direction"
    merge = re.search(r"\b(?:entrance|on)[- ]ramp\b|\bacceleration lane\b|\bmerg(?:e|ed|ing)\b",
                      state.pre_crash + " " + state.crash_sentence, re.I)
    if merge and ways == 1 and len(state.vehicles) > 1 and state.uses("rules_lanes.acceleration_lane_in_a_merge"):
        lanes += 1  # the acceleration lane counts when a merge is part of the crash (dsl.md convention 3)
        quote = f"{quote}; + acceleration lane: {around(state.pre_crash + ' ' + state.crash_sentence, merge, 40)}"
    state.note("road_network.number_of_lanes", quote or "lane count per direction")
    return max(1, lanes)
