"""The validation pass: ask until valid, review every field against the report, revise.

Two loops, both bounded:

- `ask_until_valid` sends the conversation, converts the reply to a `Scenario`
  and runs `crashscene.dsl.validate`; a reply that does not fit the schema or
  fails validation is fed back to the model with the exact diagnostics, at most
  `max_reasks` times, then the case fails with an `LlmOutputError`.
- `review` checks a valid draft field by field against the report text and the
  sketch facts (evidence quotes that are not in the report, a weather or time
  of day the report never mentions, a speed limit that differs from the stated
  one, a lane count that contradicts the sketch, a behaviour with no support in
  the text, an oracle that does not follow convention 9 from the decided
  behaviours, devices and contacts, a crash sequence that differs from the
  report's impact sentences as the rules backend reads them); `revise` sends the
  draft and the findings back once for a corrected scenario, which must again
  pass validation. A revision is kept only when it leaves no more findings than
  the draft; findings that remain become warnings of the case.

The review is deterministic (regular expressions over the narrative), so the
same reply always gets the same findings.
"""
from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from crashscene.dsl import DslError, Scenario, validate
from crashscene.dsl.errors import Severity
from crashscene.dsl.model import OracleEntry
from crashscene.dsl.tokens import Behavior, Heading, RoadMarker, RoadType, Sign, TimeOfDay, Weather
from crashscene.dsl.validate import check
from crashscene.extract.errors import ExtractError
from crashscene.extract.llm_schema import from_scenario, to_scenario
from crashscene.extract.openai_backend import BackendError, ChatBackend, Usage
from crashscene.extract.rules_positions import KEEPS_ITS_LANE, order_along_one_lane
from crashscene.units import KMH_PER_MPH

DEFAULT_MAX_REASKS = 2


class LlmOutputError(ExtractError):
    """The model gave no valid scenario within the re-ask budget."""


@dataclass(frozen=True)
class Finding:
    """One reviewer remark: the field path and what is wrong with it."""

    path: str
    message: str
    revise: bool = True  # False: a note for the warnings, not worth a model call on its own

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"


# ---------------------------------------------------------------- re-ask loop


def ask_until_valid(backend: ChatBackend, messages: list[dict[str, Any]], usage: Usage,
                    scenario_id: str | None = None, max_reasks: int = DEFAULT_MAX_REASKS,
                    source: str | None = None) -> Scenario:
    """A scenario that passes `validate`, re-asking with the diagnostics at most `max_reasks` times."""
    conversation = list(messages)
    problem = ""
    for _ in range(max_reasks + 1):
        completion = backend.complete(conversation)
        usage.add(completion.usage)
        if completion.parsed is not None:
            try:
                scenario = to_scenario(completion.parsed, scenario_id)
                validate(scenario)
                return scenario
            except DslError as exc:
                errors = [d for d in exc.diagnostics if d.severity == Severity.ERROR] or exc.diagnostics
                problem = "\n".join(f"- {_plain(d)}" for d in errors)
        else:
            problem = f"- {completion.invalid}"
        conversation += [
            {"role": "assistant", "content": completion.content or "(no JSON reply)"},
            {"role": "user", "content": "That reply is not a valid scenario:\n" + problem +
             "\nFix exactly these problems and return the complete corrected scenario."},
        ]
    raise LlmOutputError(f"{backend.name} backend (model {backend.model!r}) gave no valid scenario in "
                         f"{max_reasks + 1} replies; last problems: {problem.replace(chr(10), ' ')}", source)


def _plain(diagnostic: Any) -> str:
    """A diagnostic without the file prefix (the model has no file)."""
    text = diagnostic.message
    if diagnostic.path:
        text = f"{diagnostic.path}: {text}"
    if diagnostic.value is not None:
        text += f" (got {diagnostic.value!r})"
    if diagnostic.allowed:
        text += f"; allowed: {', '.join(map(str, diagnostic.allowed))}"
    return text


# ---------------------------------------------------------------- review


_WEATHER_WORDS = {
    Weather.CLEAR: r"\bclear\b|no adverse|sunny|\bfair\b",
    Weather.CLOUDY: r"cloud",
    Weather.OVERCAST: r"overcast",
    Weather.RAINY: r"\brain|drizzl|shower",
    Weather.SNOWY: r"\bsnow|sleet",
    Weather.FOGGY: r"\bfog|\bmist|haz[ey]",
    Weather.WINDY: r"\bwind",
}
_TIME_WORDS = {
    TimeOfDay.DAYTIME: r"daylight|\bday\b|daytime|morning|afternoon|mid-?day|noon",
    TimeOfDay.NIGHTTIME: r"\bdark|night|midnight|pre-?dawn|evening",
    TimeOfDay.DAWN: r"\bdawn",
    TimeOfDay.DUSK: r"\bdusk|twilight",
}
_BEHAVIOR_WORDS = {
    Behavior.CROSS_CENTERLINE: r"cent(er|re) ?line|left of cent|wrong (side|way|direction)|opposing|oncoming|"
                               r"(enter\w*|into|across) the (north|south|east|west)bound|head-on|yellow|"
                               r"into the path of|left side of the road",
    Behavior.TURN_LEFT: r"left turn|turn(ed|ing)? left|turn to the left|left-turn",
    Behavior.TURN_RIGHT: r"right turn|turn(ed|ing)? right|turn to the right|right-turn",
    Behavior.U_TURN: r"u-?turn",
    Behavior.STATIC: r"park|stationary|disabled|non-?occupied|unoccupied|stopped",
    Behavior.LOSE_CONTROL: r"lost control|loss of control|lose control|yaw|rotat|skid|spun|spin|fishtail",
    Behavior.LEAVE_ROAD: r"off the (road|roadway)|depart|exit(ed|ing)? the (road|roadway|travel lane)|ran off|"
                         r"shoulder|edge|embankment|ditch|left the road",
    Behavior.OVERTAKE: r"pass|overtak",
    Behavior.STOP: r"stop|queue|wait",
    Behavior.DECELERATE: r"slow|brak|decelerat|congest",
}
_NUMBER_WORDS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8}


def review(scenario: Scenario, narrative: str, facts: Sequence[str] = ()) -> list[Finding]:
    """Deterministic findings for a valid scenario, field by field; [] when nothing is suspicious."""
    text = narrative.lower()
    sketch = "\n".join(facts).lower()
    found: list[Finding] = []
    found += _evidence_findings(scenario, text)
    found += _environment_findings(scenario, text, sketch)
    found += _road_findings(scenario, text, sketch)
    found += _actor_findings(scenario, text, sketch)
    reading = _rules_reading(narrative)
    found += _oracle_findings(scenario)
    found += _sequence_findings(scenario)
    found += _lane_order_findings(scenario)
    found += _junction_findings(scenario)
    found += _stated_cause_findings(scenario, reading)
    found += _collision_findings(scenario, reading)
    found += [Finding(d.path, d.message) for d in check(scenario) if d.severity == Severity.WARNING
              and "evidence" not in d.path]
    return found


def _evidence_findings(s: Scenario, text: str) -> list[Finding]:
    known = _shingles(_squash(text))
    found = []
    for path, quote in s.evidence.items():
        head = re.split(r"\(?sketch\b", quote, maxsplit=1, flags=re.IGNORECASE)[0]  # the rest is a sketch note
        shingles = _shingles(_squash(head))
        if len(shingles) >= 4 and len(shingles & known) < 0.6 * len(shingles):
            found.append(Finding(f"evidence.{path}", f"the quote is not in the report: {head.strip()[:100]!r}; "
                                 "quote the report's exact words or a sketch fact", revise=False))
    return found


def _shingles(words: str, size: int = 3) -> set[tuple[str, ...]]:
    tokens = words.split()
    return {tuple(tokens[i:i + size]) for i in range(len(tokens) - size + 1)}


def _environment_findings(s: Scenario, text: str, sketch: str) -> list[Finding]:
    found = []
    env = s.environment
    both = text + "\n" + sketch
    if env.weather != Weather.NOT_MENTIONED and not re.search(_WEATHER_WORDS[env.weather], both):
        found.append(Finding("environment.weather", f"{env.weather.value} is not mentioned in the report; use the "
                             "stated weather, or not_mentioned"))
    if env.weather == Weather.NOT_MENTIONED:
        stated = [w.value for w, pattern in _WEATHER_WORDS.items() if re.search(pattern, text)]
        if stated:
            found.append(Finding("environment.weather", f"not_mentioned, but the report mentions {stated[0]}"))
    if env.time_of_day != TimeOfDay.NOT_MENTIONED and not re.search(_TIME_WORDS[env.time_of_day], both):
        found.append(Finding("environment.time_of_day", f"{env.time_of_day.value} is not mentioned in the report"))
    if env.time_of_day == TimeOfDay.NOT_MENTIONED:
        stated = [t.value for t, pattern in _TIME_WORDS.items() if re.search(pattern, text)]
        if stated:
            found.append(Finding("environment.time_of_day", f"not_mentioned, but the report mentions {stated[0]}"))
    return found


def stated_speed_limits(text: str) -> list[int]:
    """Posted limits [mph] stated in text: '55 mph', '89 km/h (55 mph)', '72 kmph'; near 'speed limit' words."""
    limits = []
    for match in re.finditer(r"(speed limit|posted)[^.]{0,60}", text.lower()):
        window = match.group(0)
        mph = re.search(r"(\d{2,3})\s*(mph|miles per hour)", window)
        kmh = re.search(r"(\d{2,3})\s*(km/h|km/hr|kmph|kph|km per hour)", window)
        if mph:
            limits.append(int(mph.group(1)))
        elif kmh:
            limits.append(int(5 * round(int(kmh.group(1)) / KMH_PER_MPH / 5)))
    return limits


def _road_findings(s: Scenario, text: str, sketch: str) -> list[Finding]:
    found = []
    road = s.road_network
    text_limits, sketch_limits = stated_speed_limits(text), stated_speed_limits(sketch)
    stated = text_limits or sketch_limits
    if road.speed_limit_mph is not None and stated and road.speed_limit_mph not in stated:
        found.append(Finding("road_network.speed_limit_mph", f"{road.speed_limit_mph} mph, but the "
                             f"{'report' if text_limits else 'sketch'} states {stated[0]} mph"))
    if road.speed_limit_mph is None and stated:
        found.append(Finding("road_network.speed_limit_mph", f"null, but the {'report' if text_limits else 'sketch'} "
                             f"states a posted limit of {stated[0]} mph"))
    if road.speed_limit_mph is not None and not stated and not re.search(r"speed limit|posted", text + sketch):
        found.append(Finding("road_network.speed_limit_mph", "no posted limit is stated in the report or sketch "
                             "facts; use null unless the sketch shows one", revise=False))
    lane_counts = _lane_counts(text)
    # divided roads count one carriageway, and turn lanes are never counted: the stated total may differ
    divided = re.search(r"divided|median|barrier|one-way|turn lane|turning lane", text)
    # an odd total on a two-way road ("three-lane, two-way") usually includes a centre turn lane
    plausible = lane_counts | {n - 1 for n in lane_counts if n % 2 and road.number_of_ways == 2}
    if lane_counts and not divided and road.number_of_lanes not in plausible:
        found.append(Finding("road_network.number_of_lanes", f"{road.number_of_lanes}, but the report speaks of "
                             f"{'/'.join(str(n) for n in sorted(lane_counts))}-lane roads; count V1's through lanes"))
    sketch_lanes = [int(m.group(1)) for m in re.finditer(r"(\d+) (?:travel |through )?lanes?\b", sketch)]
    if sketch_lanes and not lane_counts and road.number_of_lanes not in sketch_lanes:
        found.append(Finding("road_network.number_of_lanes", f"{road.number_of_lanes}, but the sketch shows "
                             f"{sketch_lanes[0]} lanes"))
    if road.road_marker == RoadMarker.DOUBLE_SOLID_LINE and not re.search(r"double|two (parallel )?solid",
                                                                          text + sketch):
        found.append(Finding("road_network.road_marker", "double_solid_line, but neither the report nor the sketch "
                             "mentions a double line; use not_mentioned unless it is stated or drawn", revise=False))
    junction = re.search(r"intersection|junction|driveway|\bleg\b|-leg|access|ramp|cross ?road|t-type", text)
    if road.road_type in (RoadType.INTERSECTION, RoadType.T_INTERSECTION) and not junction:
        found.append(Finding("road_network.road_type", f"{road.road_type.value}, but the report mentions no junction"))
    if road.road_type == RoadType.CURVE and not re.search(r"curv|bend", text + sketch):
        found.append(Finding("road_network.road_type", "curve, but the report mentions no curve"))
    return found


def _actor_findings(s: Scenario, text: str, sketch: str) -> list[Finding]:
    found = []
    for name, actor in s.actors.items():
        pattern = _BEHAVIOR_WORDS.get(actor.behavior)
        if pattern and not re.search(pattern, text):
            found.append(Finding(f"actors.{name}.behavior", f"{actor.behavior.value} has no support in the report"))
    labels = {int(m.group(1)) for m in re.finditer(r"\bv(?:ehicle)? ?#?([1-9])\b", text + "\n" + sketch)}
    if labels and len(s.actors) > max(labels) + 1:
        found.append(Finding("actors", f"{len(s.actors)} actors, but the report and sketch label only "
                             f"{max(labels)} vehicles"))
    return found


def _oracle_findings(s: Scenario) -> list[Finding]:
    found = []
    codes = {(entry.code, entry.actor) for entry in s.oracle}
    double = s.road_network.road_marker == RoadMarker.DOUBLE_SOLID_LINE
    for name, actor in s.actors.items():
        if actor.behavior == Behavior.CROSS_CENTERLINE and ("CVC_21650", name) not in codes:
            found.append(Finding("oracle", f"{name} crosses the centre line: CVC_21650 wrong_side is missing"))
        if actor.behavior == Behavior.LOSE_CONTROL and ("CVC_22350", name) not in codes:
            found.append(Finding("oracle", f"{name} loses control: CVC_22350 unsafe_speed is missing"))
        if double and ("CVC_21650", name) in codes and ("CVC_21460", name) not in codes:
            found.append(Finding("oracle", f"{name} enters the opposing lanes over a double solid line: "
                                 "CVC_21460 double_line_crossing is missing"))
    for index, entry in enumerate(s.oracle):
        problem = oracle_conflict(s, entry)
        if problem:
            found.append(Finding(f"oracle[{index}].code", problem))
    return found


def _sequence_findings(s: Scenario) -> list[Finding]:
    """Convention 9 read from the draft's own crash sequence and devices: rear-end contacts the striker drove
    into (CVC_21703 on a moving vehicle, CVC_22350 on a stopped one), a lane change into another vehicle
    (CVC_22107), and a stop- or yield-controlled actor in an angle contact (CVC_21802/CVC_22450, CVC_21803)."""
    found = []
    codes = {(entry.code, entry.actor) for entry in s.oracle}
    struck_before: set[str] = set()
    in_contact: set[str] = set()
    for index, contact in enumerate(s.collisions or []):
        striker, struck = contact.striking, contact.struck
        in_contact |= {striker, struck}
        other = s.actors.get(struck)
        rear = contact.struck_area.value == "rear" and contact.striking_area.value != "rear"
        free = striker not in struck_before and s.actors.get(striker) is not None and \
            s.actors[striker].behavior not in (Behavior.LEAVE_ROAD, Behavior.LOSE_CONTROL, Behavior.STATIC)
        stopped = other is not None and other.behavior in (Behavior.STOP, Behavior.STATIC)
        headings = {_heading(s, striker), _heading(s, struck)}
        in_path = stopped and (None in headings or len(headings) == 1)  # a stopped vehicle in the striker's lane
        if (rear or in_path) and free and other is not None:
            code, token = ("CVC_22350", "unsafe_speed") if stopped else ("CVC_21703", "following_too_closely")
            if (code, striker) not in codes:
                state = "stopped" if stopped else "moving"
                found.append(Finding("oracle", f"collisions[{index}]: {striker} drove into the {state} {struck} ahead "
                                     f": {code} {token} for {striker} is missing (convention 9)"))
        if contact.class_.value == "angle":
            for name in (striker, struck):
                reference = s.actors[name].position.reference if name in s.actors else None
                if reference == "stop_sign" and not {("CVC_21802", name), ("CVC_22450", name)} & codes:
                    found.append(Finding("oracle", f"{name} comes from a stop-controlled approach into an angle "
                                         "contact: CVC_21802 stop_sign_yield (or CVC_22450 stop_sign when the "
                                         "report says it did not stop) is missing"))
                if reference == "yield_sign" and ("CVC_21803", name) not in codes:
                    found.append(Finding("oracle", f"{name} comes from a yield-controlled approach into an angle "
                                         "contact: CVC_21803 yield_sign is missing"))
        struck_before.add(struck)
    for name, actor in s.actors.items():
        changing = actor.behavior in (Behavior.CHANGE_LANE_LEFT, Behavior.CHANGE_LANE_RIGHT)
        if changing and name in in_contact and ("CVC_22107", name) not in codes and not any(
                other.behavior in (Behavior.LOSE_CONTROL, Behavior.CROSS_CENTERLINE, Behavior.LEAVE_ROAD)
                for other_name, other in s.actors.items() if other_name != name):
            found.append(Finding("oracle", f"{name} changes lanes into another vehicle: CVC_22107 "
                                 "unsafe_lane_change is missing"))
    return found


def _lane_order_findings(s: Scenario) -> list[Finding]:
    """Places along the ego's lane that contradict the draft's own crash sequence: a lane-keeping striker meets
    the vehicles it rear-ends in the order of their positions (rules_positions.order_along_one_lane). Actors placed
    beside the ego (left, right) or crossing are not in its lane and are not read."""
    in_lane = {name for name, actor in s.actors.items() if name == "ego" or (
        actor.position.reference == "ego" and actor.position.heading == Heading.SAME_DIRECTION and
        actor.position.relation.value in ("front", "behind"))}
    chain = [(c.striking, c.struck) for c in s.collisions or [] if c.class_.value == "rear_end" and
             c.struck_area.value == "rear" and {c.striking, c.struck} <= in_lane and
             all(s.actors[n].behavior.value in KEEPS_ITS_LANE for n in (c.striking, c.struck))]
    closure = order_along_one_lane(chain)
    if not closure:
        return []  # no rear-end contact in the ego's lane, or contacts that contradict each other
    found = []
    contacts = ", ".join(f"{a}->{b}" for a, b in chain)
    for name in sorted(in_lane - {"ego"}):
        relation = s.actors[name].position.relation.value
        entailed = "behind" if (name, "ego") in closure else "front" if ("ego", name) in closure else None
        if entailed and entailed != relation:
            found.append(Finding(f"actors.{name}.position.relation",
                                 f"{name} is placed {relation} the ego, but the crash sequence's rear-end contacts "
                                 f"({contacts}) place it {entailed}: a striker keeping its lane meets the vehicles "
                                 "in it in the order of their positions"))
    return found


def _heading(s: Scenario, name: str) -> Heading | None:
    """An actor's travel direction relative to the ego (the ego's own is same_direction)."""
    if name == "ego":
        return Heading.SAME_DIRECTION
    actor = s.actors.get(name)
    return actor.position.heading if actor is not None else None


def _rules_reading(narrative: str) -> Scenario | None:
    """The narrative as the rules backend reads it (no sketch), or None when it cannot."""
    from crashscene.extract.case_input import Report
    from crashscene.extract.rules import extract_rules

    try:
        return extract_rules(Report(case_id="review", narrative=narrative, source=Path("narrative")), [])
    except ExtractError:
        return None


# headings as angles from the ego's direction of travel [deg]: from_left travels towards the ego's right
_HEADING_ANGLE = {Heading.SAME_DIRECTION: 0, Heading.FROM_RIGHT: 90, Heading.OPPOSITE_DIRECTION: 180,
                  Heading.FROM_LEFT: 270}
_DEVICES = {Sign.STOP_SIGN, Sign.YIELD_SIGN, Sign.TRAFFIC_LIGHT}


def _crossing_angle(s: Scenario, one: str, two: str) -> int | None:
    """The angle between two actors' directions of travel [deg, 0..180], None when a heading is unknown."""
    a, b = _heading(s, one), _heading(s, two)
    if a is None or b is None:
        return None
    delta = abs(_HEADING_ANGLE[a] - _HEADING_ANGLE[b]) % 360
    return min(delta, 360 - delta)


def _junction_findings(s: Scenario) -> list[Finding]:
    """Convention 9 at a junction and on the opposing lanes, from the draft's own manoeuvres, devices and contacts:
    an overtake enters the opposing lanes (CVC_21650); a left turn into an oncoming actor (CVC_21801, unless a red
    light was run: the turn had the arrow); an angle contact between crossing actors at a junction without devices
    (CVC_21800 for the actor without priority)."""
    found = []
    codes = {(entry.code, entry.actor) for entry in s.oracle}
    for name, actor in s.actors.items():
        if actor.behavior == Behavior.OVERTAKE and ("CVC_21650", name) not in codes:
            found.append(Finding("oracle", f"{name} overtakes through the opposing lanes into a contact: CVC_21650 "
                                 "wrong_side is missing (convention 9: entering the opposing lanes)"))
    junction = s.road_network.road_type in (RoadType.INTERSECTION, RoadType.T_INTERSECTION)
    ran_red = any(entry.code == "CVC_21453" for entry in s.oracle)
    signs = set(s.road_network.traffic_signs)
    for index, contact in enumerate(s.collisions or []):
        pair = (contact.striking, contact.struck)
        if not junction or any(name not in s.actors for name in pair):
            continue
        angle = _crossing_angle(s, *pair)
        for turner, other in (pair, pair[::-1]):
            if s.actors[turner].behavior == Behavior.TURN_LEFT and angle == 180 and not ran_red and \
                    ("CVC_21801", turner) not in codes:
                found.append(Finding("oracle", f"collisions[{index}]: {turner} turns left across the oncoming "
                                     f"{other}: CVC_21801 left_turn_yield is missing (convention 9)"))
        if contact.class_.value == "angle" and angle == 90 and not signs & _DEVICES and \
                not any(code in ("CVC_21800", "CVC_21804") and actor in pair for code, actor in codes):
            found.append(Finding("oracle", f"collisions[{index}]: {pair[0]} and {pair[1]} cross at a junction "
                                 "without devices: CVC_21800 intersection_right_of_way for the one without priority "
                                 "(the one the report says failed to yield, else the one with the other on its "
                                 "right) is missing (convention 9)"))
    return found


# codes the narrative's cause statements give (issue 11's list: "ran the red light", "failed to stop", "speeding")
_STATED_CODES = ("CVC_21453", "CVC_22450", "CVC_22349")


def _stated_cause_findings(s: Scenario, reading: Scenario | None) -> list[Finding]:
    """Convention 9 codes the report's cause statements give, as the rules backend reads them, that the draft lacks
    for the same actor (red light, no stop at a stop sign, stated speeding)."""
    if reading is None:
        return []
    codes = {(entry.code, entry.actor) for entry in s.oracle}
    found = []
    for index, entry in enumerate(reading.oracle):
        if entry.code in _STATED_CODES and (entry.code, entry.actor) not in codes and entry.actor in s.actors:
            quote = reading.evidence.get(f"oracle[{index}]", "")
            found.append(Finding("oracle", f"the report states {entry.violation} for {entry.actor}"
                                 + (f" ({quote!r})" if quote else "") + f": {entry.code} is missing (convention 9)"))
    return found


def _collision_findings(s: Scenario, reading: Scenario | None) -> list[Finding]:
    """The draft's crash sequence against the report's impact sentences, as the rules backend reads them."""
    if reading is None:
        return []
    expected = reading.collisions or []
    drafted = s.collisions or []
    if not expected and not drafted:
        return []

    def show(contact: Any) -> str:
        return (f"{contact.striking} {contact.striking_area.value} -> {contact.struck} {contact.struck_area.value} "
                f"({contact.class_.value})")

    found = []
    if len(expected) != len(drafted):
        found.append(Finding("collisions", f"{len(drafted)} contact(s), but the report's impact sentences describe "
                             f"{len(expected)}: " + ("; ".join(show(c) for c in expected) or "no contact between "
                                                    "two actors")))
        return found
    for index, (mine, theirs) in enumerate(zip(drafted, expected)):
        if (mine.striking, mine.struck, mine.class_) != (theirs.striking, theirs.struck, theirs.class_):
            quote = reading.evidence.get(f"collisions[{index}]", "")
            found.append(Finding(f"collisions[{index}]", f"{show(mine)}, but the report reads {show(theirs)}"
                                 + (f": {quote!r}" if quote else "")))
    return found


_BEHAVIOR_CODES = {"CVC_21801": {Behavior.TURN_LEFT, Behavior.U_TURN},
                   "CVC_22107": {Behavior.CHANGE_LANE_LEFT, Behavior.CHANGE_LANE_RIGHT}}
_SIGN_CODES = {"CVC_21453": Sign.TRAFFIC_LIGHT, "CVC_22450": Sign.STOP_SIGN, "CVC_21802": Sign.STOP_SIGN,
               "CVC_21803": Sign.YIELD_SIGN}
_JUNCTION_CODES = {"CVC_21800", "CVC_21801", "CVC_21802", "CVC_21803", "CVC_21453", "CVC_22450"}


def oracle_conflict(s: Scenario, entry: OracleEntry) -> str | None:
    """Why a monitored oracle entry cannot hold in this scenario (dsl.md 5.9), or None when it can."""
    actor = s.actors.get(entry.actor)
    if actor is None:
        return None  # the validator reports unknown actors
    road = s.road_network
    if entry.code == "CVC_21460" and road.road_marker != RoadMarker.DOUBLE_SOLID_LINE:
        return "CVC_21460 needs road_marker double_solid_line"
    if entry.code in _SIGN_CODES and _SIGN_CODES[entry.code] not in road.traffic_signs:
        return f"{entry.code} ({entry.violation}) needs a {_SIGN_CODES[entry.code].value} in traffic_signs"
    if entry.code in _JUNCTION_CODES and road.road_type not in (RoadType.INTERSECTION, RoadType.T_INTERSECTION):
        return f"{entry.code} ({entry.violation}) happens at a junction, but road_type is {road.road_type.value}"
    if entry.code in _BEHAVIOR_CODES and actor.behavior not in _BEHAVIOR_CODES[entry.code]:
        allowed = " or ".join(sorted(b.value for b in _BEHAVIOR_CODES[entry.code]))
        return f"{entry.code} ({entry.violation}) needs {entry.actor} to {allowed}, not {actor.behavior.value}"
    return None


def _lane_counts(text: str) -> set[int]:
    """Lane counts the narrative states: 'two-lane', '4-lane', 'one-lane'."""
    counts = set()
    for match in re.finditer(r"\b(\w+)[- ]lane\b", text):
        word = match.group(1)
        count = int(word) if word.isdigit() else _NUMBER_WORDS.get(word, 0)
        if 0 < count <= 16:
            counts.add(count)
    return counts


def prune_oracle(s: Scenario) -> tuple[Scenario, list[str]]:
    """Drop oracle entries that cannot hold in the scenario (see `oracle_conflict`); say which and why.

    The last step after revision: small models list every code they know, and an
    entry the monitor can never observe (a stop-sign code with no stop sign) would
    only make the scenario unreproducible.
    """
    kept, dropped, evidence = [], [], {}
    for index, entry in enumerate(s.oracle):
        problem = oracle_conflict(s, entry)
        if problem:
            dropped.append(f"oracle: dropped {entry.code} for {entry.actor}: {problem}")
            continue
        if f"oracle[{index}]" in s.evidence:
            evidence[f"oracle[{len(kept)}]"] = s.evidence[f"oracle[{index}]"]
        kept.append(entry)
    if not dropped:
        return s, []
    evidence.update({key: text for key, text in s.evidence.items() if not key.startswith("oracle[")})
    return s.model_copy(update={"oracle": kept, "evidence": evidence}), dropped


def _squash(text: str) -> str:
    return " ".join(re.sub(r"[^a-z0-9]+", " ", text.lower()).split())


# ---------------------------------------------------------------- revision


def revise(backend: ChatBackend, messages: list[dict[str, Any]], draft: Scenario, findings: list[Finding],
           narrative: str, facts: Sequence[str], usage: Usage, max_reasks: int = DEFAULT_MAX_REASKS,
           source: str | None = None) -> tuple[Scenario, list[Finding]]:
    """Send the draft and the findings back once; keep the revision only if it is valid and no worse."""
    if not any(finding.revise for finding in findings):
        return draft, findings
    draft_json = json.dumps(from_scenario(draft).model_dump(mode="json"), ensure_ascii=False, separators=(",", ":"))
    remarks = "\n".join(f"- {finding}" for finding in findings if finding.revise)
    conversation = list(messages) + [
        {"role": "assistant", "content": draft_json},
        {"role": "user", "content": "A reviewer checked every field of that scenario against the report, the "
         "sketch facts and the conventions, and found:\n" + remarks + "\nFor each remark, re-read the report: "
         "correct the field if the remark is right, keep it if the report supports it. Keep every other field. "
         "Return the complete scenario."},
    ]
    try:
        revised = ask_until_valid(backend, conversation, usage, draft.scenario_id, max_reasks, source)
    except (LlmOutputError, BackendError) as exc:  # the draft is valid: keep it, say why it was not revised
        return draft, findings + [Finding("revision", f"not revised: {exc}", revise=False)]
    remaining = review(revised, narrative, facts)
    if sum(f.revise for f in remaining) <= sum(f.revise for f in findings):
        return revised, remaining
    return draft, findings
