"""Rule-based extraction: NHTSA narrative language and sketch facts to a DSL scenario.

CIREN/NASS narratives are formulaic ("was traveling east in the eastbound lane
of a two-lane, two-way roadway", "It was daylight, the sky was cloudy",
"crossed the centerline", "the front of V2 struck the right side of V1"). This
module reads those patterns, deterministically, and applies the conventions of
dsl.md section 5 (actors V1=ego, V2=npc1...; positions from travel directions;
oracle codes per convention 9). Every decided field records the quote it came
from in `evidence`. It is the backend every user without an LLM gets, and the
fallback of the LLM pipeline.

The rules are general language patterns, never case lookups. Flow:
`_Text` normalises labels ("Vehicle one", "Vehicle #2" -> V1, V2) and splits
sentences; the environment, road network, actors and oracle are then decided
in that order, each step seeing the previous ones.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

from crashscene.dsl import Scenario, from_raw, validate
from crashscene.dsl.errors import DslError
from crashscene.extract.errors import RulesError
from crashscene.extract.report import Report
from crashscene.extract.sketch import SketchFact

KMH_PER_MPH = 1.609344
NUMBERS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9,
           "ten": 10, "single": 1, "1": 1, "2": 2, "3": 3, "4": 4, "5": 5, "6": 6, "7": 7, "8": 8, "9": 9}
_NUM = r"(one|two|three|four|five|six|seven|eight|nine|ten|single|\d)"
COMPASS = {"north": 0, "east": 90, "south": 180, "west": 270}  # [deg] clockwise from north
_DIR = r"(north|south|east|west)"


# ---------------------------------------------------------------- text handling


def _label_sub(match: re.Match) -> str:
    return f"V{NUMBERS[match.group(1).lower()]}"


@dataclass
class _Text:
    """The narrative with vehicle labels normalised, split into sentences."""

    raw: str
    text: str = ""
    sentences: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        text = self.raw.replace("\u2019", "'").replace("\u201c", '"').replace("\u201d", '"')
        text = re.sub(r"\bVehicles\s+((?:[1-9](?:,\s*|\s+and\s+|,\s+and\s+))+[1-9])\b",
                      lambda m: re.sub(r"([1-9])", r"V\1", m.group(1)), text)
        text = re.sub(r"\b(?:Vehicle|Veh\.?|Vehicle\s+number)\s*#?\s*(one|two|three|four|five|[1-9])\b",
                      _label_sub, text, flags=re.I)
        text = re.sub(r"\bV-?\s?([1-9])\b", r"V\1", text)
        text = re.sub(r"\bV([1-9])\s*\(\s*V\1\b[^)]*\)", r"V\1", text)  # "V1 (V1 - case vehicle)"
        text = re.sub(r"\s+", " ", text)
        self.text = text
        # split on sentence ends, not on abbreviations like "approx." followed by a number
        parts = re.split(r"(?<=[.!?])\s+(?=[A-Z0-9\"(])", text)
        self.sentences = [p.strip() for p in parts if p.strip()]

    def find(self, pattern: str, flags: int = re.I) -> re.Match | None:
        return re.search(pattern, self.text, flags)

    def sentence_with(self, pattern: str, flags: int = re.I) -> str | None:
        for sentence in self.sentences:
            if re.search(pattern, sentence, flags):
                return sentence
        return None


def _quote(text: str, limit: int = 220) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3].rstrip() + "..."


def _around(text: str, match: re.Match, width: int = 90) -> str:
    start = max(0, match.start() - width)
    end = min(len(text), match.end() + width)
    return _quote(("..." if start else "") + text[start:end] + ("..." if end < len(text) else ""))


# ---------------------------------------------------------------- the extraction state


@dataclass
class _Vehicle:
    label: str  # V1, V2, ...
    role: str  # ego, npc1, ...
    direction: str | None = None  # north|south|east|west
    lane_side: str | None = None  # left|right|middle lane of its direction
    lane_number: int | None = None  # NHTSA "number two lane", counted from the right edge
    type: str = "car"
    behavior: str = "go_forward"
    behavior_quote: str | None = None
    pre: str = ""  # the pre-crash text about this vehicle
    flags: set[str] = field(default_factory=set)


@dataclass
class _State:
    report: Report
    facts: list[SketchFact]
    t: _Text
    evidence: dict[str, str] = field(default_factory=dict)
    vehicles: dict[str, _Vehicle] = field(default_factory=dict)
    pre_crash: str = ""
    crash_sentence: str = ""
    between: str = ""  # after the first impact, up to the next one: a manoeuvre leading to the second impact
    junction: str | None = None  # intersection | t_intersection
    divided: bool = False
    signs: set[str] = field(default_factory=set)
    stop_controlled: set[str] = field(default_factory=set)  # labels whose approach has a stop sign
    yield_controlled: set[str] = field(default_factory=set)
    no_controls: bool = False
    marker: str = "not_mentioned"

    def fact_texts(self, prefix: str = "") -> list[str]:
        return [f.text for f in self.facts if f.text.startswith(prefix)]

    def note(self, path: str, quote: str) -> None:
        self.evidence.setdefault(path, _quote(quote))


def extract_rules(report: Report, facts: list[SketchFact] | None = None) -> Scenario:
    """Deterministic extraction of one report (and its sketch facts) into a validated `Scenario`."""
    state = _State(report=report, facts=list(facts or []), t=_Text(report.narrative))
    _find_vehicles(state)
    _split_pre_crash(state)
    environment = _environment(state)
    road = _road_network(state)
    _behaviors(state)
    actors = _actors(state, road)
    oracle = _oracle(state, road, actors)
    raw = {
        "scenario_id": f"CIREN-{report.case_id}",
        "summary": _summary(state, road, actors),
        "environment": environment,
        "road_network": road,
        "actors": actors,
        "oracle": oracle,
        "evidence": dict(sorted(state.evidence.items())),
    }
    try:
        scenario = from_raw(raw, source=f"rules extraction of {report.source}")
        validate(scenario)
        return scenario
    except DslError as exc:
        raise RulesError(f"rule-based extraction produced an invalid scenario:\n{exc}", report.source) from None


# ---------------------------------------------------------------- vehicles and the crash sequence


def _find_vehicles(state: _State) -> None:
    text = state.t.text
    labels = sorted({int(n) for n in re.findall(r"\bV([1-9])\b", text)})
    single = re.search(r"\bsingle[- ]vehicle\b|\bone[- ]vehicle\b", text, re.I)
    if single or not labels:
        labels = [1]
    if 1 not in labels:
        labels = [1, *labels]
    for index, number in enumerate(labels):
        label = f"V{number}"
        state.vehicles[label] = _Vehicle(label=label, role="ego" if index == 0 else f"npc{index}")
    for label, vehicle in state.vehicles.items():
        vehicle.direction, vehicle.lane_side = _direction_of(state, label)
        vehicle.type = _type_of(state, label)


def _subject_sentences(state: _State, label: str) -> list[str]:
    """Sentences (pre-crash first) whose grammatical subject is the vehicle."""
    out = []
    for sentence in state.t.sentences:
        subject = _subject(sentence)
        if subject == label:
            out.append(sentence)
    return out


_OBJECT_BEFORE = re.compile(r"(?:pass|passing|overtak\w*|struck|strike|striking|hit|avoid|avoiding|behind|following|"
                            r"follow|with|toward|towards|than|into|see|saw|approaching|and|of|front of|rear of|"
                            r"side of|by)\s+(?:the\s+)?$", re.I)


def _subject(sentence: str) -> str | None:
    """The first vehicle label in the sentence that is not an object ('struck V2', 'behind V1')."""
    for match in re.finditer(r"\bV([1-9])\b", sentence):
        before = sentence[max(0, match.start() - 25):match.start()]
        if re.search(r"driver\s+of\s+(?:the\s+)?$", before, re.I) or not _OBJECT_BEFORE.search(before):
            return f"V{match.group(1)}"
    return None


def _label_at(text: str, position: int) -> str | None:
    """The acting vehicle for a phrase at `position`: nearest preceding label that is not an object."""
    clause_start = max(text.rfind(". ", 0, position), text.rfind("; ", 0, position))
    adjacent = re.search(r"\bV([1-9])\s+(?:was\s+|were\s+|had\s+|is\s+)?$", text[max(0, position - 16):position])
    if adjacent:  # "did not see V1 stopped": the phrase describes the label right before it
        return f"V{adjacent.group(1)}"
    best = None
    for match in re.finditer(r"\bV([1-9])\b", text[:position]):
        if match.start() < clause_start:
            continue
        before = text[max(0, match.start() - 25):match.start()]
        if re.search(r"driver\s+of\s+(?:the\s+)?$", before, re.I) or not _OBJECT_BEFORE.search(before):
            best = f"V{match.group(1)}"
    return best


def _direction_of(state: _State, label: str) -> tuple[str | None, str | None]:
    for sentence in _subject_sentences(state, label):
        cut = re.split(r"\b(?:struck|strike|striking|impacted|collided)\b", sentence)[0]
        match = re.search(rf"(?:travel+ing|driven|heading|proceeding|going|traveled|travelled|was)\s+(?:in\s+(?:a|an|the)\s+)?"
                          rf"{_DIR}(?:bound|ward)?\b", cut, re.I)
        if not match:
            match = re.search(rf"\b{_DIR}bound\b|\bfacing\s+{_DIR}\b", cut, re.I)
        if match:
            lane = re.search(r"\b(left|right|middle|center|far[- ]left|far[- ]right|inboard|outboard)\b[^.]{0,30}?"
                             rf"{_DIR}bound\s+(?:travel\s+)?lane", cut, re.I)
            side = None
            if lane:
                side = "left" if "left" in lane.group(1).lower() or lane.group(1).lower() == "inboard" else \
                    "right" if "right" in lane.group(1).lower() or lane.group(1).lower() == "outboard" else "middle"
            state.note(f"actors.{state.vehicles[label].role}.position", sentence)
            number = re.search(rf"\bnumber\s+{_NUM}\b[^.]{{0,30}}?\blane", cut, re.I)
            if number:
                state.vehicles[label].lane_number = _count(number.group(1))
            return next(g for g in match.groups() if g).lower(), side
    return None, None


_TRUCK = re.compile(r"tractor|semi\b|semi-trailer|\bbus\b|school bus|motorcoach|box truck|dump truck|straight truck|"
                    r"delivery truck|garbage truck|cement|concrete mixer|tow truck|fire truck|flatbed|"
                    r"commercial (?:truck|vehicle)|heavy truck|single[- ]unit truck|\bGVWR\b", re.I)
_MOTORCYCLE = re.compile(r"motorcycle|motorbike|moped|scooter|\bHarley\b", re.I)


def _type_of(state: _State, label: str) -> str:
    texts = []
    text = state.t.text
    # "V2, a 2002 Ford F150 pickup truck was ...", "V2 - 2001 Volvo", "a 2013 Freightliner tractor/trailer (V2)"
    after = re.search(rf"\b{label}\b\s*(?:\([^)]*\))?\s*[,:(-]\s*(?:the\s+|a\s+|an\s+)?([^.;]*?)(?:\b(?:was|were|is|had|"
                      rf"driven|traveling|travelling)\b|[.;]|$)", text)
    before = re.search(rf"(?:\b(?:a|an|the)\s+|,\s*)([^.;()]{{3,80}}?)\s*\(\s*{label}\s*\)", text)
    for match in sorted((m for m in (after, before) if m), key=lambda m: m.start()):
        texts.append(match.group(1))
    texts += [t for t in state.fact_texts(f"vehicle {label}:")]
    for descriptor in texts:
        if _MOTORCYCLE.search(descriptor):
            return "motorcycle"
        if _TRUCK.search(descriptor):
            state.note(f"actors.{state.vehicles[label].role}.type", descriptor)
            return "truck"
    return "car"


_IMPACT = re.compile(r"\b(?:struck|strikes?|striking|impacted|collided|hit)\b", re.I)
_SUMMARY_SENTENCE = re.compile(r"\b(?:crash|collision|case|investigation)\s+(?:involves|involved|focused)|"
                               r"primarily involved|sustained (?:a )?(?:frontal|side|moderate|serious)", re.I)


def _split_pre_crash(state: _State) -> None:
    """Text before the first harmful event, without the summary lead and avoidance manoeuvres."""
    kept = []
    sentences = state.t.sentences
    for index, sentence in enumerate(sentences):
        if _SUMMARY_SENTENCE.search(sentence) and not re.search(r"\bV[1-9]\b.*\b(?:travel|driv|turn)", sentence):
            continue
        impact = _IMPACT.search(sentence)
        if impact:
            head = sentence[: impact.start()]
            kept.append(head)
            state.crash_sentence = sentence
            between = []
            for later in sentences[index + 1:]:
                second = _IMPACT.search(later)
                between.append(later[: second.start()] if second else later)
                if second:
                    break
            state.between = " ".join(between)
            break
        kept.append(sentence)
    pre = " ".join(kept)
    pre = re.sub(r"(?:in an? )?(?:attempt(?:ed|ing)?|tried|trying)\s+to\s+avoid[^.;]*", " ", pre, flags=re.I)
    pre = re.sub(r"\bto avoid (?:a )?(?:collision|the crash|impact)[^.;]*", " ", pre, flags=re.I)
    pre = re.sub(r"\breacted by[^.;]*|[^.;,]*\b(?:in avoidance|as an avoidance|avoidance maneuver|evasive)[^.;]*", " ", pre,
                 flags=re.I)
    state.pre_crash = pre


# ---------------------------------------------------------------- environment


_ENV_SENTENCE = r"weather|sky|skies|\bhours\b|daylight|dark|dawn|dusk|night|rain|snow|sleet|fog|cloudy|overcast|conditions|" \
                r"surface|\b(?:dry|wet|icy)\b|roads were"


def _environment(state: _State) -> dict:
    sentences = [s for s in state.t.sentences if re.search(_ENV_SENTENCE, s, re.I)]
    sketch_env = [f for f in state.fact_texts("text: ") if re.search(r"daylight|dark|dusk|dawn|clear|rain|dry|wet",
                                                                       f, re.I) and ("/" in f or "," in f)]
    env_text = " ".join(sentences + sketch_env)
    weather = "not_mentioned"
    for pattern, token in ((r"\bsleet|\bsnow(?:ing|fall)?\b(?! (?:and ice )?covered)|\bblizzard", "snowy"),
                           (r"\brain(?:ing|y)?\b|\bdrizzl|\bshowers\b", "rainy"),
                           (r"\bfog(?:gy)?\b|\bmist\b", "foggy"),
                           (r"\bovercast\b", "overcast"),
                           (r"\bcloudy\b|\bclouds\b", "cloudy"),
                           (r"\bwindy\b|\bhigh winds?\b", "windy"),
                           (r"\bclear\b|no adverse|\bsunny\b|\bfair\b", "clear")):
        match = re.search(pattern, env_text, re.I)
        if match:
            weather = token
            state.note("environment.weather", _around(env_text, match))
            break
    time_of_day = "not_mentioned"
    for pattern, token in ((r"\bpre-?dawn\b", "nighttime"), (r"\bdawn\b", "dawn"), (r"\bdusk\b", "dusk"),
                           (r"\bdark(?:ness)?\b|\bnight(?:time)?\b|\bevening hours \(dark", "nighttime"),
                           (r"\bdaylight\b|\bday ?time\b|\bdaylight hours\b|\bafternoon\b|\bmorning hours\b|\bmid-?day\b|\bnoon\b",
                            "daytime")):
        match = re.search(pattern, env_text, re.I)
        if match:
            time_of_day = token
            state.note("environment.time_of_day", _around(env_text, match))
            break
    surface = "not_mentioned"
    for pattern, token in ((r"\bic(?:y|e)\b|snow and ice|ice[- ]covered|snow[- ]covered", "icy"),
                           (r"\bsnow[- ]covered\b", "snowy"),
                           (r"\bwet\b", "wet"), (r"\bdry\b", "dry")):
        match = re.search(pattern, env_text, re.I)
        if match:
            surface = token
            state.note("environment.road_surface", _around(env_text, match))
            break
    return {"weather": weather, "time_of_day": time_of_day, "road_surface": surface}


# ---------------------------------------------------------------- road network


def _road_network(state: _State) -> dict:
    t = state.t
    road_sentences = [s for s in t.sentences if re.search(r"\b(?:road|roadway|highway|freeway|interstate|street|"
                                                          r"trafficway|lanes?|route|avenue|ramp)\b", s, re.I)]
    road_text = " ".join(road_sentences)
    sketch_text = " ".join(state.fact_texts("text: "))
    divided_pattern = r"\bdivided\b(?! by (?:a )?(?:double|painted|yellow))|\bmedian\b|" \
                      r"\b(?:concrete|jersey|cable|median) barrier|interstate|\bfreeway\b"
    state.divided = bool(re.search(divided_pattern, road_text, re.I) or re.search(r"\bmedian\b", sketch_text, re.I)) \
        and not re.search(r"\bnon-?divided|\bundivided|not divided|(?:center|centre|middle) (?:two-way )?(?:left[- ])?"
                          r"turn(?:ing)? lane", road_text, re.I)
    if state.divided:
        match = re.search(divided_pattern, road_text, re.I)
        state.note("road_network.number_of_ways", _around(road_text, match) if match else "sketch: median")
    _traffic_controls(state)
    road_type, curve_direction = _road_type(state)
    if road_type in ("intersection", "t_intersection"):
        _sketch_devices(state)
    ways = _ways(state, road_text)
    lanes = _lanes(state, road_text, ways)
    speed = _speed_limit(state)
    marker = _marker(state, road_text, ways)
    signs = set(state.signs)
    if speed is not None:
        signs.add("speed_limit_sign")
    road: dict = {"road_type": road_type, "number_of_ways": ways, "number_of_lanes": lanes, "road_marker": marker,
                  "traffic_signs": sorted(signs)}
    if speed is not None:
        road["speed_limit_mph"] = speed
    if curve_direction and road_type == "curve":
        road["curve_direction"] = curve_direction
    return road


def _traffic_controls(state: _State) -> None:
    text = state.t.text
    state.no_controls = bool(re.search(r"\b(?:without|no|not controlled by any) (?:any )?traffic control|"
                                       r"\buncontrolled\b|no traffic control devices|no controls", text, re.I))
    signal = re.search(r"traffic (?:signal|light|control signal)s?|\bsignali[sz]ed\b|tri-colou?red|"
                       r"\b(?:red|green|amber|yellow) (?:light|signal|arrow)\b|signal[- ]controlled|"
                       r"controlled by (?:overhead|traffic) signals?|\bsignals?\b(?= (?:at|for|controlling))", text, re.I)
    flashing = re.search(r"flashing (red|yellow|amber)", text, re.I)
    if signal and not (flashing and signal.start() >= flashing.start() - 5):
        state.signs.add("traffic_light")
        state.note("road_network.traffic_signs", _around(text, signal))
    if flashing and flashing.group(1).lower() == "red":
        state.signs.add("stop_sign")
        state.note("road_network.traffic_signs", _around(text, flashing))
    for match in re.finditer(r"\bstop[- ]sign|\bstop[- ]controlled|\bstop(?:ped)? (?:bar|line)|all[- ]way stop|"
                             r"\b(?:two|four|2|4)[- ]way stop", text, re.I):
        state.signs.add("stop_sign")
        state.note("road_network.traffic_signs", _around(text, match))
        sentence = next((x for x in state.t.sentences if match.group(0) in x and re.search(
            re.escape(text[max(0, match.start() - 20):match.end()]), x)), "")
        approach = re.search(rf"\b{_DIR}bound\s+(?:roadway|road|approach|lanes?|traffic|leg|direction)", sentence, re.I)
        if approach:
            state.stop_controlled.update(v.label for v in state.vehicles.values()
                                         if v.direction == approach.group(1).lower())
            continue
        label = _label_at(text, match.start()) or _label_near_after(text, match.end())
        if label:
            state.stop_controlled.add(label)
    for match in re.finditer(r"\byield(?:[- ]sign| controlled)|\byield\b(?= to)", text, re.I):
        if re.search(r"\byield[- ]sign|yield controlled", match.group(0), re.I):
            state.signs.add("yield_sign")
            state.note("road_network.traffic_signs", _around(text, match))
            label = _label_at(text, match.start())
            if label:
                state.yield_controlled.add(label)


def _sketch_devices(state: _State) -> None:
    """Devices read on the sketch of a junction that crossing traffic uses (text wins when it names controls)."""
    if state.no_controls or state.signs or not _has_cross_traffic(state):
        return
    for fact, sign in (("stop sign", "stop_sign"), ("yield sign", "yield_sign"), ("traffic signal", "traffic_light"),
                       ("flashing red signal", "stop_sign")):
        if state.fact_texts(fact):
            state.signs.add(sign)
            state.note("road_network.traffic_signs", f"sketch: {fact}")


def _label_near_after(text: str, position: int) -> str | None:
    match = re.match(r"[^.]{0,60}?\b(V[1-9])\b", text[position:])
    return match.group(1) if match else None


def _road_type(state: _State) -> tuple[str, str | None]:
    t = state.t
    text = t.text
    pre = state.pre_crash + " " + state.crash_sentence
    legs = None
    four = re.search(r"\b(?:4|four)[- ]leg(?:ged)?\b|\bfour[- ]way intersection|\bcross(?:roads| intersection)", text, re.I)
    three = re.search(r"\b(?:3|three)[- ]leg(?:ged)?\b|\bT[- ]intersection|\bT-type intersection|\bTee\b|"
                      r"\bT[- ]junction|driveway|business (?:access|entrance|exit)|parking lot (?:exit|entrance)|"
                      r"(?:private|commercial) (?:drive|road)\b", text, re.I)
    pre = re.sub(r"[^.]*\b(?:intersection|junction) ahead\b[^.]*|[^.]*\bwarning signs?\b[^.]*", " ", pre, flags=re.I)
    mentions_junction = re.search(r"\bintersection\b|\bjunction\b|\bintersecting\b", pre, re.I)
    plays_part = bool(
        re.search(r"\bturn(?:ed|ing|s)?\b|left[- ]turn|right[- ]turn|\bintersection\b|\bjunction\b|"
                  r"\bintersecting\b|entered|pulled (?:out|into)|stop sign|signal", pre, re.I) and mentions_junction
    ) or bool(state.signs - {"speed_limit_sign"}) and bool(mentions_junction)
    driveway_part = three and re.search(r"driveway|business|parking lot|(?:private|commercial) drive", three.group(0),
                                        re.I) and _driveway_vehicle(state) is not None
    if plays_part or driveway_part:
        if driveway_part or (three and not four and not re.search(r"driveway|business|parking|private", three.group(0),
                                                                  re.I)):
            legs = 3
            state.note("road_network.road_type", _around(text, three))
        else:
            legs = 4
            state.note("road_network.road_type", _around(text, four) if four else _around(pre, mentions_junction))
    curve = None
    curve_match = re.search(r"\bcurv(?:e|es|ed|ing)\b", pre, re.I)
    direction = None
    if curve_match:
        window = pre[max(0, curve_match.start() - 60):curve_match.end() + 40]
        side = re.search(r"\b(left|right)(?:-hand)?\s+curve|curve[sd]?\s+(?:to\s+the\s+)?(left|right)|"
                         r"curved\s+(?:to\s+the\s+)?(left|right)", pre, re.I)
        if side:
            direction = _as_ego_sees_it(state, pre, side, next(g for g in side.groups() if g).lower())
        if not re.search(r"\bstraight\b[^.]{0,40}\bcurv|no curve", window, re.I):
            curve = "curve"
            state.note("road_network.road_type", _around(pre, curve_match))
    if legs is not None:
        state.junction = "intersection" if legs == 4 else "t_intersection"
        return state.junction, direction
    if curve:
        # the curve must be V1's: a curve named only for another vehicle still puts the crash on it
        return "curve", direction
    match = re.search(r"\bstraight\b", text, re.I)
    state.note("road_network.road_type", _around(text, match) if match else "no junction or curve in the crash sequence")
    return "straight", None


def _as_ego_sees_it(state: _State, text: str, match: re.Match, side: str) -> str:
    """A curve stated for another vehicle's direction of travel bends the other way for an oncoming ego."""
    start = max(text.rfind(". ", 0, match.start()), 0)
    end = text.find(".", match.end())
    sentence = text[start: end if end > 0 else len(text)]
    ego = state.vehicles["V1"]
    owner = re.search(r"\b(?i:for|in)\s+(V[1-9])\b|\b(V[1-9])'s\b", sentence)
    other = None
    if owner:
        other = state.vehicles.get(owner.group(1) or owner.group(2))
    heading = re.search(rf"heading (?:{_DIR} )?to(?:wards?)? (?:the )?{_DIR}|in the {_DIR}bound direction", sentence, re.I)
    their_direction = other.direction if other and other.label != "V1" else None
    if heading:
        their_direction = next(g for g in heading.groups()[::-1] if g).lower()
    if their_direction and ego.direction and (COMPASS[their_direction] - COMPASS[ego.direction]) % 360 == 180:
        return "left" if side == "right" else "right"
    return side


_DRIVEWAY = r"(?:private |commercial |residential |business )?(?:driveway|drive\b|parking lot|business (?:access|" \
            r"entrance)|private road|alley)"


def _driveway_vehicle(state: _State) -> str | None:
    """The vehicle that enters the road from a driveway, parking lot or business access, if one does."""
    text = state.pre_crash + " " + state.crash_sentence
    for match in re.finditer(rf"(?:from|out of|exit(?:ed|ing)?|leav(?:e|ing)|in the mouth of|pull(?:ed|ing)? out of)\s+"
                             rf"(?:of\s+)?(?:a |the |an )?{_DRIVEWAY}", text, re.I):
        label = _label_at(text, match.start())
        if label:
            return label
    match = re.search(rf"{_DRIVEWAY}\s+that\s+(V[1-9])\s+was\s+(?:exiting|leaving|pulling out of)", text, re.I)
    return match.group(1) if match else None


def _ways(state: _State, road_text: str) -> int:
    one_way = re.search(r"\bone[- ]way\b", road_text, re.I)
    if one_way:
        state.note("road_network.number_of_ways", _around(road_text, one_way))
        return 1
    if state.divided and not _crosses_opposing(state):
        match = re.search(r"divided|median|barrier|interstate|freeway", road_text, re.I)
        state.note("road_network.number_of_ways", "divided roadway: V1's carriageway only; " + _around(road_text, match))
        return 1
    return 2


def _crosses_opposing(state: _State) -> bool:
    """Whether the crash sequence uses the opposing carriageway (a turn across the median, a crossover)."""
    pre = state.pre_crash
    return bool(re.search(r"left[- ]turn|turn(?:ed|ing)? left|u[- ]turn|cross(?:ed|ing)? (?:over )?the median|"
                          r"across the median|crossover", pre, re.I))


def _count(word: str) -> int:
    return NUMBERS.get(word.lower(), 0)


_PLAIN_WORD = r"(?!(?:north|south|east|west)bound\b)(?![\w-]*way\b)[\w-]+"  # not a direction, not "two-way"


def _lanes(state: _State, road_text: str, ways: int) -> int:
    """Through lanes of V1's roadway: all directions when two-way, V1's carriageway when divided or one-way."""
    ego = state.vehicles["V1"]
    per_direction: dict[str, int] = {}
    quote = None

    def put(direction: str, number: int, match: re.Match, override: bool = False) -> None:
        nonlocal quote
        if number and (override or direction not in per_direction):
            per_direction[direction] = number
            quote = quote or _around(road_text, match)

    # "two lanes northbound ... two lanes southbound", "three northbound lanes and four southbound lanes"
    for match in re.finditer(rf"\b{_NUM}\s+(?:straight\s+)?(?:through\s+)?(?:travel\s+)?(?:lanes?\s+)?{_DIR}bound"
                             rf"(?:\s+(?:through\s+|travel\s+)?lanes?)?|\b{_NUM}\s+(?:travel\s+)?lanes?\s+{_DIR}bound",
                             road_text, re.I):
        groups = [g for g in match.groups() if g]
        put(groups[1].lower(), _count(groups[0]), match)
    # "the southbound traffic-way consisted of a six-lane roadway", "the westbound roadway has three travel lanes"
    for match in re.finditer(rf"(?<![/-]){_DIR}(?:bound)?\s+(?:roadway|lanes|traffic-?way|carriageway|side)\b[^.]{{0,60}}?"
                             rf"\b{_NUM}[- ](?:{_PLAIN_WORD}\s+){{0,3}}?lanes?\b", road_text, re.I):
        put(match.group(1).lower(), _count(match.group(2)), match, override=True)
    # "the two-way east/west roadway consisted of two travel lanes": a total for the road on V1's axis
    axis = "north/south" if ego.direction in ("north", "south") else "east/west" if ego.direction else None
    for match in re.finditer(rf"\b(north[/-]south|east[/-]west)\s+(?:roadway|road|street|highway|trafficway)\b"
                             rf"[^.]{{0,60}}?\b{_NUM}[- ](?:{_PLAIN_WORD}\s+){{0,3}}?lanes?\b", road_text, re.I):
        if axis and match.group(1).lower().replace("-", "/") == axis and not any(
                d in per_direction for d in axis.split("/")):
            put("_axis", _count(match.group(2)), match)
    # explicit through-lane breakdowns and "three lanes continue westbound" override totals that hold turn lanes
    for match in re.finditer(rf"{_DIR}bound lanes (?:are|were) composed of ([^.]*)", road_text, re.I):
        through = re.search(rf"{_NUM}\s+(?:straight\s+)?through", match.group(2), re.I)
        if through:
            put(match.group(1).lower(), _count(through.group(1)), match, override=True)
            per_direction.setdefault("_breakdown", 0)
    for match in re.finditer(rf"\b{_NUM}\s+(?:through\s+)?lanes\s+continu\w*(?:[^.]{{0,30}}?{_DIR})?", road_text, re.I):
        direction = (match.group(2) or ego.direction or "").lower()
        if direction:
            put(direction, _count(match.group(1)), match, override=True)
    if "_breakdown" in per_direction:
        del per_direction["_breakdown"]
    else:
        # "six southbound lanes, with the far-left lane being a U-turn lane and the adjacent lane being a left turn lane"
        for turn in re.finditer(r"\b(?:being|is|was|as)\s+an?\s+(?:dedicated\s+)?(?:u-turn|left[- ]turn(?:[- ]only)?|"
                                r"right[- ]turn(?:[- ]only)?)\s+lane", road_text, re.I):
            direction = re.findall(rf"{_DIR}bound", road_text[: turn.start()], re.I)
            key = direction[-1].lower() if direction else None
            if key in per_direction and per_direction[key] > 1:
                per_direction[key] -= 1
    each = re.search(r"one (?:travel )?lane in each direction|single lane in each direction", road_text, re.I)
    if each:
        per_direction = {"a": 1, "b": 1}
        quote = _around(road_text, each)
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
        match = re.search(rf"\b{_NUM}[- ]lane\b", road_text, re.I)
        if match:
            total = _count(match.group(1))
            quote = _around(road_text, match)
            if ways == 2:
                # an odd count on a two-way road holds a centre turn lane ("five-lane ... middle left-turn lane")
                lanes = total - 1 if total >= 3 and total % 2 else total
            elif state.divided and total >= 2 and not re.search(r"one[- ]way", road_text, re.I):
                lanes = max(1, total // 2)
            else:
                lanes = total
    if lanes is None:
        lanes = 2 if ways == 2 else 1
        quote = "no lane count stated: one lane per direction"
    merge = re.search(r"\b(?:entrance|on)[- ]ramp\b|\bacceleration lane\b|\bmerg(?:e|ed|ing)\b",
                      state.pre_crash + " " + state.crash_sentence, re.I)
    if merge and ways == 1 and len(state.vehicles) > 1:
        lanes += 1  # the acceleration lane counts when a merge is part of the crash (dsl.md convention 3)
        quote = f"{quote}; + acceleration lane: {_around(state.pre_crash + ' ' + state.crash_sentence, merge, 40)}"
    state.note("road_network.number_of_lanes", quote or "lane count per direction")
    return max(1, lanes)


def _speed_limit(state: _State) -> int | None:
    text = state.t.text
    match = re.search(r"(?:speed\s+limit|posted\s+(?:speed|limit))[^.]{0,80}?(\d{2,3})\s*(?:mph|mi/h|miles per hour)",
                      text, re.I)
    if match:
        state.note("road_network.speed_limit_mph", _around(text, match))
        return int(match.group(1))
    match = re.search(r"(?:speed\s+limit|posted)[^.]{0,60}?(\d{2,3})\s*(?:km/h|kmph|km/hr|kph)", text, re.I)
    if match:
        state.note("road_network.speed_limit_mph", _around(text, match))
        return int(5 * round(int(match.group(1)) / KMH_PER_MPH / 5))
    match = re.search(r"(\d{2,3})\s*(?:mph|mi/h)\s+(?:speed limit|zone|posted)", text, re.I)
    if match:
        state.note("road_network.speed_limit_mph", _around(text, match))
        return int(match.group(1))
    for prefix in ("speed limit ", "speed "):
        for fact in state.facts:
            found = re.fullmatch(rf"{prefix}(\d+) mph", fact.text)
            if found:
                state.note("road_network.speed_limit_mph", f"sketch: {fact.text}")
                return int(found.group(1))
    return None


def _on_ego_road(state: _State, pattern: str, text: str, window: int = 10_000) -> re.Match | None:
    """The first match of `pattern` not in a sentence about the crossing road (another travel axis than V1's)."""
    ego = state.vehicles["V1"].direction
    axis = {"north": "ns", "south": "ns", "east": "ew", "west": "ew"}.get(ego or "")
    for match in re.finditer(pattern, text, re.I):
        start = max(text.rfind(". ", 0, match.start()), match.start() - window, 0)
        head = text[start:match.start()]
        named = re.findall(r"\b(north|south|east|west)(?:bound|[/-]|\s*&)", head, re.I)
        axes = {"ns" if d.lower() in ("north", "south") else "ew" for d in named}
        if axis and axes and axis not in axes:
            continue
        return match
    return None


def _marker(state: _State, road_text: str, ways: int) -> str:
    text = state.t.text
    sketch_text = " ".join(state.fact_texts("text: "))
    for pattern, token in (
        (r"double (?:solid )?(?:yellow )?(?:cent(?:er|re) ?)?lines?|solid double|double[- ]yellow|"
         r"(?:two|2) solid (?:yellow )?lines", "double_solid_line"),
        (r"two-way (?:center |centre )?left[- ]turn lane|center (?:two-way )?turn lane|\bTWLTL\b|"
         r"solid (?:and|with) (?:a )?broken|broken (?:and|with) (?:a )?solid|passing zone", "solid_and_broken_line"),
        (r"(?:broken|dashed|skip) (?:yellow |white )?(?:cent(?:er|re) ?)?lines?", "broken_line"),
        (r"no (?:cent(?:er|re) ?line|pavement|lane) markings?|unmarked|unpaved|gravel road|dirt road", "none"),
        (r"single solid (?:yellow )?(?:cent(?:er|re) ?)?line|solid (?:yellow )?cent(?:er|re) ?line", "solid_line"),
    ):
        match = _on_ego_road(state, pattern, text) or _on_ego_road(state, pattern, sketch_text, window=80)
        if match:
            source = text if _on_ego_road(state, pattern, text) else sketch_text
            state.note("road_network.road_marker", _around(source, match) if source is text else f"sketch: {match.group(0)}")
            return token
    if ways == 1 and state.divided:
        state.note("road_network.road_marker", "divided roadway: no centre line on V1's carriageway")
        return "none"
    if state.divided:
        state.note("road_network.road_marker", "divided roadway (median): no centre line")
        return "none"
    if ways == 2:
        for fact, token in (("double solid line drawn", "double_solid_line"), ("broken line drawn", "broken_line")):
            if state.fact_texts(fact):
                state.note("road_network.road_marker", f"sketch: {fact}")
                return token
    return "not_mentioned"


# ---------------------------------------------------------------- behaviours


_LOSE = r"\blost control|\bloss of control|\blose control|\bbegan (?:to )?(?:rotat|yaw|skid|spin|fishtail)|" \
        r"\bbegan a (?:\w+ )?(?:rotation|yaw|spin)|\b(?:spun|yawed|fishtailed|hydroplaned)\b"
_CROSS = r"cross(?:ed|ing|es)?\s+(?:over\s+)?the\s+(?:double\s+(?:yellow\s+)?|solid\s+|painted\s+)*(?:cent(?:er|re)[- ]?lines?|" \
         r"cent(?:er|re) lane lines|double (?:yellow )?lines?|yellow lines?)|" \
         r"left[- ]of[- ]cent(?:er|re)|into the (?:opposing|oncoming) (?:traffic )?(?:travel )?lane|wrong[- ]way|" \
         r"drift(?:ed|ing)? (?:across|over) the cent|into (?:the )?(?:path of )?oncoming traffic|" \
         r"encroach\w* (?:\w+ ){0,2}into V[1-9]'s (?:travel )?lane|against the flow|in the wrong direction"
_LEAVE = r"(?:depart(?:ed|ing|s)?|exit(?:ed|ing|s)?|ran|run|running|drove|went|veered|travel(?:ed|led)?)\s+(?:off\s+)?" \
         r"(?:of\s+)?the\s+(?:left|right|north|south|east|west)?\s*(?:side|edge)\s+of\s+the\s+(?:road|roadway|travel lane|" \
         r"highway|lane)|ran off the road|off the roadway|(?:depart(?:ed|ing)?|exit(?:ed|ing)?|left) the (?:road|roadway)\b" \
         r"(?! onto the (?:single |one |\w+ )?(?:lane )?(?:exit |entrance )?ramp)|onto the (?:left |right )?(?:shoulder|roadside)|" \
         r"entered the (?:[\w-]+ ){0,4}?(?:edge of the )?(?:left |right )?shoulder|" \
         r"drift(?:ed|ing)? (?:partially )?(?:off|to the (?:right|left) of) the (?:travel lane|road|roadway)"
_OVERTAKE = r"attempt(?:ed|ing)? to pass\b|\bpass(?:ed|ing)? (?:a |the )?(?:slower|V[1-9])|\bovertak\w+|to pass V[1-9]"
_LANE_CHANGE = r"(?:veer(?:ed|ing)?|mov(?:ed|ing)|chang(?:ed|ing) lanes|steer(?:ed|ing)|swerv(?:ed|ing)|merg(?:ed|ing)|" \
               r"drift(?:ed|ing))\s+(?:\w+\s+){0,3}?(?:to\s+the\s+)?(left|right)?[^.]{0,40}?into the (left|right|adjacent|" \
               r"middle|center|inside|outside|passing|(?:north|south|east|west)bound)\s*((?:north|south|east|west)bound)?"
_LANE_CHANGE_SIDE = r"chang(?:e|ed|ing|es) lanes? (?:to|into) the (left|right)|lane change to the (left|right)|" \
                    r"(?:merge|merged|merging) (?:to the )?(left|right)"
# entering a freeway from an on-ramp: ramps join from the right, so the merge is a change to the left
_RAMP_MERGE = r"(?:attempt\w* to|began to|was)\s+(?:enter|merg\w*)\w*\s+(?:onto\s+|into\s+)?(?:the\s+)?(?:same\s+)?" \
              r"(?:freeway|interstate|highway|expressway|traffic|travel lanes?)"
_TURN_LEFT = r"turn(?:ed|ing|s)?\s+left|left[- ]turn(?:ing)?(?! lane)|make a left|making a left|initiat\w+ a left"
_TURN_RIGHT = r"turn(?:ed|ing|s)?\s+right|right[- ]turn(?:ing)?(?! lane)|make a right|making a right"
_U_TURN = r"\bu[- ]turn(?:ing|ed)?\b(?! lane)"
_STOPPED = r"\b(?:brought|came|come|coming)\s+(?:\w+\s+){0,2}to a (?:stop|halt)|" \
           r"\b(?:was|were|had|been|came to a|come to a) (?:stopped|stationary|stopping|slowing to a stop)|\bstopped in (?:the )?" \
           r"(?:travel )?lane|\bwaiting (?:to|for)\b|\bstopped (?:in|for|at|behind) (?:traffic|the|a)\b|\bstopped\b"
_PARKED = r"\bparked\b|\bdisabled\b|\bunoccupied\b|\babandoned\b"
_DECEL = r"\bslow(?:ed|ing)(?: down)?\b|\bbrak(?:ed|ing)\b|\bdecelerat\w+"
_PROCEED = r"\b(?:then |and )?(?:proceeded|pulled (?:out|into|forward)|entered|accelerated|began to (?:cross|proceed|move))"


def _behaviors(state: _State) -> None:
    pre = state.pre_crash
    spans: dict[str, list[tuple[int, str, re.Match]]] = {label: [] for label in state.vehicles}

    leaders = [v.label for v in state.vehicles.values() if v.role != "ego" and re.search(
        rf"\b{v.label}\b[^.]{{0,200}}\b(?:ahead of|in front of) (?:V1|him|her)\b", state.t.text, re.I)]

    def collect(pattern: str, token: str) -> None:
        for match in re.finditer(pattern, pre, re.I):
            sentence_head = pre[max(pre.rfind(". ", 0, match.start()), pre.rfind("; ", 0, match.start()), 0):match.start()]
            clause = pre[max(pre.rfind(". ", 0, match.start()), pre.rfind(", ", 0, match.start()), 0):match.start()]
            multi = re.search(r"((?:V[1-9](?:,\s*|\s+and\s+|,\s+and\s+))+V[1-9])\s+(?:also\s+|all\s+|both\s+)?$",
                              sentence_head)
            if multi:
                for label in re.findall(r"V[1-9]", multi.group(1)):
                    if label in spans:
                        spans[label].append((match.start(), token, match))
                continue
            if not re.search(r"\bV[1-9]\b", clause) and re.search(
                    r"\b(?:non-contact|another|other|third|lead|leading|a|the)\s+vehicle\b|\btraffic\b", clause, re.I):
                # "the vehicle in front of him was stopped", "traffic ahead had slowed": not a labelled actor,
                # except that slowing traffic ahead is the leader's behaviour
                if token in ("decelerate", "stop") and re.search(r"\btraffic\b", clause, re.I):
                    for label in leaders:
                        spans[label].append((match.start(), token, match))
                continue
            label = _label_at(pre, match.start())
            if label is None and len(state.vehicles) == 1:
                label = "V1"
            if label is None:
                # "The driver failed to negotiate ..." in a report whose first vehicle is the subject
                label = _last_subject_before(state, pre, match.start())
            if label in spans:
                spans[label].append((match.start(), token, match))

    collect(_LOSE, "lose_control")
    collect(_CROSS, "cross_centerline")
    collect(_LEAVE, "leave_road")
    collect(_OVERTAKE, "overtake")
    collect(_LANE_CHANGE, "lane_change")
    collect(_LANE_CHANGE_SIDE, "lane_change_side")
    if re.search(r"\b(?:entrance|on)[- ]ramp\b|\bacceleration lane\b", pre, re.I):
        collect(_RAMP_MERGE, "ramp_merge")
    collect(_TURN_LEFT, "turn_left")
    collect(_TURN_RIGHT, "turn_right")
    collect(_U_TURN, "u_turn")
    collect(_STOPPED, "stop")
    collect(_PARKED, "static")
    collect(_DECEL, "decelerate")
    collect(r"across the (?:north|south|east|west)bound (?:travel )?lanes?|(?:into|enter(?:ed|ing|s)?|in) the "
            r"(?:north|south|east|west)bound (?:travel )?lanes?(?! of)", "into_lane")
    for label, vehicle in state.vehicles.items():
        found = sorted(spans[label], key=lambda item: item[0])
        vehicle.behavior, quote = _resolve(state, vehicle, found)
        if vehicle.behavior in ("go_forward", "decelerate") and state.between:
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


def _entered_opposing(state: _State, vehicle: _Vehicle) -> str | None:
    text = state.between
    for match in re.finditer(rf"\b{vehicle.label}\s+(?:then\s+)?(?:enter\w*|mov\w+|swerv\w+|veer\w+|drift\w+)\s+"
                             rf"(?:\w+\s+){{0,3}}?(?:into\s+)?the\s+({_DIR})bound\s+(?:travel\s+)?lane", text, re.I):
        if vehicle.direction and (COMPASS[match.group(1).lower()] - COMPASS[vehicle.direction]) % 360 == 180:
            return _around(text, match, 80)
    match = re.search(rf"\b{vehicle.label}\b(?:(?!\b(?:pushed|caused|redirected|forced)\b)[^.]){{0,60}}(?:{_CROSS})",
                      text, re.I)
    return _around(text, match, 80) if match else None


def _last_subject_before(state: _State, text: str, position: int) -> str | None:
    labels = re.findall(r"\bV([1-9])\b", text[:position])
    if labels:
        return f"V{labels[-1]}"
    return None


def _opposing_lane(vehicle: _Vehicle, phrase: str) -> bool:
    match = re.search(_DIR + "bound", phrase, re.I)
    if not match or vehicle.direction is None:
        return False
    return (COMPASS[match.group(1).lower()] - COMPASS[vehicle.direction]) % 360 == 180


def _resolve(state: _State, vehicle: _Vehicle, found: list[tuple[int, str, re.Match]]) -> tuple[str, str | None]:
    pre = state.pre_crash

    def quote(match: re.Match) -> str:
        return _around(pre, match, 80)

    if any(token == "static" for _, token, _ in found):
        match = next(m for _, token, m in found if token == "static")
        return "static", quote(match)
    parked = re.search(rf"\b(?:parked|unoccupied|non-occupied|abandoned)\b[^.()]{{0,60}}\(\s*{vehicle.label}\s*\)|"
                       rf"\(\s*{vehicle.label}\s*\)\s*(?:that|which)\s+was\s+(?:legally\s+)?(?:parked|unoccupied)|"
                       rf"\b{vehicle.label}\b[^.]{{0,80}}\bwas\s+(?:legally\s+)?parked\b", state.t.text, re.I)
    if parked:
        return "static", _around(state.t.text, parked, 80)
    first_event = None
    for position, token, match in found:
        if token in ("lose_control", "cross_centerline", "leave_road", "overtake"):
            first_event = (token, match)
            break
        if token == "lane_change":
            target = (match.group(2) or "").lower()
            bound = (match.group(3) or match.group(2) or "").lower()
            if bound.endswith("bound") and vehicle.direction and \
                    (COMPASS[bound[:-5]] - COMPASS[vehicle.direction]) % 360 == 180:
                first_event = ("cross_centerline", match)
                break
            side = (match.group(1) or (target if target in ("left", "right") else "") or "").lower()
            if side in ("left", "right"):
                first_event = (f"change_lane_{side}", match)
                break
        if token == "ramp_merge":
            first_event = ("change_lane_left", match)
            break
        if token == "lane_change_side":
            first_event = (f"change_lane_{next(g for g in match.groups() if g).lower()}", match)
            break
        if token == "into_lane" and _opposing_lane(vehicle, match.group(0)):
            first_event = ("cross_centerline", match)
            break
    if first_event:
        return first_event[0], quote(first_event[1])
    stop = next((m for _, t, m in found if t == "stop"), None)
    for token in ("u_turn", "turn_left", "turn_right"):
        match = next((m for _, t, m in found if t == token), None)
        if match:
            intention = re.search(r"(?:waiting|preparing|intending|planning|about|signal(?:ing|led)?|so as)\b[^.;]{0,40}$",
                                  pre[max(0, match.start() - 50):match.start()], re.I)
            proceeded = re.search(_PROCEED + r"|began to enter|with the intention of turning", pre[match.end():], re.I)
            if stop and intention and stop.start() < match.start() and not (
                    proceeded and _label_at(pre, match.end() + proceeded.start()) == vehicle.label):
                return "stop", quote(stop)
            return token, quote(match)
    if stop:
        for proceed in re.finditer(_PROCEED, pre[stop.end():], re.I):
            if _label_at(pre, stop.end() + proceed.start()) in (vehicle.label, None):
                return "go_forward", quote(stop)  # stopped at the sign, then went on (convention 8)
        return "stop", quote(stop)
    decel = next((m for _, t, m in found if t == "decelerate"), None)
    if decel and vehicle.role != "ego" or decel and not re.search(r"avoid", pre[decel.start() - 60: decel.end()], re.I):
        if decel:
            return "decelerate", quote(decel)
    return "go_forward", None


# ---------------------------------------------------------------- actors and positions


def _relative_heading(ego: _Vehicle, other: _Vehicle) -> str | None:
    if ego.direction is None or other.direction is None:
        return None
    delta = (COMPASS[other.direction] - COMPASS[ego.direction]) % 360
    if delta == 0:
        return "same_direction"
    if delta == 180:
        return "opposite_direction"
    origin = (COMPASS[other.direction] + 180 - COMPASS[ego.direction]) % 360  # where it comes from
    return "from_right" if origin == 90 else "from_left"


def _actors(state: _State, road: dict) -> dict:
    ego = state.vehicles["V1"]
    at_junction = road["road_type"] in ("intersection", "t_intersection")
    devices = set(road["traffic_signs"]) - {"speed_limit_sign"}
    actors: dict = {}
    crash = state.crash_sentence + " " + " ".join(state.t.sentences)
    for label, vehicle in state.vehicles.items():
        if vehicle.role == "ego":
            reference, relation = _ego_reference(state, road, devices, at_junction)
            position = {"reference": reference, "relation": relation}
        else:
            position = _npc_position(state, ego, vehicle, devices, at_junction, crash)
        actors[vehicle.role] = {"label": label, "type": vehicle.type, "behavior": vehicle.behavior,
                                "position": position}
        speed = _stated_speed(state, label)
        if speed is not None:
            actors[vehicle.role]["speed_mph"] = speed
    return actors


_SPEED_VALUE = r"(\d{1,3})\s*(mph|mi/h|miles per hour|km/h|kmph|km/hr|kph)"


def _stated_speed(state: _State, label: str) -> float | None:
    """A travel speed the report states for the vehicle ('V2 was traveling at approximately 60 mph') [mph]."""
    text = state.t.text
    for match in re.finditer(rf"(?:travel(?:l?ing|l?ed)?|going|driving|driven|moving)\s+(?:(?:north|south|east|west)(?:bound)?\s+)?"
                             rf"(?:at\s+)?(?:a\s+)?"
                             rf"(?:(?:an\s+)?(?:estimated|approximate(?:ly)?|about|roughly|reported(?:ly)?|"
                             rf"calculated|travel)\s+)*(?:speed\s+of\s+)?{_SPEED_VALUE}|"
                             rf"(?:estimated|calculated|reported|pre-?crash|travel)\s+speed\s+(?:of\s+|was\s+)?"
                             rf"(?:approximately\s+|about\s+)?{_SPEED_VALUE}", text, re.I):
        if re.search(r"limit|posted", text[max(0, match.start() - 30):match.start()], re.I):
            continue
        if _label_at(text, match.start()) != label:
            continue
        number = int(match.group(1) or match.group(3))
        unit = (match.group(2) or match.group(4)).lower()
        if unit.startswith("k"):
            after = re.match(r"\s*\((\d{1,3})\s*mph\)", text[match.end():])
            mph = float(after.group(1)) if after else round(number / KMH_PER_MPH)
        else:
            mph = float(number)
        if 0 < mph <= 200:
            state.note(f"actors.{state.vehicles[label].role}.speed_mph", _around(text, match))
            return mph
    return None


def _ego_reference(state: _State, road: dict, devices: set[str], at_junction: bool) -> tuple[str, str]:
    ego = state.vehicles["V1"]
    if at_junction:
        if "traffic_light" in devices:
            return "traffic_light", "behind"
        if "stop_sign" in devices and ("V1" in state.stop_controlled or not (state.stop_controlled or
                                                                            _has_cross_traffic(state))):
            return "stop_sign", "behind"
        if "yield_sign" in devices and "V1" in state.yield_controlled:
            return "yield_sign", "behind"
        return "intersection", "behind"
    if road["road_type"] == "curve":
        return "curve", "behind"
    return "road", "behind"


def _has_cross_traffic(state: _State) -> bool:
    ego = state.vehicles["V1"]
    return any(_relative_heading(ego, v) in ("from_left", "from_right") for v in state.vehicles.values() if v is not ego)


def _npc_position(state: _State, ego: _Vehicle, npc: _Vehicle, devices: set[str], at_junction: bool,
                  text: str) -> dict:
    heading = _relative_heading(ego, npc)
    label = npc.label
    if heading is None:
        if npc.behavior in ("cross_centerline", "overtake") or ego.behavior == "cross_centerline":
            heading = "opposite_direction"
        elif re.search(rf"(?:rear|back)(?: plane| end)? of {label}|{label}\b[^.]{{0,80}}\b(?:rear|back)[- ]end|"
                       rf"front of {label} struck the (?:rear|back)|{label}\b[^.]{{0,40}}\bbehind", text, re.I) or \
                npc.behavior in ("stop", "decelerate", "static"):
            heading = "same_direction"
        elif at_junction:
            heading = "from_left"
        else:
            heading = "opposite_direction"
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


def _same_direction_relation(state: _State, ego: _Vehicle, npc: _Vehicle, text: str) -> str:
    label = npc.label
    if npc.behavior == "static" and re.search(rf"\b{label}\b[^.]{{0,120}}\b(?:parked|stopped|disabled)\b[^.]{{0,40}}"
                                              rf"\b(?:shoulder|curb|roadside|side of the road)", text, re.I):
        side = re.search(rf"\b{label}\b[^.]{{0,160}}\b(left|median|inside)\b[^.]{{0,10}}shoulder", text, re.I)
        return "left" if side else "right"
    if ego.lane_number and npc.lane_number and ego.lane_number != npc.lane_number:
        return "left" if npc.lane_number > ego.lane_number else "right"
    if npc.behavior in ("change_lane_left", "change_lane_right") and not (ego.lane_side and npc.lane_side):
        return "right" if npc.behavior == "change_lane_left" else "left"  # it comes from the side it leaves
    if ego.lane_side and npc.lane_side and ego.lane_side != npc.lane_side and "middle" not in (ego.lane_side,
                                                                                               npc.lane_side):
        if not re.search(rf"{label}\b[^.]{{0,60}}\bbehind|behind V1|following V1", text, re.I) or \
                ego.behavior.startswith("change_lane") or npc.behavior.startswith("change_lane"):
            return npc.lane_side
    behind = re.search(rf"\b{label}\b[^.]{{0,80}}\b(?:behind|following)\b[^.]{{0,20}}V1|"
                       rf"\bfront (?:plane )?of {label}\b[^.]{{0,40}}\b(?:struck|impacted|contacted)\b[^.]{{0,20}}"
                       rf"(?:rear|back)|(?:rear|back)(?: plane)? of V1\b[^.]{{0,40}}(?:struck|impacted) by[^.]{{0,30}}{label}|"
                       rf"\b{label}\b[^.]{{0,100}}\b(?:struck|striking|strike|impacted|hit|rear-ended)\s+(?:the\s+)?"
                       rf"(?:rear|back)(?:\s+plane|\s+end)?\s+of\s+V1|\b{label}\b[^.]{{0,80}}\bapproaching V1\b|"
                       rf"\b{label}\b[^.]{{0,40}}slightly behind", text, re.I)
    if behind:
        return "behind"
    return "front"


# ---------------------------------------------------------------- oracle


def _oracle(state: _State, road: dict, actors: dict) -> list[dict]:
    entries: list[dict] = []
    marker = road["road_marker"]
    text = state.t.text
    pre = state.pre_crash

    def add(code: str, violation: str, role: str, description: str, quote: str | None = None) -> None:
        if any(e["code"] == code and e["actor"] == role for e in entries):
            return
        entries.append({"code": code, "violation": violation, "actor": role, "description": _quote(description, 300)})
        if quote:
            state.note(f"oracle[{len(entries) - 1}]", quote)

    for label, vehicle in state.vehicles.items():
        role, behavior, flags = vehicle.role, vehicle.behavior, vehicle.flags
        quote = vehicle.behavior_quote
        if behavior == "lose_control" or re.search(
                rf"\b{label}\b[^.]{{0,80}}(?:too fast for|excessive speed|unsafe speed|speed too great)", text, re.I):
            add("CVC_22350", "unsafe_speed", role, f"{label} lost control or was driven too fast for the conditions.",
                quote)
        crossed = behavior in ("cross_centerline", "overtake") or (behavior == "lose_control" and "cross_centerline"
                                                                  in flags)
        if crossed:
            add("CVC_21650", "wrong_side", role, f"{label} entered the opposing lanes of the two-way roadway.", quote)
            if marker == "double_solid_line":
                add("CVC_21460", "double_line_crossing", role, f"{label} crossed the double solid centre line.", quote)
        at_fault_other = any(v.behavior in ("lose_control", "cross_centerline", "leave_road")
                             for v in state.vehicles.values() if v is not vehicle)
        if behavior.startswith("change_lane") and not at_fault_other:
            add("CVC_22107", "unsafe_lane_change", role, f"{label} changed lanes into the path of another vehicle.",
                quote)
        speeding = re.search(rf"\b{label}\b[^.]{{0,80}}(?:speeding|exceed(?:ed|ing) the (?:posted )?speed limit|"
                             rf"above the (?:posted )?speed limit)", text, re.I)
        if speeding:
            add("CVC_22349", "speed_limit", role, f"{label} exceeded the posted speed limit.", _around(text, speeding))
        red = re.search(rf"\b{label}\b[^.]{{0,100}}(?:red (?:light|signal|indication)|against (?:the|a) red|ran the red)",
                        text, re.I)
        if red:
            add("CVC_21453", "red_light", role, f"{label} entered the intersection against a red signal.",
                _around(text, red))
    _junction_oracle(state, road, actors, add)
    _rear_end_oracle(state, actors, add)
    return entries


def _junction_oracle(state: _State, road: dict, actors: dict, add) -> None:
    if road["road_type"] not in ("intersection", "t_intersection"):
        return
    text = state.t.text
    devices = set(road["traffic_signs"]) - {"speed_limit_sign"}
    ego = state.vehicles["V1"]
    for label, vehicle in state.vehicles.items():
        role = vehicle.role
        others = [v for v in state.vehicles.values() if v is not vehicle]
        heading_to = {o.label: _relative_heading(vehicle, o) for o in others}
        # left turn across oncoming traffic
        if vehicle.behavior == "turn_left" and any(h == "opposite_direction" for h in heading_to.values()) and not \
                re.search(r"(?:green|protected) (?:left[- ]turn )?arrow", text, re.I):
            add("CVC_21801", "left_turn_yield", role, f"{label} turned left across the path of oncoming traffic.",
                vehicle.behavior_quote)
        if _driveway_vehicle(state) == label:
            add("CVC_21804", "driveway_yield", role, f"{label} left a driveway into the path of traffic.",
                vehicle.behavior_quote)
            continue
        if not any(h in ("from_left", "from_right") for h in heading_to.values()):
            continue
        ran_stop = re.search(rf"\b{label}\b[^.]{{0,80}}(?:fail(?:ed|ing) to stop|did not stop|ran the stop|"
                             rf"without stopping|disregarded the stop)", text, re.I)
        if "stop_sign" in devices and label in _stop_approaches(state):
            if ran_stop:
                add("CVC_22450", "stop_sign", role, f"{label} did not stop at its stop sign.", _around(text, ran_stop))
            else:
                add("CVC_21802", "stop_sign_yield", role,
                    f"{label} left its stop-controlled approach into the path of cross traffic.", vehicle.behavior_quote)
        elif "yield_sign" in devices and label in _yield_approaches(state):
            add("CVC_21803", "yield_sign", role, f"{label} did not yield at its yield sign to cross traffic.",
                vehicle.behavior_quote)
        elif not devices and _driveway_vehicle(state) is None:
            # uncontrolled junction: the vehicle with the other on its right must yield
            if any(h == "from_right" for h in heading_to.values()):
                add("CVC_21800", "intersection_right_of_way", role,
                    f"{label} entered the uncontrolled intersection without yielding to the vehicle on its right.",
                    vehicle.behavior_quote)


def _stop_approaches(state: _State) -> set[str]:
    if state.stop_controlled:
        return state.stop_controlled
    ego = state.vehicles["V1"]
    cross = {v.label for v in state.vehicles.values() if v is not ego and _relative_heading(ego, v) in
             ("from_left", "from_right")}
    return cross


def _yield_approaches(state: _State) -> set[str]:
    if state.yield_controlled:
        return state.yield_controlled
    ego = state.vehicles["V1"]
    return {v.label for v in state.vehicles.values() if v is not ego and _relative_heading(ego, v) in
            ("from_left", "from_right")}


_NO_LABEL = r"(?:(?!\bV[1-9]\b)[^.]){0,100}?"  # words that name no other vehicle
_STRIKE = r"(?:struck|strikes?|striking|impacted|rear-ended|hit|contacted)"
_REAR = r"(?:the\s+)?(?:rear|back)(?:\s+(?:plane|corner|end|bumper))?\s+of\s+(?:(?:a|an|the)\s+[^.()]{0,60}?\(\s*)?(V[1-9])"


def _rear_end_oracle(state: _State, actors: dict, add) -> None:
    """Striking the back of a moving vehicle -> CVC_21703, of a stopped one -> CVC_22350 (convention 9).

    Only an impact the striker drives into counts: one it is pushed into ("caused V1 to strike") is an outcome.
    """
    text = state.t.text
    for label, vehicle in state.vehicles.items():
        if vehicle.behavior in ("leave_road", "lose_control", "static"):
            continue  # off the road or out of control: not a following-distance or speed-in-traffic case
        for match in re.finditer(rf"(?:(?:front|side|corner)(?:\s+plane)?\s+of\s+{label}\b{_NO_LABEL}{_STRIKE}\s+{_REAR}|"
                                 rf"\b{label}\b{_NO_LABEL}{_STRIKE}\s+{_REAR})", text, re.I):
            head = text[max(0, match.start() - 40):match.start()]
            if re.search(r"\b(?:caus\w+|push\w*|forc\w+|redirect\w*|propell\w+)\s+(?:\w+\s+)?$", head, re.I):
                continue
            struck_label = match.group(1) or match.group(2)
            struck = state.vehicles.get(struck_label)
            if struck is None or struck_label == label:
                continue
            stopped = struck.behavior in ("stop", "static") or re.search(
                rf"{struck_label}\b[^.]{{0,60}}\bstopped|stopped {struck_label}", text, re.I)
            if stopped:
                add("CVC_22350", "unsafe_speed", vehicle.role,
                    f"{label} struck the stopped {struck_label} from behind: too fast for the traffic ahead.",
                    _around(text, match))
            else:
                add("CVC_21703", "following_too_closely", vehicle.role,
                    f"{label} struck the moving {struck_label} from behind.", _around(text, match))
            break


# ---------------------------------------------------------------- summary


def _summary(state: _State, road: dict, actors: dict) -> str:
    parts = []
    for role, actor in actors.items():
        vehicle = state.vehicles[actor["label"]]
        direction = f"{vehicle.direction}bound " if vehicle.direction else ""
        parts.append(f"{direction}{actor['label']} ({actor['behavior'].replace('_', ' ')})")
    where = {"intersection": "at a 4-leg intersection", "t_intersection": "at a 3-leg junction",
             "curve": "on a curve", "straight": "on a straight road"}[road["road_type"]]
    return _quote(f"Rule-based extraction: {', '.join(parts)} {where}.", 300)
