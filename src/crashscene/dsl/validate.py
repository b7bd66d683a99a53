"""Semantic validation beyond the schema: references, roles and road consistency.

Each check returns diagnostics addressed like schema errors (field path, line,
value, allowed). Errors make a scenario unusable downstream; warnings flag
what a renderer can work around but a reviewer should look at.
"""
from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from crashscene.dsl.errors import Diagnostic, DslError, Severity
from crashscene.dsl.io import parse_yaml, from_raw
from crashscene.dsl.model import Scenario
from crashscene.dsl.tokens import (
    CLASS_AREAS,
    JUNCTIONS,
    Heading,
    RoadElement,
    RoadType,
    Sign,
    areas_fit_class,
    monitored_codes,
)

ERROR, WARNING = Severity.ERROR, Severity.WARNING
_SIGN_REFERENCES = {RoadElement.STOP_SIGN: Sign.STOP_SIGN, RoadElement.YIELD_SIGN: Sign.YIELD_SIGN,
                    RoadElement.TRAFFIC_LIGHT: Sign.TRAFFIC_LIGHT}


MAX_ACTORS = 6  # ego + 5 NPCs: CIREN crashes involve at most 3; beyond this placement is rejection sampling for minutes


def check(scenario: Scenario) -> list[Diagnostic]:
    """All semantic diagnostics of a schema-valid scenario (no file or line)."""
    return [*_actor_checks(scenario), *_placement_checks(scenario), *_road_checks(scenario),
            *_oracle_checks(scenario), *_collision_checks(scenario), *_evidence_checks(scenario)]


def _placement_checks(s: Scenario) -> Iterator[Diagnostic]:
    """Combinations the renderer cannot place: too many actors, actors placed relative to each other in a cycle."""
    if len(s.actors) > MAX_ACTORS:
        yield Diagnostic(f"{len(s.actors)} actors cannot be placed on one rendered map; a scenario keeps the "
                         f"vehicles of the crash sequence", "actors", value=len(s.actors),
                         allowed=[f"at most {MAX_ACTORS} actors (ego, npc1 ... npc{MAX_ACTORS - 1})"])
    refs = {name: actor.position.reference for name, actor in s.actors.items()}
    reported: set[str] = set()
    for start in refs:
        chain, name = [], start
        while name in refs and name not in chain and name != "ego":
            chain.append(name)
            name = refs[name]
        if name in chain and name not in reported and refs.get(name) != name:
            cycle = chain[chain.index(name):]
            reported.update(cycle)
            paths = [f"actors.{n}.position.reference" for n in cycle]
            yield Diagnostic("actors placed relative to each other in a cycle (" + ", ".join(
                f"{n} -> {refs[n]}" for n in cycle) + "): one of them must reference the ego or a road element "
                "(also at " + ", ".join(paths[1:]) + ")", paths[0], value=refs[cycle[0]],
                allowed=["ego", *(e.value for e in RoadElement)])


def _actor_checks(s: Scenario) -> Iterator[Diagnostic]:
    names = list(s.actors)
    expected = ["ego"] + [f"npc{i}" for i in range(1, len(names))]
    if names != expected:
        yield Diagnostic("NPC names should be npc1, npc2, ... without gaps, in report order", "actors",
                         value=names, allowed=expected, severity=WARNING)
    signs = set(s.road_network.traffic_signs)
    for name, actor in s.actors.items():
        base = f"actors.{name}.position"
        ref = actor.position.reference
        if ref == name:
            yield Diagnostic("an actor cannot be placed relative to itself", f"{base}.reference", value=ref)
        elif ref not in RoadElement.__members__.values() and ref not in s.actors:
            yield Diagnostic("reference names an actor that does not exist", f"{base}.reference", value=ref,
                             allowed=[n for n in names if n != name] + [e.value for e in RoadElement])
        if name == "ego":
            if actor.position.heading is not None:
                yield Diagnostic("the ego's heading is omitted: headings are relative to the ego",
                                 f"{base}.heading", value=actor.position.heading.value)
            if ref not in RoadElement.__members__.values():
                yield Diagnostic("the ego is placed against a road element", f"{base}.reference", value=ref,
                                 allowed=[e.value for e in RoadElement], severity=WARNING)
        elif actor.position.heading is None:
            yield Diagnostic("NPC without a heading; the renderer assumes opposite_direction", f"{base}.heading",
                             allowed=[h.value for h in Heading], severity=WARNING)
        if ref in _SIGN_REFERENCES and _SIGN_REFERENCES[ref] not in signs:
            yield Diagnostic(f"references a {ref} that traffic_signs does not list", f"{base}.reference",
                             value=ref, allowed=sorted(signs))
        if ref == RoadElement.CURVE and s.road_network.road_type != RoadType.CURVE:
            yield Diagnostic("references the curve on a road that is not a curve", f"{base}.reference",
                             value=ref, severity=WARNING)
        if ref == RoadElement.INTERSECTION and s.road_network.road_type not in JUNCTIONS:
            yield Diagnostic("references an intersection on a road without one", f"{base}.reference",
                             value=ref, severity=WARNING)
        crossing = actor.position.heading in (Heading.FROM_LEFT, Heading.FROM_RIGHT)
        if crossing and s.road_network.road_type not in JUNCTIONS:
            yield Diagnostic("crossing traffic needs an intersection or T-intersection", f"{base}.heading",
                             value=actor.position.heading.value, severity=WARNING)
        if actor.position.heading == Heading.OPPOSITE_DIRECTION and s.road_network.number_of_ways == 1:
            yield Diagnostic("oncoming traffic on a one-way roadway", f"{base}.heading",
                             value=actor.position.heading.value, severity=WARNING)


def _road_checks(s: Scenario) -> Iterator[Diagnostic]:
    road = s.road_network
    if road.number_of_lanes < road.number_of_ways:
        yield Diagnostic(f"number_of_lanes ({road.number_of_lanes}) is smaller than number_of_ways "
                         f"({road.number_of_ways}): each direction needs a lane",
                         "road_network.number_of_lanes", value=road.number_of_lanes,
                         allowed=[f">= {road.number_of_ways}"])
    if road.curve_direction is not None and road.road_type != RoadType.CURVE:
        yield Diagnostic("curve_direction is only meaningful on a curve", "road_network.curve_direction",
                         value=road.curve_direction.value, allowed=["omit it", "road_type: curve"])
    if road.road_type == RoadType.CURVE and road.curve_direction is None:
        yield Diagnostic("curve without curve_direction; the renderer picks one at random",
                         "road_network.curve_direction", allowed=["left", "right"], severity=WARNING)
    if road.speed_limit_mph is not None and Sign.SPEED_LIMIT_SIGN not in road.traffic_signs:
        yield Diagnostic("speed_limit_mph is stated, so traffic_signs should hold speed_limit_sign",
                         "road_network.traffic_signs", value=[x.value for x in road.traffic_signs],
                         severity=WARNING)
    if road.speed_limit_mph is not None and road.speed_limit_mph % 5:
        yield Diagnostic("posted limits are multiples of 5 mph", "road_network.speed_limit_mph",
                         value=road.speed_limit_mph, severity=WARNING)
    referenced = {actor.position.reference for actor in s.actors.values()}
    for ref, sign in _SIGN_REFERENCES.items():
        if sign in road.traffic_signs and ref not in referenced and road.road_type not in JUNCTIONS:
            yield Diagnostic(f"a {sign.value} on a {road.road_type.value} road that no actor references "
                             f"controls nothing", "road_network.traffic_signs", value=sign.value,
                             severity=WARNING)


def _oracle_checks(s: Scenario) -> Iterator[Diagnostic]:
    seen: set[tuple[str, str]] = set()
    monitored = monitored_codes()
    for index, entry in enumerate(s.oracle):
        path = f"oracle[{index}]"
        if entry.actor not in s.actors:
            yield Diagnostic("oracle actor does not exist", f"{path}.actor", value=entry.actor,
                             allowed=list(s.actors))
        expected = monitored.get(entry.code)
        if expected is not None and entry.violation != expected:
            yield Diagnostic(f"{entry.code} is monitored under the violation token {expected!r}",
                             f"{path}.violation", value=entry.violation, allowed=[expected])
        if (entry.code, entry.actor) in seen:
            yield Diagnostic("the same code is listed twice for this actor", f"{path}.code", value=entry.code,
                             severity=WARNING)
        seen.add((entry.code, entry.actor))


def _collision_checks(s: Scenario) -> Iterator[Diagnostic]:
    for index, contact in enumerate(s.collisions or []):
        path = f"collisions[{index}]"
        for field in ("striking", "struck"):
            name = getattr(contact, field)
            if name not in s.actors:
                yield Diagnostic("contact names an actor that does not exist", f"{path}.{field}", value=name,
                                 allowed=list(s.actors))
        if contact.striking == contact.struck:
            yield Diagnostic("a contact is between two different actors", f"{path}.struck", value=contact.struck,
                             allowed=[n for n in s.actors if n != contact.striking])
        if not areas_fit_class(contact.class_, contact.striking_area, contact.struck_area):
            fitting = sorted("/".join(sorted(a.value for a in pair)) if len(pair) == 2 else f"{min(pair).value}/{min(pair).value}"
                             for pair in CLASS_AREAS[contact.class_])
            yield Diagnostic(f"class {contact.class_.value} contradicts the areas "
                             f"{contact.striking_area.value} into {contact.struck_area.value}", f"{path}.class",
                             value=contact.class_.value, allowed=fitting, severity=WARNING)


def _evidence_checks(s: Scenario) -> Iterator[Diagnostic]:
    tops = {"environment", "road_network", "actors", "oracle", "collisions", "summary", "scenario_id"}
    for key in s.evidence:
        head = key.split(".")[0].split("[")[0]
        if head not in tops:
            yield Diagnostic("evidence key is not a field path of the scenario", f"evidence.{key}", value=key,
                             allowed=sorted(tops), severity=WARNING)
        elif head == "actors" and key.count(".") >= 1 and key.split(".")[1] not in s.actors:
            yield Diagnostic("evidence names an actor that does not exist", f"evidence.{key}", value=key,
                             allowed=list(s.actors), severity=WARNING)


def validate_text(text: str, source: str | None = None) -> tuple[Scenario, list[Diagnostic]]:
    """Parse, schema-validate and check; raises DslError on any error, returns warnings."""
    raw, lines = parse_yaml(text, source)
    scenario = from_raw(raw, source=source, lines=lines)
    found = []
    for diag in check(scenario):
        line = _nearest_line(diag.path, lines)
        found.append(Diagnostic(diag.message, diag.path, source, line, diag.value, diag.allowed, diag.severity))
    errors = [d for d in found if d.severity == ERROR]
    if errors:
        raise DslError(found)
    return scenario, found


def validate_file(path: str | Path) -> tuple[Scenario, list[Diagnostic]]:
    """Read, parse and fully validate one scenario file; raises DslError, returns warnings."""
    from crashscene.dsl.io import load_file  # size and encoding checks live there

    path = Path(path)
    load_file(path)  # raises the file-level errors with the same addressing
    return validate_text(path.read_text(encoding="utf-8"), source=str(path))


def validate(scenario: Scenario) -> list[Diagnostic]:
    """Check an in-memory scenario; raises DslError on errors, returns warnings."""
    found = check(scenario)
    if any(d.severity == ERROR for d in found):
        raise DslError(found)
    return found


def _nearest_line(path: str, lines: dict[str, int]) -> int | None:
    from crashscene.dsl.io import _line_for

    return _line_for(path, lines)
