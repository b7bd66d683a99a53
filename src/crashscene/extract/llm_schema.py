"""The LLM's structured-output schema, and its conversion to and from a DSL `Scenario`.

OpenAI's strict json_schema mode (and llama.cpp's grammar from a schema)
refuse or mishandle open dictionaries and optional fields, so the DSL's
`json_schema()` is reshaped here into a strict twin:

- the actors are `ego` (V1, placed against a road element, no heading: the
  schema makes the validator's ego rules unbreakable) and `npcs`, a list of
  actors each with a closed `role` (npc1, npc2, ...) and a required heading;
- `evidence` is a list of `{path, quote}` pairs, one list per section, written
  *before* that section's values so that the model quotes first and decides
  second (environment, then road network, then actors, then the crash sequence, then oracle);
- every field is required; optional DSL fields are nullable instead.

The vocabularies are the DSL's own enums (`crashscene.dsl.tokens`), so the two
schemas cannot drift apart; `tests/extract/test_prompt.py` checks that every
token set of `json_schema()` appears in `strict_json_schema()`. `to_scenario`
turns a reply back into a `Scenario` through `crashscene.dsl.from_raw`, so the
LLM path gets the same normalisation and error addressing as a YAML file.
"""
from __future__ import annotations

from enum import StrEnum
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from crashscene.dsl import DslError, Diagnostic, Scenario, from_raw
from crashscene.dsl.tokens import (
    MONITORED_CODES,
    ActorType,
    Behavior,
    CollisionClass,
    CurveDirection,
    Heading,
    ImpactArea,
    Relation,
    RoadElement,
    RoadMarker,
    RoadSurface,
    RoadType,
    Sign,
    TimeOfDay,
    Weather,
)

MAX_NPCS = 9  # the closed role vocabulary: ego, npc1..npc9 (CIREN cases involve at most 5 vehicles)
MAX_ORACLE = 6  # violations per scenario; list bounds (maxItems) also stop a small model's repetition loops
MAX_CONTACTS = 6  # contacts in the crash sequence (CIREN cascades have up to 4)

NpcRole = StrEnum("NpcRole", {f"NPC{i}": f"npc{i}" for i in range(1, MAX_NPCS + 1)})
Role = StrEnum("Role", {"EGO": "ego", **{r.name: r.value for r in NpcRole}})
Reference = StrEnum("Reference", {**{e.name: e.value for e in RoadElement}, **{r.name: r.value for r in Role}})

_CLOSED = ConfigDict(extra="forbid")


class Quote(BaseModel):
    """One piece of evidence: a field (relative to its section) and the words that support it."""

    model_config = _CLOSED

    path: str = Field(description="the field this quote supports, e.g. weather, number_of_lanes, behavior")
    quote: str = Field(description="exact words from the report, or 'sketch: ...' for a sketch fact")


class LlmEnvironment(BaseModel):
    model_config = _CLOSED

    evidence: list[Quote] = Field(max_length=3)
    weather: Weather
    time_of_day: TimeOfDay
    road_surface: RoadSurface


class LlmRoadNetwork(BaseModel):
    model_config = _CLOSED

    evidence: list[Quote] = Field(max_length=7)
    road_type: RoadType
    number_of_ways: Literal[1, 2]
    number_of_lanes: int = Field(ge=1, le=16, description="through lanes of V1's roadway, all directions")
    road_marker: RoadMarker
    traffic_signs: list[Sign] = Field(max_length=len(Sign))
    speed_limit_mph: int | None = Field(ge=5, le=100, description="posted limit [mph], null when not stated")
    curve_direction: CurveDirection | None = Field(description="left or right as V1 sees it; null unless a curve")


class LlmEgoPosition(BaseModel):
    model_config = _CLOSED

    reference: RoadElement
    relation: Relation


class LlmPosition(BaseModel):
    model_config = _CLOSED

    reference: Reference
    relation: Relation
    heading: Heading


class LlmEgo(BaseModel):
    model_config = _CLOSED

    label: str | None = Field(description="the report's label of the case vehicle, usually V1")
    evidence: list[Quote] = Field(max_length=3)
    type: ActorType
    behavior: Behavior
    position: LlmEgoPosition
    speed_mph: float | None = Field(description="travel speed [mph] only when the report states it, else null")


class LlmNpc(BaseModel):
    model_config = _CLOSED

    role: NpcRole = Field(description="npc1 for V2, npc2 for V3, ...")
    label: str | None = Field(description="the report's label: V2, V3, ...; unknown for an unlabelled vehicle")
    evidence: list[Quote] = Field(max_length=3)
    type: ActorType
    behavior: Behavior
    position: LlmPosition
    speed_mph: float | None = Field(description="travel speed [mph] only when the report states it, else null")


class LlmViolation(BaseModel):
    model_config = _CLOSED

    actor: Role
    quote: str = Field(description="the report's words that support this violation")
    code: str = Field(pattern=r"^CVC_[0-9]+[A-Za-z]?$")
    violation: str = Field(pattern=r"^[a-z][a-z0-9_]*$")
    description: str


class LlmContact(BaseModel):
    """One contact of the crash sequence (dsl.md convention 11), first harmful event first."""

    model_config = _CLOSED

    quote: str = Field(description="the report's impact sentence, e.g. 'the front of V2 struck the right side of V1'")
    striking: Role
    struck: Role
    striking_area: ImpactArea
    struck_area: ImpactArea
    collision_class: CollisionClass


class LlmScenario(BaseModel):
    """What the model returns: one crash scenario, sections in decision order."""

    model_config = _CLOSED

    summary: str = Field(description="one sentence: who did what, where")
    environment: LlmEnvironment
    road_network: LlmRoadNetwork
    ego: LlmEgo
    npcs: list[LlmNpc] = Field(max_length=MAX_NPCS)
    collisions: list[LlmContact] = Field(max_length=MAX_CONTACTS, description="contacts between actors in order; "
                                         "[] when no two actors touched")
    oracle: list[LlmViolation] = Field(max_length=MAX_ORACLE)


def strict_json_schema() -> dict[str, Any]:
    """The JSON Schema sent as the strict `json_schema` response format (what `parse` sends)."""
    from openai.lib._pydantic import to_strict_json_schema

    return to_strict_json_schema(LlmScenario)


def to_scenario(reply: LlmScenario, scenario_id: str | None = None, source: str | None = None) -> Scenario:
    """Convert a model reply to a schema-valid `Scenario`; raises `DslError` naming the bad field."""
    actors: dict[str, Any] = {}
    evidence: dict[str, str] = {}
    problems: list[Diagnostic] = []
    _collect(evidence, "environment", reply.environment.evidence)
    _collect(evidence, "road_network", reply.road_network.evidence)
    ego = reply.ego
    actors["ego"] = _raw_actor(ego.type, ego.behavior, {"reference": ego.position.reference.value,
                                                        "relation": ego.position.relation.value},
                               ego.label, ego.speed_mph)
    _collect(evidence, "actors.ego", ego.evidence)
    for index, actor in enumerate(reply.npcs):
        role = actor.role.value
        if role in actors:
            problems.append(Diagnostic("two actors have the same role", f"npcs[{index}].role", source,
                                       value=role, allowed=_free_roles(reply)))
            continue
        position = {"reference": actor.position.reference.value, "relation": actor.position.relation.value,
                    "heading": actor.position.heading.value}
        actors[role] = _raw_actor(actor.type, actor.behavior, position, actor.label, actor.speed_mph)
        _collect(evidence, f"actors.{role}", actor.evidence)
    oracle = []
    for index, entry in enumerate(reply.oracle):
        # the monitored codes have a fixed token: a table lookup, not a judgement left to the model
        violation = MONITORED_CODES.get(entry.code, entry.violation)
        oracle.append({"code": entry.code, "violation": violation, "actor": entry.actor.value,
                       "description": entry.description.strip()[:2000]})
        if entry.quote.strip():
            evidence[f"oracle[{index}]"] = entry.quote.strip()
    collisions = [{"striking": c.striking.value, "struck": c.struck.value, "striking_area": c.striking_area.value,
                   "struck_area": c.struck_area.value, "class": c.collision_class.value} for c in reply.collisions]
    quotes = [c.quote.strip() for c in reply.collisions if c.quote.strip()]
    if quotes:
        evidence["collisions"] = " | ".join(quotes)
    if problems:
        raise DslError(problems)
    road = reply.road_network
    raw: dict[str, Any] = {
        "environment": reply.environment.model_dump(mode="json", exclude={"evidence"}),
        "road_network": road.model_dump(mode="json", exclude={"evidence"}, exclude_none=True),
        "actors": actors,
        "oracle": oracle,
        "collisions": collisions,
        "evidence": evidence,
    }
    if scenario_id:
        raw["scenario_id"] = scenario_id
    if reply.summary.strip():
        raw["summary"] = " ".join(reply.summary.split())[:2000]
    return from_raw(raw, source=source)


def from_scenario(scenario: Scenario) -> LlmScenario:
    """The reply a perfect model would give for `scenario` (few-shot exemplars, tests)."""
    def quotes(prefix: str) -> list[Quote]:
        return [Quote(path=key[len(prefix) + 1:] or prefix, quote=text) for key, text in scenario.evidence.items()
                if key == prefix or key.startswith(prefix + ".")]

    env, road = scenario.environment, scenario.road_network
    def npc(name: str, actor: Any) -> LlmNpc:
        # a golden NPC without heading is rendered as oncoming; say so explicitly in the reply form
        heading = actor.position.heading or Heading.OPPOSITE_DIRECTION
        return LlmNpc(role=name, label=actor.label, evidence=quotes(f"actors.{name}"), type=actor.type,
                      behavior=actor.behavior, speed_mph=actor.speed_mph,
                      position=LlmPosition(reference=actor.position.reference, relation=actor.position.relation,
                                           heading=heading))

    ego = scenario.actors["ego"]
    ego_reply = LlmEgo(label=ego.label, evidence=quotes("actors.ego"), type=ego.type, behavior=ego.behavior,
                       position=LlmEgoPosition(reference=ego.position.reference, relation=ego.position.relation),
                       speed_mph=ego.speed_mph)
    oracle = [LlmViolation(actor=entry.actor, quote=scenario.evidence.get(f"oracle[{index}]", ""), code=entry.code,
                           violation=entry.violation, description=entry.description)
              for index, entry in enumerate(scenario.oracle)]
    return LlmScenario(
        summary=scenario.summary or "",
        environment=LlmEnvironment(evidence=quotes("environment"), weather=env.weather,
                                   time_of_day=env.time_of_day, road_surface=env.road_surface),
        road_network=LlmRoadNetwork(evidence=quotes("road_network"), road_type=road.road_type,
                                    number_of_ways=road.number_of_ways, number_of_lanes=road.number_of_lanes,
                                    road_marker=road.road_marker, traffic_signs=road.traffic_signs,
                                    speed_limit_mph=road.speed_limit_mph, curve_direction=road.curve_direction),
        ego=ego_reply, npcs=[npc(name, actor) for name, actor in scenario.npcs.items()], oracle=oracle,
        collisions=[LlmContact(quote=scenario.evidence.get(f"collisions[{index}]")
                               or (scenario.evidence.get("collisions", "") if index == 0 else ""),
                               striking=c.striking, struck=c.struck, striking_area=c.striking_area,
                               struck_area=c.struck_area, collision_class=c.class_)
                    for index, c in enumerate(scenario.collisions or [])])


def _collect(evidence: dict[str, str], prefix: str, quotes: list[Quote]) -> None:
    for item in quotes:
        path, text = item.path.strip().strip("."), item.quote.strip()
        if not path or not text:
            continue
        if path.startswith(prefix + "."):
            path = path[len(prefix) + 1:]
        key = f"{prefix}.{path}" if path != prefix else prefix
        evidence[key] = f"{evidence[key]} | {text}" if key in evidence else text


def _raw_actor(type_: ActorType, behavior: Behavior, position: dict[str, Any], label: str | None,
               speed_mph: float | None) -> dict[str, Any]:
    raw: dict[str, Any] = {"type": type_.value, "behavior": behavior.value, "position": position}
    if label and label.strip():
        raw["label"] = label.strip()[:40]
    if speed_mph is not None and speed_mph > 0:
        raw["speed_mph"] = speed_mph
    return raw


def _free_roles(reply: LlmScenario) -> list[str]:
    used = {actor.role.value for actor in reply.npcs}
    return [role.value for role in NpcRole if role.value not in used][:3]
