"""The working state of one rule-based extraction: vehicles as read so far, and the evidence.

`RulesState` is passed through the steps of `crashscene.extract.rules` (actors,
environment, road network, behaviours, positions, oracle), each step reading
what the previous ones decided.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from crashscene.extract.narrative import COMPASS, Narrative, clip
from crashscene.extract.case_input import Report
from crashscene.extract.rule_sources import known_rule
from crashscene.extract.sketch import SketchFact


# a direction's lanes from its left edge to its right: the values of Vehicle.lane_side, in order
LANE_SIDES = ("left", "middle", "right")


def lane_side(word: str) -> str:
    """The lane side a report's word names ("leftmost", "inboard", "center", ...): left, right or middle."""
    if "left" in word or word == "inboard":
        return "left"
    if "right" in word or word == "outboard":
        return "right"
    return "middle"


@dataclass
class Vehicle:
    """One labelled vehicle of the report as the rules read it."""

    label: str  # V1, V2, ...
    role: str  # ego, npc1, ...
    direction: str | None = None  # north|south|east|west
    lane_side: str | None = None  # left|right|middle lane of its direction
    type: str = "car"
    behavior: str = "go_forward"
    behavior_quote: str | None = None
    flags: set[str] = field(default_factory=set)  # every behaviour clue seen for it (e.g. a lane crossing)


@dataclass
class RulesState:
    """The report, its sketch facts and narrative, and what the steps decided so far."""

    report: Report
    facts: list[SketchFact]
    t: Narrative
    evidence: dict[str, str] = field(default_factory=dict)
    vehicles: dict[str, Vehicle] = field(default_factory=dict)
    pre_crash: str = ""
    crash_sentence: str = ""
    between: str = ""  # after the first impact, up to the next one: a manoeuvre leading to the second impact
    junction: str | None = None  # intersection | t_intersection
    divided: bool = False
    signs: set[str] = field(default_factory=set)
    stop_controlled: set[str] = field(default_factory=set)  # labels whose approach has a stop sign
    yield_controlled: set[str] = field(default_factory=set)
    no_controls: bool = False
    contacts: list = field(default_factory=list)  # rules_collisions.Contact, in sequence order
    speeds: dict[str, float] = field(default_factory=dict)  # label -> stated travel speed [mph]
    unstated_positions: set[str] = field(default_factory=set)  # labels placed ahead of V1 by default, not by the text
    off: frozenset[str] = frozenset()  # recorded rules switched off (rule_sources): held-out extraction
    consulted: set[str] = field(default_factory=set)  # recorded rules this extraction asked for

    def uses(self, rule: str) -> bool:
        """Whether the recorded rule `rule` (crashscene.extract.rule_sources) is on for this extraction."""
        self.consulted.add(known_rule(rule))
        return rule not in self.off

    def fact_texts(self, prefix: str = "") -> list[str]:
        """Texts of the sketch facts starting with `prefix`."""
        return [f.text for f in self.facts if f.text.startswith(prefix)]

    def note(self, path: str, quote: str) -> None:
        """Keep the first quote for a field path as its evidence."""
        self.evidence.setdefault(path, clip(quote))


def relative_heading(ego: Vehicle, other: Vehicle) -> str | None:
    """`other`'s heading as `ego` sees it, from compass travel directions (V1 east, V2 north: from_right)."""
    if ego.direction is None or other.direction is None:
        return None
    delta = (COMPASS[other.direction] - COMPASS[ego.direction]) % 360
    if delta == 0:
        return "same_direction"
    if delta == 180:
        return "opposite_direction"
    origin = (COMPASS[other.direction] + 180 - COMPASS[ego.direction]) % 360  # where it comes from
    return "from_right" if origin == 90 else "from_left"


def has_cross_traffic(state: RulesState) -> bool:
    """Whether some vehicle crosses V1's path from the left or the right."""
    ego = state.vehicles["V1"]
    return any(relative_heading(ego, v) in ("from_left", "from_right") for v in state.vehicles.values() if v is not ego)
