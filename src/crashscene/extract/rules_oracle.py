"""Rules extractor: the oracle, the California Vehicle Code violations the pre-crash sequence entails
(dsl.md convention 9), each attributed to its actor.
"""
from __future__ import annotations

import re

from crashscene.extract.narrative import around, clip, label_at
from crashscene.extract.rules_road import driveway_vehicle
from crashscene.extract.rules_state import RulesState, relative_heading


class _Oracle:
    """The entries found so far; one per (code, actor), each with its quote in the evidence."""

    def __init__(self, state: RulesState):
        self.state = state
        self.entries: list[dict] = []

    def add(self, code: str, violation: str, role: str, description: str, quote: str | None = None) -> None:
        if any(e["code"] == code and e["actor"] == role for e in self.entries):
            return
        self.entries.append({"code": code, "violation": violation, "actor": role,
                             "description": clip(description, 300)})
        if quote:
            self.state.note(f"oracle[{len(self.entries) - 1}]", quote)


def decide_oracle(state: RulesState, road: dict) -> list[dict]:
    """Every monitored violation the described pre-crash sequence entails, plus CVC_21804 for driveway exits;
    `[]` when the report states no cause."""
    oracle = _Oracle(state)
    _manoeuvre_oracle(state, road, oracle)
    _junction_oracle(state, road, oracle)
    _rear_end_oracle(state, oracle)
    return oracle.entries


def _manoeuvre_oracle(state: RulesState, road: dict, oracle: _Oracle) -> None:
    """Codes that follow from a vehicle's own manoeuvre or stated speed, wherever it happens."""
    text = state.t.text
    for label, vehicle in state.vehicles.items():
        role, behavior, quote = vehicle.role, vehicle.behavior, vehicle.behavior_quote
        too_fast = re.search(rf"\b{label}\b[^.]{{0,80}}(?:too fast for|excessive speed|unsafe speed|speed too great|"
                             rf"high rate of speed)", text, re.I)
        if behavior == "lose_control" or too_fast:
            oracle.add("CVC_22350", "unsafe_speed", role,
                       f"{label} lost control or was driven too fast for the conditions.", quote)
        crossed = behavior in ("cross_centerline", "overtake") or (
            behavior == "lose_control" and "cross_centerline" in vehicle.flags)
        if crossed:
            oracle.add("CVC_21650", "wrong_side", role, f"{label} entered the opposing lanes of the roadway.", quote)
            if road["road_marker"] == "double_solid_line":
                oracle.add("CVC_21460", "double_line_crossing", role, f"{label} crossed the double solid centre line.",
                           quote)
        # a vehicle that lost control or crossed into the lane changer's path is the one at fault
        other_at_fault = any(v.behavior in ("lose_control", "cross_centerline", "leave_road")
                             for v in state.vehicles.values() if v is not vehicle)
        if behavior.startswith("change_lane") and not other_at_fault:
            oracle.add("CVC_22107", "unsafe_lane_change", role,
                       f"{label} changed lanes into the path of another vehicle.", quote)
        speeding = re.search(rf"\b{label}\b[^.]{{0,80}}(?:speeding|exceed(?:ed|ing) the (?:posted )?speed limit|"
                             rf"above the (?:posted )?speed limit)", text, re.I)
        if speeding:
            oracle.add("CVC_22349", "speed_limit", role, f"{label} exceeded the posted speed limit.",
                       around(text, speeding))
        red = re.search(rf"\b{label}\b[^.]{{0,100}}(?:red (?:light|signal|indication)|against (?:the|a) red|"
                        rf"ran the red|disregard\w* the (?:traffic )?(?:signal|light))", text, re.I)
        if red:
            oracle.add("CVC_21453", "red_light", role, f"{label} entered the intersection against a red signal.",
                       around(text, red))


def _junction_oracle(state: RulesState, road: dict, oracle: _Oracle) -> None:
    """Right-of-way codes at a junction: left turns, stop and yield signs, uncontrolled junctions, driveways."""
    if road["road_type"] not in ("intersection", "t_intersection"):
        return
    text = state.t.text
    devices = set(road["traffic_signs"]) - {"speed_limit_sign"}
    from_driveway = driveway_vehicle(state)
    yield_phrase = re.search(r"fail(?:ed|ing|s)? to yield|did not yield", state.t.text, re.I)
    failed_to_yield = label_at(state.t.text, yield_phrase.start()) if yield_phrase else None
    for label, vehicle in state.vehicles.items():
        role, quote = vehicle.role, vehicle.behavior_quote
        headings = {relative_heading(vehicle, other) for other in state.vehicles.values() if other is not vehicle}
        if vehicle.behavior == "turn_left" and "opposite_direction" in headings and not \
                re.search(r"(?:green|protected) (?:left[- ]turn )?arrow", text, re.I):
            oracle.add("CVC_21801", "left_turn_yield", role,
                       f"{label} turned left across the path of oncoming traffic.", quote)
        if from_driveway == label:
            oracle.add("CVC_21804", "driveway_yield", role, f"{label} left a driveway into the path of traffic.", quote)
            continue
        if not headings & {"from_left", "from_right"}:
            continue
        ran_stop = re.search(rf"\b{label}\b[^.]{{0,80}}(?:fail(?:ed|ing) to stop|did not stop|ran the stop|"
                             rf"without stopping|disregarded the stop|rolled through the stop)", text, re.I)
        if "stop_sign" in devices and label in _controlled(state, state.stop_controlled):
            if ran_stop:
                oracle.add("CVC_22450", "stop_sign", role, f"{label} did not stop at its stop sign.",
                           around(text, ran_stop))
            else:  # stopped, or the stop is not stated, then entered into cross traffic
                oracle.add("CVC_21802", "stop_sign_yield", role,
                           f"{label} left its stop-controlled approach into the path of cross traffic.", quote)
        elif "yield_sign" in devices and label in _controlled(state, state.yield_controlled):
            oracle.add("CVC_21803", "yield_sign", role, f"{label} did not yield at its yield sign to cross traffic.",
                       quote)
        elif not devices and from_driveway is None and (
                failed_to_yield == label if failed_to_yield else "from_right" in headings):
            # uncontrolled junction: the one the report says failed to yield, else the one with the other on its right
            oracle.add("CVC_21800", "intersection_right_of_way", role,
                       f"{label} entered the uncontrolled intersection without yielding to the vehicle on its right.",
                       quote)


def _controlled(state: RulesState, named: set[str]) -> set[str]:
    """The approaches a sign controls (rules_road attributes every sign it reports)."""
    return named


_NO_LABEL = r"(?:(?!\bV[1-9]\b)[^.]){0,100}?"  # words that name no other vehicle
_STRIKE = r"(?:struck|strikes?|striking|impacted|rear-ended|hit|contacted)"
_REAR = (r"(?:the\s+)?(?:rear|back)(?:\s+(?:plane|corner|end|bumper))?\s+of\s+"
         r"(?:(?:a|an|the)\s+[^.()]{0,60}?\(\s*)?(V[1-9])")  # "the rear of V2", "the rear of a parked Corolla (V2)"


def _rear_end_oracle(state: RulesState, oracle: _Oracle) -> None:
    """Striking the back of a moving vehicle -> CVC_21703, of a stopped one -> CVC_22350 (convention 9).

    Only an impact the striker drives into counts: one it is pushed into ("caused V1 to strike") is an outcome.
    """
    text = state.t.text
    for label, vehicle in state.vehicles.items():
        if vehicle.behavior in ("leave_road", "lose_control", "static"):
            continue  # off the road or out of control: not a following-distance or speed-in-traffic case
        striker = rf"(?:(?:front|side|corner)(?:\s+plane)?\s+of\s+{label}|\b{label})\b"
        for match in re.finditer(rf"{striker}{_NO_LABEL}{_STRIKE}\s+{_REAR}", text, re.I):
            head = text[max(0, match.start() - 40):match.start()]
            if re.search(r"\b(?:caus\w+|push\w*|forc\w+|redirect\w*|propell\w+)\s+(?:\w+\s+)?$", head, re.I):
                continue
            struck_label = match.group(1)
            struck = state.vehicles.get(struck_label)
            if struck is None or struck_label == label:
                continue
            stopped = struck.behavior in ("stop", "static") or re.search(
                rf"{struck_label}\b[^.]{{0,60}}\bstopped|stopped {struck_label}", text, re.I)
            if stopped:
                oracle.add("CVC_22350", "unsafe_speed", vehicle.role,
                           f"{label} struck the stopped {struck_label} from behind: too fast for the traffic ahead.",
                           around(text, match))
            else:
                oracle.add("CVC_21703", "following_too_closely", vehicle.role,
                           f"{label} struck the moving {struck_label} from behind.", around(text, match))
            break
