"""Rule-based extraction: NHTSA narrative language and sketch facts to a DSL scenario.

CIREN/NASS narratives are formulaic ("was traveling east in the eastbound lane
of a two-lane, two-way roadway", "It was daylight, the sky was cloudy",
"crossed the centerline", "the front of V2 struck the right side of V1"). This
module reads those patterns, deterministically, and applies the conventions of
dsl.md section 5 (actors V1=ego, V2=npc1...; positions from travel directions;
oracle codes per convention 9). Every decided field records the quote it came
from in `evidence`. It is the backend every user without an LLM gets, and the
fallback of the LLM pipeline.

The rules are general language patterns, never case lookups. Flow, one module
per step, all sharing a `RulesState` (rules_state):

1. narrative          labels folded ("Vehicle one", "Vehicle #2" -> V1, V2), sentences
2. rules_vehicles     vehicles, travel directions, body types; the pre-crash text
3. rules_environment  weather, light, surface
4. rules_road         junction/curve/straight, ways, marking, devices, limit
   (rules_lanes       through lanes)
5. rules_behavior     each vehicle's primary manoeuvre
6. rules_positions    references, relations, headings, stated speeds
7. rules_oracle       CVC codes per actor

The text wins over the sketch where both speak (dsl.md convention 6); sketch
facts fill what the text leaves out (posted limit, signs, drawn centre lines).
"""
from __future__ import annotations

from collections.abc import Iterable

from crashscene.dsl import Scenario, from_raw, validate
from crashscene.dsl.errors import DslError
from crashscene.extract.errors import CaseInputError, RulesError
from crashscene.extract.narrative import Narrative, clip
from crashscene.extract.nhtsa_xml import nhtsa_facts
from crashscene.extract.case_input import Report
from crashscene.extract.rule_sources import known_rule
from crashscene.extract.rules_behavior import decide_behaviors, revise_by_contacts
from crashscene.extract.rules_collisions import decide_collisions
from crashscene.extract.rules_environment import decide_environment
from crashscene.extract.rules_oracle import decide_oracle
from crashscene.extract.rules_positions import decide_actors, revise_positions_by_the_sequence
from crashscene.extract.rules_road import decide_road_network
from crashscene.extract.rules_state import RulesState
from crashscene.extract.rules_vehicles import find_vehicles, split_pre_crash
from crashscene.extract.sketch import SketchFact


def extract_rules(report: Report, facts: list[SketchFact] | None = None, off: Iterable[str] = ()) -> Scenario:
    """Deterministic extraction of one report (and its sketch facts) into a validated `Scenario`.

    The report's case XML, when there is one, adds its coded speed limit and conditions after the sketch
    facts (a damaged XML is skipped: it is a supplement, the narrative is the report). `off` names recorded
    rules (crashscene.extract.rule_sources) to switch off: the held-out evaluation of a case switches off
    the rules written from it."""
    off = frozenset(known_rule(name) for name in off)
    facts = list(facts or [])
    if report.nhtsa_xml is not None:
        try:
            facts += nhtsa_facts(report.nhtsa_xml)
        except CaseInputError:
            pass
    state = RulesState(report=report, facts=facts, t=Narrative(report.narrative), off=off)
    find_vehicles(state)
    split_pre_crash(state)
    environment = decide_environment(state)
    road = decide_road_network(state)
    decide_behaviors(state)
    actors = decide_actors(state, road)
    collisions = decide_collisions(state, actors)
    revise_by_contacts(state, actors, collisions)
    revise_positions_by_the_sequence(state, actors, collisions)
    oracle = decide_oracle(state, road)
    raw = {
        "scenario_id": f"CIREN-{report.case_id}",
        "summary": summary_line(state, road, actors),
        "environment": environment,
        "road_network": road,
        "actors": actors,
        "oracle": oracle,
        "collisions": collisions,
        "evidence": dict(sorted(state.evidence.items())),
    }
    try:
        scenario = from_raw(raw, source=f"rules extraction of {report.source}")
        validate(scenario)
        return scenario
    except DslError as exc:
        raise RulesError(f"rule-based extraction produced an invalid scenario:\n{exc}", report.source) from None


def summary_line(state: RulesState, road: dict, actors: dict) -> str:
    """One line naming each vehicle's direction and manoeuvre and where the crash happens."""
    parts = []
    for actor in actors.values():
        vehicle = state.vehicles[actor["label"]]
        direction = f"{vehicle.direction}bound " if vehicle.direction else ""
        parts.append(f"{direction}{actor['label']} ({actor['behavior'].replace('_', ' ')})")
    where = {"intersection": "at a 4-leg intersection", "t_intersection": "at a 3-leg junction",
             "curve": "on a curve", "straight": "on a straight road"}[road["road_type"]]
    return clip(f"Rule-based extraction: {', '.join(parts)} {where}.", 300)
