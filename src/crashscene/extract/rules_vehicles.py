"""Rules extractor, step 1: the vehicles (labels, roles, directions of travel, body types) and the
text before the first harmful event, which the behaviour rules read.
"""
from __future__ import annotations

import re

from crashscene.extract.errors import RulesError
from crashscene.extract.narrative import DIR, subject_of
from crashscene.extract.rules_state import RulesState, Vehicle, lane_side


_VEHICLE_WORDS = re.compile(r"\b(?:vehicles?|cars?|sedans?|coupes?|trucks?|pickups?|vans?|minivans?|SUVs?|bus(?:es)?|"
                            r"motorcycles?|tractor|trailer|drivers?|motorists?|crash(?:es|ed)?|collisions?)\b", re.I)


def find_vehicles(state: RulesState) -> None:
    """Every labelled vehicle (V1 always; only V1 in a single-vehicle crash), its direction, lane and body type."""
    text = state.t.text
    labels = sorted({int(n) for n in re.findall(r"\bV([1-9])\b", text)})
    if not labels and not _VEHICLE_WORDS.search(text):
        raise RulesError("no vehicle found in the narrative (no V1, V2 ... label and no word for a vehicle or its "
                         "driver); is this a crash report?", state.report.source)
    single = re.search(r"\bsingle[- ]vehicle\b|\bone[- ]vehicle\b", text, re.I)
    if single or not labels:
        labels = [1]
    if 1 not in labels:
        labels = [1, *labels]
    for index, number in enumerate(labels):
        label = f"V{number}"
        state.vehicles[label] = Vehicle(label=label, role="ego" if index == 0 else f"npc{index}")
    for label, vehicle in state.vehicles.items():
        if state.uses("rules_vehicles.travel_direction"):
            vehicle.direction, vehicle.lane_side = _direction_of(state, label)
        if state.uses("rules_vehicles.body_type"):
            vehicle.type = _type_of(state, label)


def subject_sentences(state: RulesState, label: str) -> list[str]:
    """Sentences (pre-crash first) whose grammatical subject is the vehicle."""
    out = []
    for sentence in state.t.sentences:
        subject = subject_of(sentence)
        if subject == label:
            out.append(sentence)
    return out


def _direction_of(state: RulesState, label: str) -> tuple[str | None, str | None]:
    """Travel direction and lane side: stated in a clause of its own ("V2, which was traveling south", "and V2
    was traveling west"), else from the first sentence the vehicle is the subject of."""
    clause_direction = None
    if state.uses("rules_vehicles.direction_in_any_clause"):
        # "struck the front of V2, which was traveling south", "V1 was traveling north and V2 was traveling east"
        match = re.search(rf"\b{label}\b\s*(?:\([^)]*\))?,?\s*(?:(?:which|that|who)\s+)?(?:was|had been)\s+"
                          rf"(?:travel+ing|driving|heading|proceeding|going)\s+{DIR}(?:bound|ward)?\b",
                          state.t.text, re.I)
        if match:
            clause_direction, clause = match.group(1).lower(), match.group(0)
    for sentence in subject_sentences(state, label):
        cut = re.split(r"\b(?:struck|strike|striking|impacted|collided)\b", sentence)[0]
        match = re.search(rf"(?:travel+ing|driven|heading|proceeding|going|traveled|travelled|was)\s+"
                          rf"(?:in\s+(?:a|an|the)\s+)?{DIR}(?:bound|ward)?\b", cut, re.I)
        if not match:
            match = re.search(rf"\b{DIR}bound\b|\bfacing\s+{DIR}\b", cut, re.I)
        if match:
            lane = re.search(r"\b(left|right|middle|center|far[- ]left|far[- ]right|inboard|outboard)\b[^.]{0,30}?"
                             rf"{DIR}bound\s+(?:travel\s+)?lane", cut, re.I)
            side = lane_side(lane.group(1).lower()) if lane and state.uses("rules_vehicles.lane_side") else None
            state.note(f"actors.{state.vehicles[label].role}.position", sentence)
            return clause_direction or next(g for g in match.groups() if g).lower(), side
    if clause_direction:
        state.note(f"actors.{state.vehicles[label].role}.position", clause)
    return clause_direction, None


# pickups, vans and SUVs are cars (dsl.md section 2 aliases: semi, tractor-trailer, bus, box truck -> truck); a
# named kind of truck is a truck
_TRUCK = (r"tractor|semi\b|semi-trailer|\bbus\b|box truck|dump truck|straight truck|delivery truck|garbage truck|"
          r"tow truck|fire truck|heavy truck|single[- ]unit truck|commercial truck")
_MORE_TRUCK = r"|motorcoach|cement|concrete mixer|flatbed|commercial vehicle|\bGVWR\b"  # read in the reports
_MOTORCYCLE = re.compile(r"motorcycle|motorbike|moped|scooter|\bHarley\b", re.I)


def _type_of(state: RulesState, label: str) -> str:
    """car, truck or motorcycle from the description beside the label (or the sketch's vehicle list)."""
    texts = []
    text = state.t.text
    # "V2, a 2002 Ford F150 pickup truck was ...", "V2 - 2001 Volvo", "a 2013 Freightliner tractor/trailer (V2)"
    after = re.search(rf"\b{label}\b\s*(?:\([^)]*\))?\s*[,:(-]\s*(?:the\s+|a\s+|an\s+)?([^.;]*?)"
                      rf"(?:\b(?:was|were|is|had|driven|traveling|travelling)\b|[.;]|$)", text)
    before = re.search(rf"(?:\b(?i:a|an|the)\s+|,\s*)([^.;()]{{3,80}}?)\s*\(\s*{label}\s*\)", text)
    for match in sorted((m for m in (after, before) if m), key=lambda m: m.start()):
        texts.append(match.group(1))
    texts += [t for t in state.fact_texts(f"vehicle {label}:")]
    truck = _TRUCK + (_MORE_TRUCK if state.uses("rules_vehicles.more_truck_words") else "")
    for descriptor in texts:
        if _MOTORCYCLE.search(descriptor):
            return "motorcycle"
        if re.search(truck, descriptor, re.I):
            state.note(f"actors.{state.vehicles[label].role}.type", descriptor)
            return "truck"
    return "car"


_IMPACT = re.compile(r"\b(?:struck|strikes?|striking|impacted|collided|hit)\b", re.I)
_SUMMARY_SENTENCE = re.compile(r"\b(?:crash|collision|case|investigation)\s+(?:involves|involved|focused)|"
                               r"primarily involved|sustained (?:a )?(?:frontal|side|moderate|serious)", re.I)


def split_pre_crash(state: RulesState) -> None:
    """Text before the first harmful event, without the summary lead and avoidance manoeuvres."""
    kept = []
    sentences = state.t.sentences
    for index, sentence in enumerate(sentences):
        if _SUMMARY_SENTENCE.search(sentence) and not re.search(r"\bV[1-9]\b.*\b(?:travel|driv|turn)", sentence) \
                and state.uses("rules_vehicles.summary_lead_is_not_the_sequence"):
            continue
        impact = _IMPACT.search(sentence)
        if impact:
            head = sentence[: impact.start()]
            kept.append(head)
            # "V2 struck V1 after V2 drifted across the centerline": the manoeuvre is told after the impact verb
            after = re.search(r"\b(?:after|as|when|while)\b\s+(?:the\s+driver\s+of\s+)?(?:V[1-9]|it|he|she)\b"
                              r"[^.;]*", sentence[impact.end():], re.I)
            if after and state.uses("rules_vehicles.manoeuvre_after_the_impact_verb"):
                kept.append(after.group(0))
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
    if not state.uses("rules_vehicles.avoidance_is_not_the_manoeuvre"):
        state.pre_crash = pre
        return
    pre = re.sub(r"(?:in an? )?(?:attempt(?:ed|ing)?|tried|trying)\s+to\s+avoid[^.;]*", " ", pre, flags=re.I)
    pre = re.sub(r"\bto avoid (?:a )?(?:collision|the crash|impact)[^.;]*", " ", pre, flags=re.I)
    pre = re.sub(r"\breacted by[^.;]*|[^.;,]*\b(?:in avoidance|as an avoidance|avoidance maneuver|evasive)[^.;]*", " ",
                 pre, flags=re.I)
    state.pre_crash = pre
