"""Rules extractor: each vehicle's primary pre-crash manoeuvre (dsl.md convention 8) from the phrases of
the pre-crash text ("lost control", "crossed the centerline", "was stopped waiting to turn left").
"""
from __future__ import annotations

import re

from crashscene.extract.narrative import (
    COMPASS,
    DIR,
    around,
    label_at,
    last_label_before,
)
from crashscene.extract.rules_state import LANE_SIDES, RulesState, Vehicle, lane_side


def _any(*alternatives: str) -> str:
    """One regex matching any of the phrasings."""
    return "|".join(alternatives)


_LOSE = _any(r"\blost control", r"\bloss of control", r"\blose control",
             r"\bbegan (?:to )?(?:rotat|yaw|skid|spin|fishtail)", r"\bbegan a (?:\w+ )?(?:rotation|yaw|spin)",
             r"\b(?:spun|yawed|fishtailed|hydroplaned)\b")
# dsl.md section 3 and conventions 8, 9: crossed the centre line, drift, wrong way, entering the opposing lanes
_CROSS_SPEC = _any(
    r"cross(?:ed|ing|es)?\s+(?:over\s+)?the\s+(?:double\s+(?:yellow\s+)?|solid\s+|painted\s+)*"
    r"(?:cent(?:er|re)[- ]?lines?|cent(?:er|re) lane lines|double (?:yellow )?lines?|yellow lines?)",
    r"into the (?:opposing|oncoming) (?:traffic )?(?:travel )?lane",
    r"wrong[- ]way",
    r"drift(?:ed|ing)? (?:across|over) the cent",
    r"into (?:the )?(?:path of )?oncoming traffic",
    r"in the wrong direction")
# rules.md's own words for the same concept (CVC_21460 "left of double solid centre lines", "beyond a double solid
# centre line"; CVC_21650 "in a lane of the opposite direction", wrong_side) and dsl.md's "enters the opposing
# lanes", "crosses into the opposing carriageway"
_CROSS_RULEBOOK = _any(
    r"left[- ]of[- ](?:the\s+)?(?:double\s+solid\s+)?cent(?:er|re)",
    r"beyond (?:the|a) (?:double\s+solid\s+)?cent(?:er|re)[- ]?lines?",
    r"\b(?:in|into|entered|entering|enters) (?:a|an|the) lanes? of the opposite direction",
    r"\bwrong[- _]side of the (?:road|roadway|street|highway)",
    r"\bent(?:er|ers|ered|ering) the opposing lanes?",
    r"\binto the opposing carriageway")
_CROSS_MORE = _any(r"encroach\w* (?:\w+ ){0,2}into V[1-9]'s (?:travel )?lane", r"against the flow")  # read in reports
_CROSS = _any(_CROSS_SPEC, _CROSS_RULEBOOK, _CROSS_MORE)
_LEAVE_SPEC = _any(
    r"(?:depart(?:ed|ing|s)?|exit(?:ed|ing|s)?|ran|run|running|drove|went|veered|travel(?:ed|led)?)\s+(?:off\s+)?"
    r"(?:of\s+)?the\s+(?:left|right|north|south|east|west)?\s*(?:side|edge)\s+of\s+the\s+"
    r"(?:road|roadway|travel lane|highway|lane)",
    r"ran off the road", r"off the roadway",
    # "exited the roadway onto the exit ramp" is not leaving the road
    r"(?:depart(?:ed|ing)?|exit(?:ed|ing)?|left) the (?:road|roadway)\b"
    r"(?! onto the (?:single |one |\w+ )?(?:lane )?(?:exit |entrance )?ramp)")
_LEAVE_MORE = _any(  # read in the reports: the shoulder, the roadside, off the travel lane
    r"onto the (?:left |right )?(?:shoulder|roadside)",
    r"entered the (?:[\w-]+ ){0,4}?(?:edge of the )?(?:left |right )?shoulder",
    r"drift(?:ed|ing)? (?:partially )?(?:off|to the (?:right|left) of) the (?:travel lane|road|roadway)")
_OVERTAKE = _any(r"attempt(?:ed|ing)? to pass\b", r"\bpass(?:ed|ing)? (?:a |the )?(?:slower|V[1-9])", r"\bovertak\w+",
                 r"to pass V[1-9]")
# "veered to the left and into the left northbound lane": groups = side, target lane, its direction
_LANE_CHANGE_VERBS = r"chang(?:ed|ing) lanes|merg(?:ed|ing)"  # section 3 and convention 8: a lane change, merging
_LANE_CHANGE_MORE_VERBS = r"veer(?:ed|ing)?|mov(?:ed|ing)|steer(?:ed|ing)|swerv(?:ed|ing)|drift(?:ed|ing)"
_LANE_CHANGE = (r"(?:VERBS)\s+(?:\w+\s+){0,3}?(?:to\s+the\s+)?(left|right)?[^.]{0,40}?into the "
                r"(left|right|adjacent|middle|center|inside|outside|passing|(?:north|south|east|west)bound)\s*"
                r"((?:north|south|east|west)bound)?")
_LANE_CHANGE_SIDE = _any(r"chang(?:e|ed|ing|es) lanes? (?:to|into) the (left|right)",
                         r"lane change to the (left|right)", r"(?:merge|merged|merging) (?:to the )?(left|right)")
# entering a freeway from an on-ramp: ramps join from the right, so the merge is a change to the left
_RAMP_MERGE = (r"(?:attempt\w* to|began to|was)\s+(?:enter|merg\w*)\w*\s+(?:onto\s+|into\s+)?(?:the\s+)?(?:same\s+)?"
               r"(?:freeway|interstate|highway|expressway|traffic|travel lanes?)")
_TURN_LEFT = _any(r"turn(?:ed|ing|s)?\s+left", r"left[- ]turn(?:ing)?(?! lane)", r"make a left", r"making a left",
                  r"initiat\w+ a left")
_TURN_RIGHT = _any(r"turn(?:ed|ing|s)?\s+right", r"right[- ]turn(?:ing)?(?! lane)", r"make a right", r"making a right")
_U_TURN = r"\bu[- ]turn(?:ing|ed)?\b(?! lane)"
_STOPPED = _any(r"\b(?:brought|came|come|coming)\s+(?:\w+\s+){0,2}to a (?:stop|halt)",
                r"\b(?:was|were|had|been|came to a|come to a) (?:stopped|stationary|stopping|slowing to a stop)",
                r"\bstopped in (?:the )?(?:travel )?lane",
                r"\bstopped (?:in|for|at|behind) (?:traffic|the|a)\b", r"\bstopped\b")
_WAITING = r"\bwaiting (?:to|for)\b"  # read in the reports
_PARKED = _any(r"\bparked\b", r"\bdisabled\b")  # convention 1: a parked or disabled vehicle is static
_UNOCCUPIED = _any(r"\bunoccupied\b", r"\babandoned\b")  # read in the reports
_DECEL = _any(r"\bslow(?:ed|ing)(?: down)?\b", r"\bbrak(?:ed|ing)\b", r"\bdecelerat\w+")
_PROCEED = (r"\b(?:then |and )?(?:proceeded|pulled (?:out|into|forward)|entered|accelerated|"
            r"began to (?:cross|proceed|move))")


# "drifted to the left and into the path of V2": into an oncoming vehicle's path is into the opposing lanes
_INTO_PATH = (r"(?:drift|veer|swerv|steer|travel|mov|cross|went|go)\w*\s+(?:[\w,-]+\s+){0,6}?into the (?:travel )?"
              r"(?:path|lane) of (V[1-9])\b")
_INTO_LANE = (r"across the (?:north|south|east|west)bound (?:travel )?lanes?|(?:into|enter(?:ed|ing|s)?|in) the "
              r"(?:north|south|east|west)bound (?:travel )?lanes?(?! of)")
# rules.md CVC_21650 "in a lane of the opposite direction", whatever qualifies the lane: named by its direction of
# travel with qualifiers between ("into the adjacent northbound travel lane" while southbound) or by a vehicle that
# travels the opposite way ("into V1's lane", "into the lane of V1"); the verb does not decide, the lane does
_OPPOSITE_LANE_BY_DIRECTION = (r"\b(?:into|entered|entering|enters|in) the (?:(?!V[1-9]\b)[\w-]+\s+){1,2}?"
                               r"(?:north|south|east|west)bound (?:travel )?lanes?\b(?! of)")
_OPPOSITE_LANE_BY_VEHICLE = r"\b(?:in|into) (?:the (?:travel )?lane of (V[1-9])\b|(V[1-9])['’]s (?:travel )?lane\b)"
# dsl.md convention 9's "lane change or merge into another vehicle": a lane change (section 3, convention 8's
# merging) into a named vehicle's lane or path; the side is the way from the changer's lane to that vehicle's
_INTO_A_VEHICLE = (r"\b(?:chang(?:e|ed|es|ing) lanes?|lane change|merg(?:e|ed|es|ing))\b[^.]{0,30}?\binto "
                   r"(?:the (?:travel )?(?:path|lane) of (V[1-9])\b|(V[1-9])['’]s (?:travel )?(?:path|lane)\b)")
# a move from the vehicle's stated lane into another lane of its own direction, named by its side and that direction
# ("into the left northbound lane" from the right northbound lane), whatever the verb: a lane change (dsl.md section
# 3 change_lane_left|right; rules.md CVC_22107's "target lane"); groups = the target's side, its direction
_OWN_DIRECTION_LANE = (r"\b(?:into|entered|entering|enters) the (left|right|middle|cent(?:er|re))(?:most)? "
                       r"(north|south|east|west)bound (?:travel )?lane\b(?! of)")
_RAMP = r"\b(?:entrance|on)[- ]ramp\b|\bacceleration lane\b"
_PARKED_NAMED = (r"\b(?:parked{unoccupied})\b[^.()]{{0,60}}\(\s*{label}\s*\)|"
                 r"\(\s*{label}\s*\)\s*(?:that|which)\s+was\s+(?:legally\s+)?(?:parked{unoccupied})|"
                 r"\b{label}\b[^.]{{0,80}}\bwas\s+(?:legally\s+)?parked\b")
_PARKED_APPOSITION = r"|\b{label},\s+an?\s+(?:[\w-]+\s+){{0,3}}?(?:parked|unoccupied|disabled)\b"  # "V2, a parked car"
# phrase table: (switch, pattern, token); a token names a behaviour or a clue the resolution reads. The first
# round's phrasings: the spec's own words (dsl.md sections 3 and 5) and, apart, those read in the reports
PHRASES = (
    ("rules_behavior.lose_control_words", _LOSE, "lose_control"),
    ("rules_behavior.centre_line_crossing_words", _CROSS_SPEC, "cross_centerline"),
    ("rules_behavior.rulebook_crossing_words", _CROSS_RULEBOOK, "cross_centerline"),
    ("rules_behavior.veering_into_a_lane", _CROSS_MORE, "cross_centerline"),  # the reports' moves into a lane
    ("rules_behavior.run_off_road_words", _LEAVE_SPEC, "leave_road"),
    ("rules_behavior.shoulder_is_leaving_the_road", _LEAVE_MORE, "leave_road"),
    ("rules_behavior.overtake_words", _OVERTAKE, "overtake"),
    ("rules_behavior.lane_change_words", _LANE_CHANGE.replace("VERBS", _LANE_CHANGE_VERBS), "lane_change"),
    ("rules_behavior.veering_into_a_lane", _LANE_CHANGE.replace("VERBS", _LANE_CHANGE_MORE_VERBS), "lane_change"),
    ("rules_behavior.lane_change_words", _LANE_CHANGE_SIDE, "lane_change_side"),
    ("rules_behavior.lane_change_words", _RAMP_MERGE, "ramp_merge"),
    ("rules_behavior.turn_words", _TURN_LEFT, "turn_left"), ("rules_behavior.turn_words", _TURN_RIGHT, "turn_right"),
    ("rules_behavior.turn_words", _U_TURN, "u_turn"), ("rules_behavior.stop_words", _STOPPED, "stop"),
    ("rules_behavior.waiting_is_stopped", _WAITING, "stop"),
    ("rules_behavior.parked_words", _PARKED, "static"), ("rules_behavior.unoccupied_is_parked", _UNOCCUPIED, "static"),
    ("rules_behavior.slowing_words", _DECEL, "decelerate"),
    ("rules_behavior.centre_line_crossing_words", _INTO_LANE, "into_lane"),
    ("rules_behavior.centre_line_crossing_words", _INTO_PATH, "into_path"),
    ("rules_behavior.lane_of_the_opposite_direction", _OPPOSITE_LANE_BY_DIRECTION, "into_lane"),
    ("rules_behavior.lane_of_the_opposite_direction", _OPPOSITE_LANE_BY_VEHICLE, "into_path"),
    ("rules_behavior.lane_change_into_a_vehicle", _INTO_A_VEHICLE, "lane_change_into"),
    ("rules_behavior.into_another_lane_of_its_direction", _OWN_DIRECTION_LANE, "into_own_lane"),
)
# general phrasings of the same manoeuvres (dsl.md convention 8), each a recorded switch (rule_sources)
MORE_PHRASES = (
    ("rules_behavior.skids_slides_and_traction", _any(
        r"\bskid(?:ded|ding) (?:sideways|out of control|across|into the (?:opposing|oncoming|other))",
        r"\bbegan (?:to )?slid(?:e|ing)", r"\bslid (?:sideways|out of control)",
        r"\bentered an? (?:\w+ )?(?:yaw|skid|spin|rotation)\b", r"\blost (?:traction|its traction|grip)",
        r"\bover-?correct(?:ed|ing|ion)\b"), "lose_control"),
    ("rules_behavior.sitting_in_traffic_is_a_stop", r"\bsitting (?:stopped |still )?(?:in|at)\b", "stop"),
    # "made an unsafe lane change into the right lane": groups = side, target lane, its direction (as _LANE_CHANGE)
    ("rules_behavior.made_a_lane_change",
     r"(?:made|making|initiat\w+|attempt\w+|perform\w+)\s+an?\s+(?:[\w-]+\s+){0,2}lane change\s+(?:to\s+the\s+"
     r"(left|right)|[^.]{0,30}?into the (left|right|adjacent|middle|center|inside|outside|(?:north|south|east|west)bound)"
     r"\s*((?:north|south|east|west)bound)?)", "lane_change"),
)
# manoeuvres where the first one stated is the primary one (convention 8: crossed first -> cross_centerline)
_EVENTS = ("lose_control", "cross_centerline", "leave_road", "overtake", "lane_change", "lane_change_side",
           "ramp_merge", "into_lane", "into_path", "lane_change_into", "into_own_lane")

Phrase = tuple[int, str, re.Match]  # position in the pre-crash text, token, match


def decide_behaviors(state: RulesState) -> None:
    """Set each vehicle's `behavior` (with its quote) and `flags` (every clue token seen for it)."""
    phrases = _phrases(state)
    for label, vehicle in state.vehicles.items():
        found = sorted(phrases[label], key=lambda item: item[0])
        vehicle.behavior, quote = _resolve(state, vehicle, found)
        if vehicle.behavior in ("go_forward", "decelerate") and state.between and \
                state.uses("rules_behavior.opposing_entry_between_impacts"):
            # "V1 struck V2's rear ... V3 saw V1 enter the eastbound lane" then V1 and V3 collide head-on
            entered = _entered_opposing(state, vehicle)
            if entered:
                vehicle.behavior, quote = "cross_centerline", entered
        if quote:
            vehicle.behavior_quote = quote
            state.note(f"actors.{vehicle.role}.behavior", quote)
        vehicle.flags = {token for _, token, _ in found}
        if any(token == "into_lane" and _opposing_lane(vehicle, match.group(0)) for _, token, match in found):
            vehicle.flags.add("cross_centerline")


def _phrases(state: RulesState) -> dict[str, list[Phrase]]:
    """Every behaviour phrase of the pre-crash text, attributed to the vehicle(s) it describes."""
    pre = state.pre_crash
    phrases: dict[str, list[Phrase]] = {label: [] for label in state.vehicles}
    leaders = [v.label for v in state.vehicles.values() if v.role != "ego" and
               state.uses("rules_behavior.slowing_traffic_is_the_leaders") and re.search(
        rf"\b{v.label}\b[^.]{{0,200}}\b(?:ahead of|in front of) (?:V1|him|her)\b", state.t.text, re.I)]
    table = [(pattern, token) for name, pattern, token in (*PHRASES, *MORE_PHRASES) if state.uses(name)]
    for pattern, token in table:
        if token == "ramp_merge" and not re.search(_RAMP, pre, re.I):
            continue
        for match in re.finditer(pattern, pre, re.I):
            for label in _described(state, pre, match, token, leaders):
                if label in phrases:
                    phrases[label].append((match.start(), token, match))
    return phrases


def _described(state: RulesState, pre: str, match: re.Match, token: str, leaders: list[str]) -> list[str]:
    """The vehicles a phrase describes: a listed subject ("V1, V3, and V4 slowed"), the acting label, or none
    when an unlabelled vehicle acts ("the vehicle in front of him was stopped"). Slowing traffic ahead is the
    leaders' behaviour."""
    start = match.start()
    sentence_head = pre[max(pre.rfind(". ", 0, start), pre.rfind("; ", 0, start), 0):start]
    clause = pre[max(pre.rfind(". ", 0, start), pre.rfind(", ", 0, start), 0):start]
    listed = re.search(r"((?:V[1-9](?:,\s*|\s+and\s+|,\s+and\s+))+V[1-9])\s+(?:also\s+|all\s+|both\s+)?$",
                       sentence_head)
    if listed:
        return re.findall(r"V[1-9]", listed.group(1))
    if not re.search(r"\bV[1-9]\b", clause) and re.search(
            r"\b(?:non-contact|another|other|third|lead|leading|a|the)\s+vehicle\b|\btraffic\b", clause, re.I):
        slowing_traffic = token in ("decelerate", "stop") and re.search(r"\btraffic\b", clause, re.I)
        return leaders if slowing_traffic else []
    label = label_at(pre, start)
    if label is None and len(state.vehicles) == 1:
        label = "V1"
    if label is None:
        # "The driver failed to negotiate ..." after sentences about one vehicle
        label = last_label_before(pre, start)
    return [label] if label else []


def _entered_opposing(state: RulesState, vehicle: Vehicle) -> str | None:
    """A move into the opposing lanes between the first and the second impact, quoted, if the text states one."""
    text = state.between
    for match in re.finditer(rf"\b{vehicle.label}\s+(?:then\s+)?(?:enter\w*|mov\w+|swerv\w+|veer\w+|drift\w+)\s+"
                             rf"(?:\w+\s+){{0,3}}?(?:into\s+)?the\s+({DIR})bound\s+(?:travel\s+)?lane", text, re.I):
        if _opposite(vehicle, match.group(1)):
            return around(text, match, 80)
    match = re.search(rf"\b{vehicle.label}\b(?:(?!\b(?:pushed|caused|redirected|forced)\b)[^.]){{0,60}}(?:{_CROSS})",
                      text, re.I)
    return around(text, match, 80) if match else None


def _towards(side: str, target: str) -> str:
    """The lane change from one lane side of a direction to another (LANE_SIDES runs left to right)."""
    return "change_lane_right" if LANE_SIDES.index(target) > LANE_SIDES.index(side) else "change_lane_left"


def _opposite(vehicle: Vehicle, direction: str) -> bool:
    return vehicle.direction is not None and (COMPASS[direction.lower()] - COMPASS[vehicle.direction]) % 360 == 180


def _opposing_lane(vehicle: Vehicle, phrase: str) -> bool:
    match = re.search(DIR + "bound", phrase, re.I)
    return bool(match) and _opposite(vehicle, match.group(1))


def _resolve(state: RulesState, vehicle: Vehicle, found: list[Phrase]) -> tuple[str, str | None]:
    """The primary manoeuvre and its quote: parked, else the first lane-leaving event, else a turn (or the stop
    before it), else a stop, else slowing, else go_forward."""
    pre = state.pre_crash

    def quote(match: re.Match) -> str:
        return around(pre, match, 80)

    static = next((m for _, token, m in found if token == "static"), None)
    if static:
        return "static", quote(static)
    named = _PARKED_NAMED + (_PARKED_APPOSITION if state.uses("rules_behavior.parked_in_apposition") else "")
    unoccupied = "|unoccupied|non-occupied|abandoned" if state.uses("rules_behavior.unoccupied_is_parked") else ""
    parked = re.search(named.format(label=vehicle.label, unoccupied=unoccupied), state.t.text, re.I) \
        if state.uses("rules_behavior.parked_words") else None
    if parked:
        return "static", around(state.t.text, parked, 80)
    events = [(m, e) for _, token, m in found if token in _EVENTS for e in [_event(vehicle, token, m, state)] if e]
    if events and state.uses("rules_behavior.leaving_the_road_is_primary_only_without_control_loss"):
        event = events[0][1]
        later = [e for _, e in events[1:]]
        if event == "leave_road" and "lose_control" in later:  # convention 8: ran off WITHOUT losing control
            events = [next(item for item in events if item[1] == "lose_control")]
        elif event == "leave_road" and "cross_centerline" in later and _strikes_a_vehicle(state, vehicle):
            # onto the shoulder, then back across the centre line into another vehicle: the crossing leads to it
            events = [next(item for item in events if item[1] == "cross_centerline")]
    if events and state.uses("rules_behavior.crossing_to_pass_is_overtaking") and events[0][1] == "cross_centerline":
        first = events[0][0]
        overtake = next((m for _, t, m in found if t == "overtake" and 0 <= m.start() - first.end() < 60), None)
        if overtake and "." not in pre[first.end():overtake.start()]:  # "pulled into the westbound lane to pass V1"
            events = [(first, "overtake")]
    for match, event in events[:1]:
        return event, quote(match)
    stop = next((m for _, t, m in found if t == "stop"), None)
    for token in ("u_turn", "turn_left", "turn_right"):
        match = next((m for _, t, m in found if t == token), None)
        if match:
            stop_to = state.uses("rules_behavior.stopped_to_turn_is_a_stop")
            waiting = state.uses("rules_behavior.waiting_to_turn_is_a_stop") and \
                _waiting_to_turn(pre, vehicle, stop, match, stop_to)
            return ("stop", quote(stop)) if waiting else (token, quote(match))
    if stop and state.uses("rules_behavior.stopped_then_proceeded"):
        went_on = _PROCEED
        if state.uses("rules_behavior.failing_to_yield_after_a_stop_is_proceeding"):
            went_on += r"|\bfail(?:ed|ing|s)? to yield|\bpulled into"  # "stopped, then failed to yield"
        for proceed in re.finditer(went_on, pre[stop.end():], re.I):
            if label_at(pre, stop.end() + proceed.start()) in (vehicle.label, None):
                return "go_forward", quote(stop)  # stopped at the sign, then went on (convention 8)
    if stop:
        return "stop", quote(stop)
    decel = next((m for _, t, m in found if t == "decelerate"), None)
    avoiding = vehicle.role == "ego" and decel and re.search(r"avoid", pre[decel.start() - 60: decel.end()], re.I)
    if decel and not (avoiding and state.uses("rules_vehicles.avoidance_is_not_the_manoeuvre")):
        return "decelerate", quote(decel)
    return "go_forward", None


def _event(vehicle: Vehicle, token: str, match: re.Match, state: RulesState) -> str | None:
    """The behaviour a lane-leaving phrase means for this vehicle, or None when it does not apply."""
    if token == "into_path":
        if not state.uses("rules_behavior.into_oncoming_path"):
            return None
        other = state.vehicles.get(next((g for g in match.groups() if g), ""))
        oncoming = other is not None and other.direction is not None and _opposite(vehicle, other.direction)
        return "cross_centerline" if oncoming else None
    if token in ("lose_control", "cross_centerline", "leave_road", "overtake"):
        return token
    if token == "lane_change":
        target = (match.group(2) or "").lower()
        bound = (match.group(3) or match.group(2) or "").lower()
        if bound.endswith("bound") and _opposite(vehicle, bound[:-5]):
            return "cross_centerline"  # "veered left into the southbound lane" while northbound
        side = (match.group(1) or (target if target in ("left", "right") else "") or "").lower()
        from_ramp = re.search(rf"\b{vehicle.label}\b[^.]{{0,80}}(?:{_RAMP})", state.pre_crash, re.I)
        if (match.group(0).lower().startswith("merg") and re.search(_RAMP, state.pre_crash, re.I) or from_ramp) and \
                state.uses("rules_behavior.merging_from_a_ramp_is_to_the_left"):
            side = "left"  # "merged into the right lane" from an on-ramp: ramps join from the right
        return f"change_lane_{side}" if side in ("left", "right") else None
    if token == "lane_change_into":
        other = state.vehicles.get(next((g for g in match.groups() if g), ""))
        if other is None or other is vehicle or (other.direction and _opposite(vehicle, other.direction)):
            return None  # into an oncoming vehicle's lane is the opposing lanes, read by the crossing rules
        if vehicle.lane_side is None or other.lane_side is None or vehicle.lane_side == other.lane_side:
            return None  # the side is not stated: no manoeuvre guessed
        return _towards(vehicle.lane_side, other.lane_side)
    if token == "into_own_lane":
        target = lane_side(match.group(1).lower())
        if vehicle.direction != match.group(2).lower() or vehicle.lane_side is None or vehicle.lane_side == target:
            return None  # another direction's lane, or the vehicle's own lane is not stated
        return _towards(vehicle.lane_side, target)
    if token == "ramp_merge":
        return "change_lane_left"
    if token == "lane_change_side":
        return f"change_lane_{next(g for g in match.groups() if g).lower()}"
    if token == "into_lane" and _opposing_lane(vehicle, match.group(0)):
        return "cross_centerline"
    return None


def _strikes_a_vehicle(state: RulesState, vehicle: Vehicle) -> bool:
    """Whether an impact sentence names this vehicle and another one (the contacts are read after behaviours)."""
    return bool(re.search(rf"\b{vehicle.label}\b[^.]*\b(?:struck|strikes?|impacted|hit|collided)\b[^.]*\bV[1-9]\b|"
                          rf"\bV[1-9]\b[^.]*\b(?:struck|strikes?|impacted|hit|collided)\b[^.]*\b{vehicle.label}\b",
                          state.t.text))


def _waiting_to_turn(pre: str, vehicle: Vehicle, stop: re.Match | None, turn: re.Match, stop_to: bool = False
                     ) -> bool:
    """'was stopped ... waiting to turn left' with no later 'began to enter': the manoeuvre is the stop."""
    if stop is None or stop.start() >= turn.start():
        return False
    intention = re.search(r"(?:waiting|preparing|intending|planning|about|signal(?:ing|led)?|so as)\b[^.;]{0,40}$",
                          pre[max(0, turn.start() - 50):turn.start()], re.I)
    if stop_to and not intention:  # "came to a stop in the lane to make a left turn"
        intention = re.search(r"\b(?:stop|stopped|halt)(?: in (?:the|its) (?:\w+ )?lane)?\s+(?:in order\s+)?to\s*$",
                              pre[max(0, turn.start() - 50):turn.start()], re.I)
    proceeded = re.search(_PROCEED + r"|began to enter|with the intention of turning", pre[turn.end():], re.I)
    went_on = proceeded and label_at(pre, turn.end() + proceeded.start()) == vehicle.label
    return bool(intention) and not went_on



def revise_by_contacts(state: RulesState, actors: dict, collisions: list[dict]) -> None:
    """Manoeuvres the crash sequence settles (dsl.md conventions 8 and 11), once the contacts are read: a vehicle
    struck in the rear that the text has stopped before its turn was stopped in a queue (`stop`), not turning: it
    never began the turn."""
    roles = {vehicle.role: vehicle for vehicle in state.vehicles.values()}
    for contact in collisions:
        struck = roles[contact["struck"]]
        if contact["class"] == "rear_end" and contact["struck_area"] == "rear" and \
                struck.behavior in ("turn_left", "turn_right", "u_turn") and "stop" in struck.flags and \
                _turn_intended(state, struck) and \
                state.uses("rules_behavior.struck_from_behind_before_the_turn_is_a_stop"):
            _revise(state, actors, struck, "stop", struck.behavior_quote)


def _turn_intended(state: RulesState, vehicle: Vehicle) -> bool:
    """The text gives the vehicle a turn only as an intention ("to turn left", "to make a left turn"), never as
    made ("then turned right"): a turn made after the stop is the manoeuvre (convention 8)."""
    pre = state.pre_crash
    turns = [m for m in re.finditer(_any(_TURN_LEFT, _TURN_RIGHT, _U_TURN), pre, re.I)
             if label_at(pre, m.start()) == vehicle.label]
    return bool(turns) and all(re.search(r"\bto\s+(?:\w+\s+){0,2}$", pre[max(0, m.start() - 30):m.start()], re.I)
                               for m in turns)


def _revise(state: RulesState, actors: dict, vehicle: Vehicle, behavior: str, quote: str | None) -> None:
    vehicle.behavior = behavior
    vehicle.flags.add(behavior)
    actors[vehicle.role]["behavior"] = behavior
    state.evidence[f"actors.{vehicle.role}.behavior"] = f"from the crash sequence: {behavior}" + (
        f"; {quote}" if quote else "")
