"""Rules extractor: the oracle, the California Vehicle Code violations the pre-crash sequence entails
(dsl.md convention 9), each attributed to its actor.

Every entry follows mechanically from what the earlier steps decided, never from a case's wording:
the manoeuvre (lose_control -> CVC_22350; cross_centerline/overtake -> CVC_21650, plus CVC_21460 on a
double solid centre line; a lane change into another vehicle -> CVC_22107), the devices and who they
control (stop sign -> CVC_22450 when the stop is stated as missed, else CVC_21802; yield sign -> CVC_21803;
no device -> CVC_21800 for the vehicle without priority; left turn across oncoming traffic -> CVC_21801;
driveway exit -> CVC_21804), the crash sequence (a rear-end contact the striker drove into: CVC_21703 on a
moving vehicle, CVC_22350 on a stopped one) and the narrative's cause statements ("too fast for
conditions", "speeding", "ran the red light", "failed to stop", "failed to yield"), attributed to the
vehicle the statement is about.
"""
from __future__ import annotations

import re

from crashscene.dsl.tokens import OPPOSING_PASSES, STANDING
from crashscene.extract.narrative import around, clip, label_at, last_label_before
from crashscene.extract.rules_road import driveway_vehicle
from crashscene.extract.rules_state import RulesState, relative_heading
from crashscene.monitor.rules import rule_class


def violation_of(code: str) -> str:
    """The violation token the rule registered for `code` declares (a RegistryError for an unknown code)."""
    return rule_class(code).violation


class _Oracle:
    """The entries found so far; one per (code, actor), each with its quote in the evidence."""

    def __init__(self, state: RulesState):
        self.state = state
        self.entries: list[dict] = []

    def add(self, code: str, role: str, description: str, quote: str | None = None) -> None:
        """One entry; its violation token is the one the rule registered for `code` declares."""
        if any(e["code"] == code and e["actor"] == role for e in self.entries):
            return
        self.entries.append({"code": code, "violation": violation_of(code), "actor": role,
                             "description": clip(description, 300)})
        if quote:
            self.state.note(f"oracle[{len(self.entries) - 1}]", quote)


def decide_oracle(state: RulesState, road: dict) -> list[dict]:
    """Every monitored violation the described pre-crash sequence entails, plus CVC_21804 for driveway exits;
    `[]` when the report states no cause."""
    oracle = _Oracle(state)
    _manoeuvre_oracle(state, road, oracle)
    _junction_oracle(state, road, oracle)
    if state.uses("rules_oracle.sequence_rear_end"):
        _sequence_oracle(state, oracle)
    else:
        _rear_end_by_phrase(state, oracle)
    return oracle.entries


def stated(state: RulesState, pattern: str) -> list[tuple[str, re.Match]]:
    """The vehicles a cause statement is about: the acting vehicle of the clause ("the driver of V2 failed
    to stop"), else the last vehicle named before it, else V1 in a single-vehicle report."""
    text = state.t.text
    out = []
    if not state.uses("rules_oracle.cause_statements"):
        # switched off: the first round's reading, a statement within the sentence after a vehicle's label
        for label in state.vehicles:
            match = re.search(rf"\b{label}\b[^.]{{0,100}}?(?:{pattern})", text, re.I)
            if match:
                out.append((label, match))
        return out
    for match in re.finditer(pattern, text, re.I):
        label = label_at(text, match.start()) or last_label_before(text, match.start())
        if label is None and len(state.vehicles) == 1:
            label = "V1"
        if label in state.vehicles:
            out.append((label, match))
    return out


# cause statements in convention 9's and issue 11's words: "too fast for conditions", "stated speeding", "red
# light", "failed to stop" / "no stop at a stop sign"
_TOO_FAST = r"\btoo fast\b|unsafe speed"
_SPEEDING = (r"\bspeeding\b|exceed(?:ed|ing) the (?:posted )?speed limit|above the (?:posted )?speed limit|"
             r"over the (?:posted )?speed limit")
_RED = r"red (?:light|signal|indication|traffic signal)|against (?:the|a) (?:steady )?red|ran the red"
_RAN_STOP = (r"fail(?:ed|ing|s)? to stop (?:at|for) the stop|did not stop at the stop|ran the stop|"
             r"without stopping|fail(?:ed|ing|s)? to (?:come to a )?"
             r"(?:complete |full )?stop\b(?! for (?:the )?(?:traffic|vehicles?|V[1-9]))")
# the first round's further phrasings, read in the reports
_MORE_TOO_FAST = (r"|excessive (?:speed|rate of speed)|speed too (?:great|high|fast)|high rate of speed|"
                  r"speed (?:was|as) (?:a|the) (?:\w+ )?factor")
_MORE_RED_WORDS = r"|disregard\w* the (?:traffic )?(?:signal|light)"
_MORE_STOP_WORDS = r"|disregarded the stop|rolled through the stop"


# "failed to obey the traffic signal", "drove through the stop sign"
_MORE_RED = r"|fail(?:ed|ing|s)? to (?:obey|observe|comply with) the (?:traffic )?(?:control )?(?:signal|light)"
_MORE_RAN_STOP = (r"|(?:drove|traveled|travelled|went|proceeded|continued|ran|rolled) (?:straight )?(?:past|through) "
                  r"(?:the|a) stop sign|fail(?:ed|ing|s)? to (?:obey|observe|comply with) (?:the|a) stop sign")


def _manoeuvre_oracle(state: RulesState, road: dict, oracle: _Oracle) -> None:
    """Codes that follow from a vehicle's own manoeuvre or stated speed, wherever it happens."""
    text = state.t.text
    words = state.uses("rules_oracle.more_cause_phrases")
    too_fast = {label: match for label, match in reversed(stated(state, _TOO_FAST + (_MORE_TOO_FAST if words else "")))}
    speeding = {label: match for label, match in reversed(stated(state, _SPEEDING))}
    more = state.uses("rules_oracle.disobeyed_device_phrasings")
    red_words = _RED + (_MORE_RED_WORDS if words else "") + (_MORE_RED if more else "")
    red = {label: match for label, match in reversed(stated(state, red_words)) if not (
        state.uses("rules_oracle.red_light_only_when_disobeyed") and _obeyed(text, match))}
    for label, vehicle in state.vehicles.items():
        role, behavior, quote = vehicle.role, vehicle.behavior, vehicle.behavior_quote
        if label in too_fast and behavior != "lose_control":
            quote = around(text, too_fast[label])
        if behavior == "lose_control" or label in too_fast:
            oracle.add("CVC_22350", role,
                       f"{label} lost control or was driven too fast for the conditions.", quote)
        crossed = behavior in OPPOSING_PASSES or (
            behavior == "lose_control" and "cross_centerline" in vehicle.flags)
        if crossed:
            oracle.add("CVC_21650", role, f"{label} entered the opposing lanes of the roadway.", quote)
            if road["road_marker"] == "double_solid_line":
                oracle.add("CVC_21460", role, f"{label} crossed the double solid centre line.",
                           quote)
        # convention 9: a lane change or merge into another vehicle
        if behavior.startswith("change_lane") and not _only_met_vehicles_out_of_control(state, label):
            oracle.add("CVC_22107", role,
                       f"{label} changed lanes into the path of another vehicle.", quote)
        if label in speeding:
            oracle.add("CVC_22349", role, f"{label} exceeded the posted speed limit.",
                       around(text, speeding[label]))
        limit, speed = road.get("speed_limit_mph"), state.speeds.get(label)
        if limit and speed and speed > limit and state.uses("rules_oracle.stated_speed_above_the_limit"):
            oracle.add("CVC_22349", role,
                       f"{label} was traveling at {speed:g} mph where {limit} mph is posted.",
                       state.evidence.get(f"actors.{role}.speed_mph"))
        if label in red and "traffic_light" in road["traffic_signs"]:
            oracle.add("CVC_21453", role, f"{label} entered the intersection against a red signal.",
                       around(text, red[label]))


def _only_met_vehicles_out_of_control(state: RulesState, label: str) -> bool:
    """Whether every vehicle the lane changer touches lost control into it: then the changer moved into no vehicle.

    dsl.md convention 9 charges a "lane change or merge into another vehicle" (CVC_22107), and the rulebook's check
    is on "a vehicle in the target lane" (rules.md CVC_22107); a vehicle that loses control ("skid, yaw,
    rotation", dsl.md section 3) has left its own path, and is charged for that ("losing control, or too fast for
    conditions -> CVC_22350"). So a changer whose only contacts are with vehicles that lost control is not charged;
    one that meets a vehicle under control, or whose contacts are not stated, keeps the convention's code. Written
    for 103341 (rule_sources.SESSION_7_DEDUCTIONS)."""
    partners = [c.struck.label if c.striking.label == label else c.striking.label for c in state.contacts
                if label in (c.striking.label, c.struck.label)]
    return bool(partners) and all(state.vehicles[p].behavior == "lose_control" for p in partners) and \
        state.uses("rules_oracle.no_lane_change_into_a_vehicle_out_of_control")


def _obeyed(text: str, match: re.Match) -> bool:
    """'was stopped for a red light', 'waiting at the red signal': the red is named, not run."""
    head = text[max(0, text.rfind(". ", 0, match.start()), match.start() - 50):match.start()]
    if re.search(r"\b(?:fail\w*\s+to|did\s+not|didn't|never|without)\s+(?:\w+\s+){0,3}$", head, re.I):
        return False  # "failed to stop for the red light"
    return bool(re.search(r"\b(?:stopped|stopping|waiting|slowed|slowing|stop|queued)\s+(?:\w+\s+){0,2}"
                          r"(?:for|at|by)\s+(?:a|the)\s+(?:steady\s+)?$", head, re.I))


def _junction_oracle(state: RulesState, road: dict, oracle: _Oracle) -> None:
    """Right-of-way codes at a junction: left turns, stop and yield signs, uncontrolled junctions, driveways."""
    if road["road_type"] not in ("intersection", "t_intersection"):
        return
    text = state.t.text
    devices = set(road["traffic_signs"]) - {"speed_limit_sign"}
    from_driveway = driveway_vehicle(state)
    failed_to_yield = next((label for label, _ in stated(state, r"fail(?:ed|ing|s)? to yield|did not yield")), None)
    more = state.uses("rules_oracle.disobeyed_device_phrasings")
    stop_words = _RAN_STOP + (_MORE_STOP_WORDS if state.uses("rules_oracle.more_cause_phrases") else "")
    ran_stop = {label: match for label, match in reversed(stated(state, stop_words + (_MORE_RAN_STOP if more else "")))}
    if not failed_to_yield and not devices and ran_stop and \
            state.uses("rules_oracle.failed_to_stop_at_an_uncontrolled_junction"):
        failed_to_yield = next(iter(ran_stop))  # no device: the one stated as not stopping lacks priority
    ran_red = any(e["code"] == "CVC_21453" for e in oracle.entries)
    arrow = re.search(r"(?:green|protected) (?:left[- ]turn )?arrow", text, re.I) and \
        state.uses("rules_oracle.protected_arrow_exempts_a_left_turn")
    stated_oncoming = state.uses("rules_oracle.left_turn_stated_oncoming")
    for label, vehicle in state.vehicles.items():
        role, quote = vehicle.role, vehicle.behavior_quote
        headings = {relative_heading(vehicle, other) for other in state.vehicles.values() if other is not vehicle}
        oncoming = "opposite_direction" in headings or (headings <= {None} and stated_oncoming and re.search(
            r"\boncoming\b|\bopposite direction\b", state.pre_crash + " " + state.crash_sentence, re.I))
        if vehicle.behavior == "turn_left" and oncoming and not (arrow or ran_red):
            oracle.add("CVC_21801", role,
                       f"{label} turned left across the path of oncoming traffic.", quote)
        if from_driveway == label:
            oracle.add("CVC_21804", role, f"{label} left a driveway into the path of traffic.", quote)
            continue
        crossing = state.uses("rules_oracle.angle_contact_is_crossing") and _crossing_contact(state, label)
        if not (headings & {"from_left", "from_right"} or crossing):
            continue
        all_way = state.stop_controlled >= set(state.vehicles) and len(state.vehicles) > 1
        if "stop_sign" in devices and label in state.stop_controlled and not all_way:
            if label in ran_stop:
                oracle.add("CVC_22450", role, f"{label} did not stop at its stop sign.",
                           around(text, ran_stop[label]))
            elif vehicle.behavior not in STANDING:  # stopped, or the stop is not stated, then entered
                oracle.add("CVC_21802", role,
                           f"{label} left its stop-controlled approach into the path of cross traffic.", quote)
        elif "yield_sign" in devices and label in state.yield_controlled:
            oracle.add("CVC_21803", role, f"{label} did not yield at its yield sign to cross traffic.",
                       quote)
        elif (not devices or all_way) and from_driveway is None and (
                failed_to_yield == label if failed_to_yield else "from_right" in headings):
            # uncontrolled (or all-way stop) junction: the one the report says failed to yield, else the one
            # with the other on its right
            oracle.add("CVC_21800", role,
                       f"{label} entered the junction without yielding to the vehicle with priority.", quote)


def _crossing_contact(state: RulesState, label: str) -> bool:
    """Whether the vehicle takes part in an angle contact (directions unknown: the contact shows the crossing)."""
    return any(c.class_word in (None, "angle") and c.areas and "front" in c.areas.values() and
               set(c.areas.values()) & {"left", "right"} and label in (c.striking.label, c.struck.label)
               for c in state.contacts)


# manoeuvres made under way: a vehicle stopped at a sign that then turned or changed lanes was moving when struck
_MOVING = ("turn_left", "turn_right", "u_turn", "change_lane_left", "change_lane_right", "overtake")


def _sequence_oracle(state: RulesState, oracle: _Oracle) -> None:
    """Rear-end contacts the striker drove into (dsl.md convention 9): CVC_21703 on a moving vehicle ahead,
    CVC_22350 on a stopped one. A contact the striker was pushed into, or made after it was itself struck,
    is an outcome, not a choice."""
    text = state.t.text
    struck_before: set[str] = set()
    for contact in state.contacts:
        striker = state.vehicles[contact.striking.label]
        struck = state.vehicles[contact.struck.label]
        # striking a vehicle ahead: its rear is hit (the striker's front or a glancing front side), or any part of
        # a vehicle stopped in the striker's path (stopped at an angle across the lane)
        rear_end = contact.areas.get("striking") != "rear" and contact.areas.get("struck") == "rear"
        moving = struck.behavior in _MOVING and state.uses("rules_oracle.a_turning_vehicle_is_moving")
        stopped = struck.behavior in STANDING or (not moving and bool(re.search(
            rf"\b{struck.label}\b[^.]{{0,60}}\b(?:was|had)\s+(?:\w+\s+)?stopped|stopped {struck.label}\b", text, re.I)))
        in_path = stopped and relative_heading(striker, struck) in (None, "same_direction")
        free = not contact.pushed and striker.label not in struck_before
        if (rear_end or in_path) and free and striker.behavior not in ("leave_road", "lose_control", "static"):
            if stopped:
                oracle.add("CVC_22350", striker.role,
                           f"{striker.label} struck the stopped {struck.label} ahead: too fast for the traffic "
                           f"ahead.", contact.quote)
            else:
                oracle.add("CVC_21703", striker.role,
                           f"{striker.label} struck the moving {struck.label} from behind.", contact.quote)
        struck_before.add(struck.label)


_NO_LABEL = r"(?:(?!\bV[1-9]\b)[^.]){0,100}?"  # words that name no other vehicle
_STRIKE = r"(?:struck|strikes?|striking|impacted|rear-ended|hit|contacted)"
_REAR = (r"(?:the\s+)?(?:rear|back)(?:\s+(?:plane|corner|end|bumper))?\s+of\s+"
         r"(?:(?:a|an|the)\s+[^.()]{0,60}?\(\s*)?(V[1-9])")  # "the rear of V2", "the rear of a parked Corolla (V2)"


def _rear_end_by_phrase(state: RulesState, oracle: _Oracle) -> None:
    """The first round's rear-end codes, used when `rules_oracle.sequence_rear_end` (which replaced them) is
    switched off: a vehicle striking the rear of a moving vehicle -> CVC_21703, of a stopped one -> CVC_22350;
    one pushed into it ("caused V1 to strike") chose nothing."""
    text = state.t.text
    for label, vehicle in state.vehicles.items():
        if vehicle.behavior in ("leave_road", "lose_control", "static"):
            continue
        striker = rf"(?:(?:front|side|corner)(?:\s+plane)?\s+of\s+{label}|\b{label})\b"
        for match in re.finditer(rf"{striker}{_NO_LABEL}{_STRIKE}\s+{_REAR}", text, re.I):
            head = text[max(0, match.start() - 40):match.start()]
            if re.search(r"\b(?:caus\w+|push\w*|forc\w+|redirect\w*|propell\w+)\s+(?:\w+\s+)?$", head, re.I):
                continue
            struck = state.vehicles.get(match.group(1))
            if struck is None or struck.label == label:
                continue
            if struck.behavior in STANDING or re.search(
                    rf"{struck.label}\b[^.]{{0,60}}\bstopped|stopped {struck.label}", text, re.I):
                oracle.add("CVC_22350", vehicle.role,
                           f"{label} struck the stopped {struck.label} from behind: too fast for the traffic ahead.",
                           around(text, match))
            else:
                oracle.add("CVC_21703", vehicle.role,
                           f"{label} struck the moving {struck.label} from behind.", around(text, match))
            break
