"""Rules extractor: the road network of V1's roadway (dsl.md conventions 2, 3, 5, 6): junction or curve,
directions and through lanes, centre marking, traffic control devices and the posted limit.
"""
from __future__ import annotations

import re

from crashscene.extract.narrative import (
    COMPASS,
    DIR,
    around,
    label_after,
    label_at,
)
from crashscene.extract.rules_lanes import count_lanes
from crashscene.extract.rules_state import RulesState, has_cross_traffic
from crashscene.extract.sketch import CURVED_DOUBLE, EDGE_ONLY
from crashscene.units import KMH_PER_MPH


def decide_road_network(state: RulesState) -> dict:
    """The `road_network` mapping; records which vehicles' approaches are stop- or yield-controlled on `state`."""
    road_sentences = [s for s in state.t.sentences if re.search(r"\b(?:road|roadway|highway|freeway|interstate|street|"
                                                          r"trafficway|lanes?|route|avenue|ramp)\b", s, re.I)]
    road_text = " ".join(road_sentences)
    sketch_text = " ".join(state.fact_texts("text: "))
    # convention 3: "a divided roadway (median or barrier)"
    divided_pattern = r"\bdivided\b(?! by (?:a )?(?:double|painted|yellow))|\bmedian\b|" \
                      r"\b(?:concrete|jersey|cable|median) barrier"
    if not state.uses("rules_road.divided_roadway"):
        divided_pattern = r"(?!)"
    if state.uses("rules_road.freeway_is_divided"):
        divided_pattern += r"|interstate|\bfreeway\b"
    if state.uses("rules_road.separated_by_a_barrier"):
        # dsl.md section 3's "seven lanes separated by a barrier", convention 3's "divided roadway (median or
        # barrier)": the directions separated by a barrier or median, whatever qualifies it
        divided_pattern += r"|\bseparat(?:ed|ing)\b[^.]{0,60}?\bby (?:an?|the) (?:[\w-]+ ){0,3}?(?:barrier|median)\b"
    if state.uses("rules_road.divided_by_a_line_is_not_divided"):
        # "a two-way road divided by a solid yellow line": a painted line divides the directions, not a median
        divided_pattern = divided_pattern.replace("(?! by (?:a )?(?:double|painted|yellow))", _BY_A_LINE)
    not_divided = r"\bnon-?divided|\bundivided|not divided"
    if state.uses("rules_road.centre_turn_lane_is_not_divided"):
        not_divided += r"|(?:center|centre|middle) (?:two-way )?(?:left[- ])?turn(?:ing)? lane"
    sketch_median = state.uses("rules_road.sketch_median") and re.search(r"\bmedian\b", sketch_text, re.I)
    state.divided = bool(re.search(divided_pattern, road_text, re.I) or sketch_median) \
        and not re.search(not_divided, road_text, re.I)
    if state.divided:
        match = re.search(divided_pattern, road_text, re.I)
        state.note("road_network.number_of_ways", around(road_text, match) if match else "sketch: median")
    if state.uses("rules_road.traffic_control_words"):
        _traffic_controls(state)
    road_type, curve_direction = _road_type(state)
    if road_type in ("intersection", "t_intersection"):
        if state.uses("rules_road.sketch_devices"):
            _sketch_devices(state)
        _attribute_signs(state)
    ways = _ways(state, road_text)
    lanes = count_lanes(state, road_text, ways)
    speed = _speed_limit(state) if state.uses("rules_road.posted_limit") else None
    marker = _marker(state, road_text, ways)
    if road_type not in ("intersection", "t_intersection") and \
            state.uses("rules_road.junction_devices_only_at_a_junction"):
        # convention 6: a stop sign, yield sign or signal away from the crash's junction controls no involved approach
        dropped = state.signs & {"stop_sign", "yield_sign", "traffic_light"}
        if dropped:
            state.signs -= dropped
            state.evidence.pop("road_network.traffic_signs", None)
            state.note("road_network.traffic_signs", f"no junction in the crash: {', '.join(sorted(dropped))} left out")
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


def _traffic_controls(state: RulesState) -> None:
    """Signals, stop and yield signs the text names, and whose approach each sign controls."""
    text = state.t.text
    state.no_controls = bool(re.search(r"\b(?:without|no|not controlled by any) (?:any )?traffic control|"
                                       r"\buncontrolled\b|no traffic control devices|no controls", text, re.I))
    signal = re.search(r"traffic (?:signal|light|control signal)s?|\bsignali[sz]ed\b|tri-colou?red|"
                       r"\b(?:red|green|amber|yellow) (?:light|signal|arrow)\b|signal[- ]controlled|"
                       r"controlled by (?:overhead|traffic) signals?|\bsignals?\b(?= (?:at|for|controlling))",
                       text, re.I)
    flashes = list(re.finditer(r"flashing (red|yellow|amber)", text, re.I))
    flashing = flashes[0] if flashes else None
    if signal and not (flashing and signal.start() >= flashing.start() - 5):
        state.signs.add("traffic_light")
        state.note("road_network.traffic_signs", around(text, signal))
    if not state.uses("rules_road.every_flashing_signal"):
        flashes = flashes[:1]
    for flash in flashes:  # a flashing red is a stop sign for the approach it faces (convention 6)
        if flash.group(1).lower() != "red":
            continue
        state.signs.add("stop_sign")
        state.note("road_network.traffic_signs", around(text, flash))
        label = label_at(text, flash.start())
        if label and len(flashes) > 1:  # "V2 faced a flashing red" while V1's approach flashes yellow
            state.stop_controlled.add(label)
    for match in re.finditer(r"\bstop[- ]sign|\bstop[- ]controlled|\bstop(?:ped)? (?:bar|line)|all[- ]way stop|"
                             r"\b(?:two|four|2|4)[- ]way stop", text, re.I):
        state.signs.add("stop_sign")
        state.note("road_network.traffic_signs", around(text, match))
        sentence = next((x for x in state.t.sentences if match.group(0) in x and re.search(
            re.escape(text[max(0, match.start() - 20):match.end()]), x)), "")
        approach = re.search(rf"\b{DIR}bound\s+(?:roadway|road|approach|lanes?|traffic|leg|direction)", sentence, re.I)
        if approach:
            state.stop_controlled.update(v.label for v in state.vehicles.values()
                                         if v.direction == approach.group(1).lower())
            continue
        label = label_at(text, match.start()) or label_after(text, match.end())
        if label:
            state.stop_controlled.add(label)
    for match in re.finditer(r"\byield(?:[- ]sign| controlled)|\byield\b(?= to)", text, re.I):
        if re.search(r"\byield[- ]sign|yield controlled", match.group(0), re.I):
            state.signs.add("yield_sign")
            state.note("road_network.traffic_signs", around(text, match))
            label = label_at(text, match.start())
            if label:
                state.yield_controlled.add(label)


def _sketch_devices(state: RulesState) -> None:
    """Devices read on the sketch of a junction that crossing traffic uses (text wins when it names controls)."""
    if state.no_controls or state.signs or not has_cross_traffic(state):
        return
    for fact, sign in (("stop sign", "stop_sign"), ("yield sign", "yield_sign"), ("traffic signal", "traffic_light"),
                       ("flashing red signal", "stop_sign")):
        if state.fact_texts(fact):
            state.signs.add(sign)
            state.note("road_network.traffic_signs", f"sketch: {fact}")


# issue 11's "failed to stop", "failed to yield"; dsl.md convention 8's "stopped at a sign"
_SIGN_STATED = r"(?:fail(?:ed|ing|s)? to (?:yield|stop)|\bstopped (?:at|for) the (?:stop|yield) sign)\b"
_YIELDED = (r"(?:fail(?:ed|ing|s)? to (?:yield|stop|obey|observe)|did not (?:yield|stop|see|observe)|"
            r"\bstopped (?:at|for) the (?:stop|yield)|without (?:stopping|yielding)|(?:ran|disregarded) the)\b")


def _attribute_signs(state: RulesState) -> None:
    """Which approaches an unattributed stop or yield sign controls: an all-way stop controls every one; else
    the vehicle the text says failed to yield or stop (or stopped at the sign); else the vehicle whose label
    the sketch draws nearest to the sign; else V1's (dsl.md section 3: a device no actor names controls the
    ego's approach). Two switches: the spec's words (`sign_controls_by_the_spec`: all-way stops, issue 11's
    'failed to stop/yield', 'stopped at the stop sign', V1 by default) and the rest, written from the reports
    (`attribute_signs`: 'four-way stop', 'did not yield', 'ran the', the sketch's nearest label)."""
    spec = state.uses("rules_road.sign_controls_by_the_spec")
    more = state.uses("rules_road.attribute_signs")
    if not (spec or more):
        return
    text = state.t.text
    all_way = (r"all[- ]way stop" if spec else r"(?!)") + (r"|\b(?:four|4)[- ]way stop" if more else "")
    if "stop_sign" in state.signs and re.search(all_way, text, re.I):
        state.stop_controlled.update(state.vehicles)
    sequence = state.pre_crash + " " + state.crash_sentence
    for sign, controlled in (("stop_sign", state.stop_controlled), ("yield_sign", state.yield_controlled)):
        if sign not in state.signs or controlled:
            continue
        for match in re.finditer(_YIELDED if more else _SIGN_STATED, sequence, re.I):
            label = label_at(sequence, match.start())
            if label in state.vehicles:
                controlled.add(label)
                break
        else:
            label = (_nearest_label(state, sign.replace("_", " ")) if more else None) or ("V1" if spec else None)
            if label:
                controlled.add(label)


def _nearest_label(state: RulesState, fact: str) -> str | None:
    """The vehicle whose sketch label is drawn nearest to a sketch fact (a sign), when both have positions."""
    def centre(box: tuple[int, int, int, int]) -> tuple[float, float]:
        return (box[0] + box[2]) / 2, (box[1] + box[3]) / 2

    signs = [centre(f.bbox) for f in state.facts if f.text == fact and f.bbox]
    labels = [(f.text.rsplit(" ", 1)[-1], centre(f.bbox)) for f in state.facts
              if f.text.startswith("vehicle label ") and f.bbox]
    pairs = [((sx - lx) ** 2 + (sy - ly) ** 2, label) for sx, sy in signs for label, (lx, ly) in labels
             if label in state.vehicles]
    if not pairs:
        return None
    label = min(pairs)[1]
    state.note("road_network.traffic_signs", f"sketch: {fact} drawn nearest to {label}'s label")
    return label


_BY_A_LINE = (r"(?! by (?:a |an |the )?(?:(?:double|single|solid|broken|dashed|painted|yellow|white|"
              r"cent(?:er|re)|skip)[- ]?)+(?:lines?|stripes?|markings?))")


_FOUR_LEGS = re.compile(r"\b(?:4|four)[- ]leg(?:ged)?\b|\bfour[- ]way intersection|\bcross(?:roads| intersection)",
                        re.I)
_THREE_LEGS = re.compile(r"\b(?:3|three)[- ]leg(?:ged)?\b|\bT[- ]intersection|\bT-type intersection|\bTee\b|"
                         r"\bT[- ]junction|driveway|business (?:access|entrance|exit)|parking lot (?:exit|entrance)|"
                         r"(?:private|commercial) (?:drive|road)\b", re.I)
_ACCESS = re.compile(r"driveway|business|parking|private|commercial drive", re.I)


def _road_type(state: RulesState) -> tuple[str, str | None]:
    """Where V1's first harmful event happens (convention 2): a junction the pre-crash text takes part in
    (4 legs unless 3 are stated, or a vehicle comes out of a driveway), else a curve named there, else straight.
    Returns the road type and the curve's side as V1 sees it."""
    text = state.t.text
    # "warning signs for an intersection ahead" names a junction that plays no part
    pre = state.pre_crash + " " + state.crash_sentence
    if state.uses("rules_road.junction_ahead_plays_no_part"):
        pre = re.sub(r"[^.]*\b(?:intersection|junction) ahead\b[^.]*", " ", pre, flags=re.I)
    legs_stated = state.uses("rules_road.leg_words")  # convention 2: 4 legs; 3 legs, a driveway or business access
    four = _FOUR_LEGS.search(text) if legs_stated else None
    three = _THREE_LEGS.search(text) if legs_stated else None
    if state.uses("rules_road.a_junction_some_distance_away_plays_no_part"):
        # "approximately 100 meters south of an intersection": the junction only locates the crash
        pre = re.sub(r"\b\d+(?:\.\d+)?\s*(?:m|meters?|metres?|ft|feet|yards?|miles?|km)\b\s+(?:\w+\s+){0,2}?"
                     r"(?:of|from|before|past|beyond)\s+(?:an?|the)\s+(?:[\w-]+\s+){0,2}?(?:intersection|junction)",
                     " ", pre, flags=re.I)
    junction = re.search(r"\bintersection\b|\bjunction\b|\bintersecting\b", pre, re.I) \
        if state.uses("rules_road.junction_words") else None
    turns_in = re.search(rf"\b(?:into|onto|to enter)\s+(?:a |the |an )?{_DRIVEWAY}", pre, re.I)
    from_access = bool(three and _ACCESS.search(three.group(0)) and (driveway_vehicle(state) is not None or turns_in))
    if not from_access and driveway_vehicle(state) is not None and \
            state.uses("rules_road.leaving_an_access_is_a_junction"):
        # "exiting a parking lot", "pulled out of a private drive": the access is the third leg (convention 2)
        three, from_access = re.search(_DRIVEWAY, text, re.I), True
    legs = None
    if from_access or (junction and three and not four and not _ACCESS.search(three.group(0))):
        legs = 3
        state.note("road_network.road_type", around(text, three))
    elif junction:
        legs = 4
        state.note("road_network.road_type", around(text, four) if four else around(pre, junction))
    curve = None
    bends = state.uses("rules_road.a_bend_is_a_curve")  # "a road that bends to the right"
    curve_match = re.search((r"\bcurv(?:e|es|ed|ing)\b" if state.uses("rules_road.curve_words") else r"(?!)")
                            + (r"|\bbend(?:s|ing)?\b" if bends else ""), pre, re.I)
    direction = None
    if curve_match:
        window = pre[max(0, curve_match.start() - 60):curve_match.end() + 40]
        side = re.search(r"\b(left|right)(?:-hand)?\s+curve|curve[sd]?\s+(?:to\s+the\s+)?(left|right)|"
                         r"curved\s+(?:to\s+the\s+)?(left|right)"
                         + (r"|\b(left|right)(?:-hand)?\s+bend|bend(?:s|ing)?\s+(?:to\s+the\s+)?(left|right)"
                            if bends else ""), pre, re.I)
        if side:
            direction = _as_ego_sees_it(state, pre, side, next(g for g in side.groups() if g).lower())
        if not (re.search(r"\bstraight\b[^.]{0,40}\bcurv|no curve", window, re.I) and
                state.uses("rules_road.straight_before_a_curve")):
            curve = "curve"
            state.note("road_network.road_type", around(pre, curve_match))
    if legs is not None:
        state.junction = "intersection" if legs == 4 else "t_intersection"
        return state.junction, direction
    if curve:
        # the curve must be V1's: a curve named only for another vehicle still puts the crash on it
        return "curve", direction
    match = re.search(r"\bstraight\b", text, re.I)
    state.note("road_network.road_type", around(text, match) if match else "no junction or curve in the crash sequence")
    return "straight", None


def _as_ego_sees_it(state: RulesState, text: str, match: re.Match, side: str) -> str:
    """A curve stated for another vehicle's direction of travel bends the other way for an oncoming ego."""
    start = max(text.rfind(". ", 0, match.start()), 0)
    end = text.find(".", match.end())
    sentence = text[start: end if end > 0 else len(text)]
    ego = state.vehicles["V1"]
    owner = re.search(r"\b(?i:for|in)\s+(V[1-9])\b|\b(V[1-9])'s\b", sentence)
    other = None
    if owner:
        other = state.vehicles.get(owner.group(1) or owner.group(2))
    stated = ""
    if state.uses("rules_road.curve_side_for_a_stated_direction"):  # "for southbound traffic the road curved left"
        stated = rf"|for {DIR}bound (?:traffic|vehicles|travel)"
    heading = re.search(rf"heading (?:{DIR} )?to(?:wards?)? (?:the )?{DIR}|in the {DIR}bound direction{stated}",
                        sentence, re.I)
    their_direction = other.direction if other and other.label != "V1" else None
    if heading:
        their_direction = next(g for g in heading.groups()[::-1] if g).lower()
    if their_direction and ego.direction and (COMPASS[their_direction] - COMPASS[ego.direction]) % 360 == 180:
        return "left" if side == "right" else "right"
    return side


_DRIVEWAY = r"(?:private |commercial |residential |business )?(?:driveway|drive\b|parking lot|business (?:access|" \
            r"entrance)|private road|alley)"


def driveway_vehicle(state: RulesState) -> str | None:
    """The vehicle that enters the road from a driveway, parking lot or business access, if one does."""
    if not state.uses("rules_road.driveway_exit"):
        return None
    text = state.pre_crash + " " + state.crash_sentence
    for match in re.finditer(rf"(?:from|out of|exit(?:ed|ing)?|leav(?:e|ing)|in the mouth of|pull(?:ed|ing)? out of)\s+"
                             rf"(?:of\s+)?(?:a |the |an )?{_DRIVEWAY}", text, re.I):
        label = label_at(text, match.start())
        if label:
            return label
    match = re.search(rf"{_DRIVEWAY}\s+that\s+(V[1-9])\s+was\s+(?:exiting|leaving|pulling out of)", text, re.I)
    return match.group(1) if match else None


def _ways(state: RulesState, road_text: str) -> int:
    """1 for a one-way or divided roadway (V1's carriageway), unless the crash crosses to the other one."""
    one_way = re.search(r"\bone[- ]way\b", road_text, re.I)
    if one_way:
        state.note("road_network.number_of_ways", around(road_text, one_way))
        return 1
    if state.divided and not _crosses_opposing(state):
        match = re.search(r"divided|median|barrier|interstate|freeway", road_text, re.I)
        where = around(road_text, match) if match else "sketch: median"  # a median drawn, not written
        state.note("road_network.number_of_ways", "divided roadway: V1's carriageway only; " + where)
        return 1
    return 2


def _crosses_opposing(state: RulesState) -> bool:
    """Whether the crash sequence uses the opposing carriageway (a turn across the median, a crossover)."""
    pre = state.pre_crash
    words = r"(?:[\w-]+ ){0,2}" if state.uses("rules_road.crossed_the_median_words") else ""  # "the grass median"
    return bool(re.search(rf"left[- ]turn|turn(?:ed|ing)? left|u[- ]turn|cross(?:ed|ing)? (?:over )?the {words}median|"
                          rf"across the {words}median|crossover", pre, re.I))


def _speed_limit(state: RulesState) -> int | None:
    """The posted limit [mph]: the text's mph figure, else its km/h rounded to 5 mph, else the sketch's."""
    text = state.t.text
    match = re.search(r"(?:speed\s+limit|posted\s+(?:speed|limit))[^.]{0,80}?(\d{2,3})\s*(?:mph|mi/h|miles per hour)",
                      text, re.I)
    if match:
        state.note("road_network.speed_limit_mph", around(text, match))
        return int(match.group(1))
    match = re.search(r"(?:speed\s+limit|posted)[^.]{0,60}?(\d{2,3})\s*(?:km/h|kmph|km/hr|kph)", text, re.I)
    if match:
        state.note("road_network.speed_limit_mph", around(text, match))
        return int(5 * round(int(match.group(1)) / KMH_PER_MPH / 5))
    match = re.search(r"(\d{2,3})\s*(?:mph|mi/h)\s+(?:speed limit|zone|posted)", text, re.I)
    if match:
        state.note("road_network.speed_limit_mph", around(text, match))
        return int(match.group(1))
    for prefix in ("speed limit ", "speed "):
        for fact in state.facts:
            found = re.fullmatch(rf"{prefix}(\d+) mph", fact.text)
            if found:
                where = "case XML" if fact.source == "nhtsa:xml" else "sketch"
                state.note("road_network.speed_limit_mph", f"{where}: {fact.text}")
                return int(found.group(1))
    return None


def _on_ego_road(state: RulesState, pattern: str, text: str, window: int = 10_000) -> re.Match | None:
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


# centre-line phrasings, in precedence order (convention 5)
MARKERS = (
    (r"double (?:solid )?(?:yellow )?(?:cent(?:er|re) ?)?lines?|solid double|double[- ]yellow|"
     r"(?:two|2) solid (?:yellow )?lines", "double_solid_line"),
    (r"two-way (?:center |centre )?left[- ]turn lane|center (?:two-way )?turn lane|\bTWLTL\b|"
     r"solid (?:and|with) (?:a )?broken|broken (?:and|with) (?:a )?solid", "solid_and_broken_line"),
    (r"(?:broken|dashed|skip) (?:yellow |white )?(?:cent(?:er|re) ?)?lines?", "broken_line"),
    (r"no (?:cent(?:er|re) ?line|pavement|lane) markings?|unmarked|unpaved|gravel road|dirt road", "none"),
    (r"single solid (?:yellow )?(?:cent(?:er|re) ?)?line|solid (?:yellow )?cent(?:er|re) ?line", "solid_line"),
)


# more centre-line phrasings (convention 5): a yellow line is a centre line in the US, white ones separate lanes
MORE_MARKERS = (
    # a "middle left-turn lane" at a junction is a turn bay, not a two-way left-turn lane
    (r"continuous (?:cent(?:er|re) )?(?:two-way )?left[- ]turn(?:ing)? lane|"
     r"two-way (?:cent(?:er|re) )?turn(?:ing)? lane",
     "solid_and_broken_line"),
    (r"(?:no|without (?:a|any)) (?:painted |marked )?(?:cent(?:er|re)[- ]?line|(?:lane |road |pavement )?markings?)\b|"
     r"(?:was|were) not (?:painted|marked|striped)", "none"),
    (r"(?:single )?solid yellow (?:cent(?:er|re) ?)?(?:line|stripe)", "solid_line"),
)


def _marker(state: RulesState, road_text: str, ways: int) -> str:
    """The centre line of V1's road: stated in the text, else written on the sketch, else divided (none),
    else drawn on the sketch, else not_mentioned."""
    text = state.t.text
    sketch_text = " ".join(state.fact_texts("text: "))
    markers = MARKERS if state.uses("rules_road.centre_line_words") else tuple((r"(?!)", t) for _, t in MARKERS)
    sketch_markers = markers
    if state.uses("rules_road.passing_zone"):  # a passing zone: a broken line beside the solid one
        markers = tuple((p + (r"|passing zone" if t == "solid_and_broken_line" else ""), t) for p, t in markers)
        sketch_markers = markers
    if state.uses("rules_road.marker_phrasings"):
        extra = {token: pattern for pattern, token in MORE_MARKERS}
        if state.junction is None:  # away from a junction a centre left-turn lane is a two-way one
            extra["solid_and_broken_line"] += r"|(?:cent(?:er|re)|middle) left[- ]turn(?:ing)? lane"
        markers = tuple((f"{pattern}|{extra[token]}" if token in extra else pattern, token)
                        for pattern, token in markers)
    if state.uses("rules_road.white_lines_separate_lanes"):  # a white line is a lane line, never the centre line
        markers = tuple((pattern.replace("(?:yellow |white )?", "(?:yellow )?(?!white)"), token)
                        for pattern, token in markers)
    for (pattern, token), (sketch_pattern, _) in zip(markers, sketch_markers):
        match = _on_ego_road(state, pattern, text)
        if match:
            state.note("road_network.road_marker", around(text, match))
            return token
        # a label on the sketch names no road: only the first round's phrasings are read there
        match = _on_ego_road(state, sketch_pattern, sketch_text, window=80)  # OCR lines: look back one line or so
        if match:
            state.note("road_network.road_marker", f"sketch: {match.group(0)}")
            return token
    if state.divided:
        state.note("road_network.road_marker", "divided roadway: no centre line on V1's carriageway")
        return "none"
    if ways == 2 and state.uses("rules_road.drawn_centre_line"):
        edge_only = bool(state.fact_texts(EDGE_ONLY)) and state.uses("rules_road.a_centre_line_lies_between_the_edges")
        drawn = [("double solid line drawn", "double_solid_line"), ("broken line drawn", "broken_line")]
        if state.uses("rules_road.a_curved_centre_line_in_short_runs"):
            drawn.insert(1, (CURVED_DOUBLE, "double_solid_line"))
        for fact, token in drawn:
            if state.fact_texts(fact) and not (token == "double_solid_line" and edge_only):
                state.note("road_network.road_marker", f"sketch: {fact}")
                return token
    return "not_mentioned"
