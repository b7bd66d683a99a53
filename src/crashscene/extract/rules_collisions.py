"""Rules extractor: the crash sequence (`collisions`, dsl.md convention 11) from the narrative's impact formulas.

NHTSA narratives state each contact with a small set of formulas: "the front of V2 struck the right side
of V1", "V3's frontal plane struck V4's back plane", "V2 ... struck the rear plane of V1 with its frontal
plane (Event 2)", "the right plane of V1 was struck by the front plane of V3", "causing the front of V2 to
strike the front of V1", "V1 and V2 collided head-on", "V1 was pushed into V3". Each formula gives the
striking and the struck vehicle and, when stated, the touching areas; a class word ("head-on",
"sideswipe", "T-type", "rear-end", "front-to-rear") or else the two areas give the class. Areas the
text leaves out follow from the travel directions (a vehicle crossing from the striker's left is hit on
its right side). Contacts with objects name no second vehicle and are not listed. Order: text order, or
the "(Event N)" numbers when every contact carries one; a contact restated later is merged into the
first statement of it.

Rules written from the impact sentences of the development folds (issue 11 record: 100237, 100343,
103341, 103378, 108812, 109176, 117330, 119489, 119897, 120013, 121520, 3-C1-2018-003, 3-C1-2018-007,
3-C1-2018-010, 3-C1-2018-012, 3-C2-2017-004, 3-C4-2017-007, 3-C4-2018-010, 3-C4-2018-012, 3-C5-2018-004);
every formula below occurs in at least two of them.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

from crashscene.extract.narrative import COMPASS, clip, label_at
from crashscene.extract.rules_state import RulesState

_PART = (r"(?:left|right|front|frontal|rear|back|side|sides|plane|end|corner|area|bumper|quarter|panel|doors?|"
         r"fender|hood|tail|driver'?s?|passenger'?s?)")
AREA = rf"{_PART}(?:[\s-]+{_PART}){{0,4}}"
# "the left side of V1", "the rear of a parked Corolla (V2)", "the rear of V4 trailer"
_AREA_OF = rf"(?:the\s+)?(?P<area>{AREA})\s+of\s+(?:(?:a|an|the)\s+[^.()]{{0,60}}?\(\s*)?(?P<label>V[1-9])\b"
_POSSESSIVE = rf"(?P<label>V[1-9])'s?\s+(?P<area>{AREA})"
_BARE = r"(?P<label>V[1-9])\b"
_SPEC_VERBS = r"struck|strikes?|striking|sideswiped"  # dsl.md convention 11's formula ("the front of V2 struck ...")
_MORE_VERBS = (r"impacted|impacting|contacted|contacting|hit|hitting|rear-ended|collided\s+with|crashed\s+into|"
               r"ran\s+into")  # read in the reports
# dsl.md's class token rear_end as a verb, up to hyphenation and inflection ("V1 rear-ended V2", "was rear-ended by")
_REAR_END_VERB = r"rear[- ]end(?:ed|ing|s)"
_VERB = rf"\b(?:{_SPEC_VERBS}|{_MORE_VERBS})\b"
_CLASS_WORDS = (
    ("head_on", r"head[- ]on|offset[- ]frontal|frontal[- ](?:to[- ]frontal|offset)|front[- ]to[- ]front"),
    ("rear_end", r"rear[- ]end(?:ed)?|front[- ]to[- ](?:rear|back)"),
    ("sideswipe", r"sideswip\w*|side[- ]to[- ]side"),
    ("angle", r"\b[TL][- ](?:type|bone)|broadside|\bangle[ds]?\b|\boblique"),
)
_EVENT = r"\(\s*events?\s+(\d+)"
_PUSHED = r"\b(?:caus\w+|push\w*|forc\w+|redirect\w*|propell\w+|result\w*\s+in)\b"
_LEAVING_LANE = ("cross_centerline", "overtake", "lose_control", "leave_road", "change_lane_left",
                 "change_lane_right", "turn_left", "turn_right", "u_turn")


@dataclass
class Side:
    """The touching area of one vehicle as the text states it."""

    label: str
    words: str = ""  # the stated area phrase, "" when none

    def parts(self) -> tuple[str | None, str | None, bool]:
        """(front|rear|None, left|right|None, whether a side without a named side is stated)."""
        words = self.words.lower()
        end = "rear" if re.search(r"\b(?:rear|back|tail)\b", words) else (
            "front" if re.search(r"\b(?:front|frontal|hood)\b", words) else None)
        side = "left" if re.search(r"\b(?:left|driver)", words) else (
            "right" if re.search(r"\b(?:right|passenger)", words) else None)
        return end, side, bool(re.search(r"\bsides?\b", words))


@dataclass
class Contact:
    """One contact between two vehicles, as read from one impact sentence."""

    striking: Side
    struck: Side
    position: int  # in the narrative text
    quote: str
    event: int | None = None
    class_word: str | None = None
    pushed: bool = False  # the striker was propelled into it by an earlier impact
    again: bool = False  # the text says it is a further contact ("again", "a second time")
    guessed: bool = False  # the text names the pair but not who struck whom ("V1 and V2 collided")
    areas: dict[str, str] = field(default_factory=dict)


def decide_collisions(state: RulesState, actors: dict) -> list[dict]:
    """The `collisions` list: every contact between two actors, first harmful event first; `[]` when the
    narrative states no contact between two vehicles."""
    roles = {vehicle.label: vehicle.role for vehicle in state.vehicles.values()}
    contacts = [c for c in _contacts(state) if c.striking.label in roles and c.struck.label in roles
                and c.striking.label != c.struck.label]
    if state.uses("rules_collisions.event_numbers_and_merge"):
        contacts = _merge(contacts)
        if contacts and all(c.event is not None for c in contacts):
            contacts.sort(key=lambda c: (c.event, c.position))
    out = []
    for index, contact in enumerate(contacts):
        rotated = index > 0 and _rotating(state.t.text, contacts[0].position, contact.position)
        config = _configuration(state, actors, contact.striking.label, contact.struck.label, rotated)
        corners = state.uses("rules_collisions.corner_by_configuration")
        striking_area = _area(contact.striking, "striking", config, corners)
        struck_area = _area(contact.struck, "struck", config, corners)
        if contact.class_word == "head_on":
            striking_area, struck_area = "front", "front"
        elif contact.class_word == "rear_end" and not contact.struck.words:
            striking_area, struck_area = "front", "rear"
        cls = contact.class_word or _class(striking_area, struck_area, contact)
        contact.areas = {"striking": striking_area, "struck": struck_area}
        out.append({"striking": roles[contact.striking.label], "struck": roles[contact.struck.label],
                    "striking_area": striking_area, "struck_area": struck_area, "class": cls})
        state.note(f"collisions[{index}]", contact.quote)
    state.contacts = contacts
    return out


# ---------------------------------------------------------------- reading the impact sentences


def _contacts(state: RulesState) -> list[Contact]:
    text = state.t.text
    found: list[Contact] = []
    verbs = [_SPEC_VERBS] if state.uses("rules_collisions.spec_impact_formula") else []
    if state.uses("rules_collisions.impact_formula"):
        verbs.append(_MORE_VERBS)
    elif state.uses("rules_collisions.rear_end_as_a_verb"):
        verbs.append(_REAR_END_VERB)  # split from impact_formula's verbs: the class token, inflected
    with_its = state.uses("rules_collisions.possessive_and_with_its")
    # "V3's frontal plane struck V4's back plane": convention 11's formula with the genitive (split from with_its)
    possessive = with_its or state.uses("rules_collisions.genitive_impact_formula")
    # "The impact pushed V1 forward": the noun names the first contact again, not a new one. Switched off, the
    # noun is read again as the first round read it: with the reports' other verbs (impact_formula), never with
    # convention 11's own formula alone
    if state.uses("rules_collisions.impact_formula") and not state.uses("rules_collisions.noun_impact_is_not_a_contact"):
        verbs.append(r"impacts?")  # the noun too: the switched-off form of one rule
    for match in re.finditer(rf"\b(?:{'|'.join(verbs)})\b", text, re.I) if verbs else ():
        contact = _active_or_passive(text, match, possessive, with_its)
        if contact is not None:
            found.append(contact)
    two = len(state.vehicles) == 2 and state.uses("rules_collisions.the_two_vehicles_collided")
    pair = r"(?:the\s+two|both)\s+vehicles" if two else r"(?!)"
    collided = state.uses("rules_collisions.collided_head_on_at_fault")
    for match in () if not collided else re.finditer(rf"\b(?:(V[1-9])\s+and\s+(V[1-9])|{pair})\s+"
                                                     r"(?:then\s+|subsequently\s+)?"
                             r"(?:collided|crashed)\b(?!\s+with)", text, re.I):
        first, second = (match.group(1), match.group(2)) if match.group(1) else ("V1", _second(state))
        striker, struck = _at_fault_first(state, first, second)
        contact = _finish(text, match, Side(striker), Side(struck), match.end())
        contact.guessed = True
        found.append(contact)
    if not found and state.uses("rules_collisions.noun_only_contact"):  # "a head-on collision with V2"
        for match in re.finditer(r"\b(?:collision|crash|impact)\s+(?:with|between)\s+(?:the\s+)?(V[1-9])\b"
                                 r"(?:\s+and\s+(V[1-9]))?", text, re.I):
            first = match.group(2) and match.group(1) or label_at(text, match.start()) or "V1"
            second = match.group(2) or match.group(1)
            if first == second:
                continue
            striker, struck = _at_fault_first(state, first, second) if collided else (first, second)
            contact = _finish(text, match, Side(striker), Side(struck), match.end())
            contact.guessed = True
            found.append(contact)
    which = r",\s*(?:which|that)" if state.uses("rules_collisions.which_was_pushed_into") else r"(?!)"
    for match in re.finditer(rf"\b(V[1-9])(?:{which})?\s+(?:was|were)\s+(?:then\s+)?"
                             r"(?:pushed|propelled|redirected|forced)\s+"
                             r"(?:\w+\s+){0,4}?into\s+(?:the\s+(?:rear|back|side|front)\s+of\s+)?(V[1-9])\b",
                             text, re.I):
        contact = _finish(text, match, Side(match.group(1)), Side(match.group(2)), match.end())
        contact.pushed = True
        found.append(contact)
    found.sort(key=lambda c: c.position)
    return found


def _active_or_passive(text: str, verb: re.Match, possessive: bool = True, with_its: bool = True) -> Contact | None:
    """The contact an impact verb states, or None when it names no second vehicle (a pole, a tree)."""
    start = max(text.rfind(". ", 0, verb.start()) + 2, 0)
    head = text[start:verb.start()]
    if re.search(r"\b(?:avoid(?:ed)?|prevent\w*|without)\s+(?:\w+\s+)?$", head, re.I) and not re.search(
            r"(?:could not|couldn't|unable to|failed to|did not|was not able to)\s+(?:\w+\s+){0,2}avoid\w*\s+"
            r"(?:\w+\s+)?$", head, re.I):
        return None
    tail_end = text.find(". ", verb.end())
    tail = text[verb.end(): tail_end if tail_end >= 0 else len(text)]
    passive = re.search(r"\b(?:was|were|been|being|is)\s+(?:then\s+|subsequently\s+|also\s+)?$", head, re.I)
    if passive:
        by = re.search(r"\bby\s+(?:the\s+)?", tail[:120], re.I)
        if by is None:
            return None
        striker, _ = _first_vehicle(tail[by.end():by.end() + 120], possessive=possessive)
        struck = _subject(text, start, verb.start(), possessive)
        if striker is None or struck is None:
            return None
        area = re.match(rf"\s*(?:in|on|at)\s+(?:the\s+|its\s+)?(?P<area>{AREA})", tail, re.I)
        if area and not struck.words:
            struck.words = area.group("area")
        return _finish(text, verb, striker, struck, verb.end() + by.end())
    struck, struck_end = _first_vehicle(tail[:140], clause=True, possessive=possessive)
    if struck is None:
        return None
    striker = _subject(text, start, verb.start(), possessive)
    if striker is None:
        return None
    rest = tail[struck_end:200]
    with_area = re.search(rf"\bwith\s+(?:its|his|her|the)\s+(?P<area>{AREA})(?:\s+of\s+(?P<label>V[1-9]))?", rest,
                          re.I)
    if with_its and with_area and (with_area.group("label") in (None, striker.label)) and not striker.words:
        striker.words = with_area.group("area")
    contact = _finish(text, verb, striker, struck, verb.end())
    contact.pushed = bool(re.search(_PUSHED + r"[^.]{0,40}$", head[-60:], re.I))
    return contact


def _first_vehicle(text: str, clause: bool = False, possessive: bool = True) -> tuple[Side | None, int]:
    """The first vehicle the phrase names, with its stated area ('the left side of V1', "V2's rear", 'V2'),
    and where its phrase ends."""
    if clause:  # the object ends where the next clause starts
        cut = re.search(r"[;]|,\s*(?:and|but|causing|which|where|before|after|while|then)\b|\b(?:causing|which|"
                        r"where|before|after|while|when|resulting)\b", text, re.I)
        text = text[:cut.start()] if cut else text
    best = None
    for pattern in (_AREA_OF, _POSSESSIVE, _BARE) if possessive else (_AREA_OF, _BARE):
        match = re.search(pattern, text, re.I)
        if match and (best is None or match.start() < best.start()):
            best = match
    if best is None:
        return None, 0
    if clause and re.match(r"[^V]{0,40}\b(?:path|lane|direction)\s+of\s*$", text[:best.start()], re.I):
        return None, 0  # "into the path of V3": a movement, not a contact
    area = best.groupdict().get("area") or ""
    if not area:
        after = re.match(rf"\s*(?:in|on|at)\s+(?:the\s+|its\s+)(?P<area>{AREA})", text[best.end():], re.I)
        area = after.group("area") if after and re.search(r"left|right|front|rear|back", after.group("area"), re.I) \
            else ""
    return Side(best.group("label").upper(), area), best.end()


def _subject(text: str, start: int, verb_start: int, possessive: bool = True) -> Side | None:
    """The striker: an area phrase right before the verb ('the front of V2 struck', "V3's frontal plane
    subsequently struck", 'causing the front of V2 to strike'), else the acting vehicle of the clause."""
    head = text[start:verb_start]
    glue = r"\s+(?:(?:then|subsequently|also|to|again|first|initially|partially|was|were|been|being|is|had)\s+)*$"
    for pattern in (_AREA_OF, _POSSESSIVE) if possessive else (_AREA_OF,):
        match = re.search(pattern + glue, head, re.I)
        if match:
            return Side(match.group("label").upper(), match.group("area"))
    label = label_at(text, verb_start)
    return Side(label) if label else None


def _finish(text: str, match: re.Match, striker: Side, struck: Side, tail_from: int) -> Contact:
    """A contact with its event number, class word and further-contact flag read from the rest of its clause."""
    sentence_start = text.rfind(". ", 0, match.start()) + 2
    end = text.find(". ", tail_from)
    end = len(text) if end < 0 else end
    nxt = re.search(_VERB, text[tail_from:end], re.I)
    tail = text[tail_from: tail_from + nxt.start() if nxt else end]
    event = re.search(_EVENT, tail, re.I) or re.search(_EVENT, text[tail_from:end], re.I)
    scope = text[sentence_start: tail_from + len(tail)]
    class_word = next((token for token, pattern in _CLASS_WORDS if re.search(pattern, scope, re.I)), None)
    again = bool(re.search(r"\bagain\b|\bsecond(?:ary)? (?:time|impact|contact|collision)|\bre-?contact", scope,
                           re.I))
    quote = clip(text[max(sentence_start, match.start() - 80): min(end + 1, tail_from + 120)])
    return Contact(striker, struck, match.start(), quote, int(event.group(1)) if event else None, class_word,
                   again=again)


def _second(state: RulesState) -> str:
    """The other vehicle of a two-vehicle report."""
    return next(label for label in state.vehicles if label != "V1")


def _at_fault_first(state: RulesState, first: str, second: str) -> tuple[str, str]:
    """'V1 and V2 collided': the vehicle whose manoeuvre left its lane strikes, else the first named."""
    one, two = state.vehicles.get(first), state.vehicles.get(second)
    if one and two and two.behavior in _LEAVING_LANE and one.behavior not in _LEAVING_LANE:
        return second, first
    return first, second


def _merge(contacts: list[Contact]) -> list[Contact]:
    """One entry per contact: a pair stated again (same or no event number, not 'again') fills the first."""
    kept: list[Contact] = []
    for contact in contacts:
        pair = {contact.striking.label, contact.struck.label}
        same = next((k for k in kept if {k.striking.label, k.struck.label} == pair and not contact.again and (
            k.event is None or contact.event is None or k.event == contact.event)), None)
        if same is None:
            kept.append(contact)
            continue
        if same.guessed and not contact.guessed:  # a later formula says who struck whom
            same.striking, same.struck, same.guessed = contact.striking, contact.struck, False
        elif same.striking.label == contact.striking.label:
            same.striking.words = same.striking.words or contact.striking.words
            same.struck.words = same.struck.words or contact.struck.words
        same.class_word = same.class_word or contact.class_word
        same.event = same.event if same.event is not None else contact.event
    return kept


# ---------------------------------------------------------------- areas and class


def _rotating(text: str, first: int, position: int) -> bool:
    """Whether the text between the first contact and this one has a vehicle rotating or spinning."""
    return bool(re.search(r"\brotat\w+|\bspun\b|\bspinning\b|\byaw\w*", text[first:position], re.I))


def _heading_angle(state: RulesState, actors: dict, label: str) -> int | None:
    """The vehicle's travel direction [deg], compass when stated, else from its heading relative to V1."""
    vehicle = state.vehicles[label]
    if vehicle.direction is not None and state.vehicles["V1"].direction is not None:
        return COMPASS[vehicle.direction]
    if vehicle.role == "ego":
        return 0
    heading = actors.get(vehicle.role, {}).get("position", {}).get("heading")
    return {"same_direction": 0, "opposite_direction": 180, "from_left": 90, "from_right": 270}.get(heading)


def _configuration(state: RulesState, actors: dict, striker: str, struck: str, rotated: bool) -> str:
    """same | opposite | from_left | from_right: where the struck vehicle comes from as the striker travels."""
    a, b = _heading_angle(state, actors, striker), _heading_angle(state, actors, struck)
    if a is None or b is None:
        return "crossing" if rotated else "same"
    delta = (b - a) % 360
    turning = any(state.vehicles[x].behavior in ("turn_left", "turn_right", "u_turn") for x in (striker, struck))
    if delta == 0:
        return "crossing" if rotated else "same"
    if delta == 180:
        return "crossing" if rotated or turning else "opposite"
    return "from_left" if delta == 90 else "from_right"  # struck travels to the striker's right: it came from its left


def _area(side: Side, role: str, config: str, corners: bool = True) -> str:
    """The area token for a stated phrase (corners resolved by the configuration) or the configuration's default."""
    end, lateral, generic = side.parts()
    crossing = config in ("crossing", "from_left", "from_right")
    if end and lateral:
        return lateral if role == "struck" and crossing and corners else end
    if end or lateral:
        return end or lateral
    if role == "striking":
        return "front"
    if config == "from_left":
        return "right"
    if config == "from_right":
        return "left"
    if generic or config == "crossing":
        return "left"
    return "front" if config == "opposite" else "rear"


def _class(striking: str, struck: str, contact: Contact) -> str:
    """rear_end, head_on, angle or sideswipe from the two areas (dsl.md section 3)."""
    ends = {"front", "rear"}
    if striking in ends and struck in ends:
        return "head_on" if striking == struck == "front" else "rear_end"
    if striking not in ends and struck not in ends:
        return "sideswipe"
    corner = any(re.search(r"corner", s.words, re.I) for s in (contact.striking, contact.struck))
    if striking not in ends and corner:
        return "sideswipe"  # a side along a corner: glancing
    return "angle"
