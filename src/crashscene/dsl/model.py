"""Pydantic models of the Extended Scenic DSL (../shared/spec/dsl.md, version 1).

The models accept the canonical form only; `normalize` runs first on any raw
tree (file or LLM output), so human spellings are accepted on input while the
JSON Schema exported from these models stays canonical.
"""
from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator, model_validator

from crashscene.dsl.normalize import normalize
from crashscene.dsl.tokens import (
    CODE_PATTERN,
    NPC_PATTERN,
    VIOLATION_PATTERN,
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

_STRICT = ConfigDict(extra="forbid", use_enum_values=False, validate_default=True)
REFERENCE_TOKENS = [e.value for e in RoadElement] + ["ego", "npc<N>"]


def _not_bool(value: Any) -> Any:
    """YAML reads `true` as a bool, and Python counts a bool as 1: refuse it where a number is meant."""
    if isinstance(value, bool):
        raise ValueError(f"a number is required, not the boolean {str(value).lower()}")
    return value


NotBool = BeforeValidator(_not_bool)


def actor_names_allowed() -> str:
    return "ego, npc1, npc2, ..."


class Environment(BaseModel):
    model_config = _STRICT

    weather: Weather
    time_of_day: TimeOfDay
    road_surface: RoadSurface = RoadSurface.NOT_MENTIONED


class RoadNetwork(BaseModel):
    model_config = _STRICT

    road_type: RoadType
    number_of_ways: Annotated[Literal[1, 2], NotBool] = Field(description="directions of travel on the crash roadway")
    number_of_lanes: Annotated[int, NotBool] = Field(ge=1, le=16, description="through lanes of the crash roadway, all directions")
    road_marker: RoadMarker
    traffic_signs: list[Sign] = Field(default_factory=list, description="a set; [] = none or not mentioned")
    speed_limit_mph: Annotated[int | None, NotBool] = Field(default=None, ge=5, le=100, description="posted limit [mph]")
    curve_direction: CurveDirection | None = Field(default=None, description="as the ego sees it")

    @field_validator("traffic_signs")
    @classmethod
    def _as_ordered_set(cls, signs: list[Sign]) -> list[Sign]:
        order = list(Sign)
        return sorted(set(signs), key=order.index)


class Position(BaseModel):
    model_config = _STRICT

    reference: str = Field(description="ego, npcN, or a road element: " + ", ".join(e.value for e in RoadElement))
    relation: Relation
    heading: Heading | None = None

    @field_validator("reference")
    @classmethod
    def _known_reference(cls, value: str) -> str:
        if value in RoadElement.__members__.values() or value == "ego" or NPC_PATTERN.match(value):
            return value
        raise ValueError(f"unknown reference {value!r}; allowed: {', '.join(REFERENCE_TOKENS)}")


class Actor(BaseModel):
    model_config = _STRICT

    label: str | None = Field(default=None, max_length=40, description="the report's label, e.g. V2")
    type: ActorType
    behavior: Behavior
    position: Position
    speed_mph: Annotated[float | None, NotBool] = Field(default=None, gt=0, le=200, description="stated travel speed [mph]")


class OracleEntry(BaseModel):
    model_config = _STRICT

    code: str = Field(description="California Vehicle Code section, CVC_<digits>")
    violation: str = Field(description="snake_case violation token (fixed for the monitored codes)")
    actor: str = Field(description="the actor that committed it: ego or npcN")
    description: str = Field(default="", max_length=2000)

    @field_validator("code")
    @classmethod
    def _code_form(cls, value: str) -> str:
        if not CODE_PATTERN.match(value):
            raise ValueError(f"code {value!r} is not of the form CVC_<digits>")
        return value

    @field_validator("violation")
    @classmethod
    def _violation_form(cls, value: str) -> str:
        if not VIOLATION_PATTERN.match(value):
            raise ValueError(f"violation {value!r} is not a snake_case token")
        return value

    @field_validator("actor")
    @classmethod
    def _actor_form(cls, value: str) -> str:
        return _actor_name(value)


def _actor_name(value: str) -> str:
    if value == "ego" or NPC_PATTERN.match(value):
        return value
    raise ValueError(f"actor {value!r} is not an actor name; allowed: {actor_names_allowed()}")


class Contact(BaseModel):
    """One contact between two actors in the crash sequence (dsl.md `collisions`)."""

    model_config = ConfigDict(extra="forbid", validate_default=True, populate_by_name=True)

    striking: str = Field(description="the actor whose striking_area meets the other: ego or npcN")
    struck: str = Field(description="the other actor: ego or npcN")
    striking_area: ImpactArea
    struck_area: ImpactArea
    class_: CollisionClass = Field(alias="class", description="rear_end | head_on | angle | sideswipe")

    @field_validator("striking", "struck")
    @classmethod
    def _actor_form(cls, value: str) -> str:
        return _actor_name(value)


class Scenario(BaseModel):
    """One crash scenario: what happened, never where in coordinates."""

    model_config = _STRICT

    dsl_version: Annotated[Literal[1], NotBool] = 1
    scenario_id: str | None = Field(default=None, max_length=120)
    summary: str | None = Field(default=None, max_length=2000)
    environment: Environment
    road_network: RoadNetwork
    actors: dict[str, Actor]
    oracle: list[OracleEntry] = Field(description="required (dsl.md section 2); [] when the report supports no violation")
    collisions: list[Contact] | None = Field(default=None, description="the crash sequence, first contact first; "
                                             "absent = not written, [] = no contact between actors")
    evidence: dict[str, str] = Field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _normalize(cls, raw: Any) -> Any:
        return normalize(raw)

    @field_validator("actors")
    @classmethod
    def _actor_names(cls, actors: dict[str, Actor]) -> dict[str, Actor]:
        if "ego" not in actors:
            raise ValueError("actors must include 'ego' (the report's V1)")
        bad = [name for name in actors if name != "ego" and not NPC_PATTERN.match(name)]
        if bad:
            raise ValueError(f"actor name {bad[0]!r} is not allowed; allowed: {actor_names_allowed()}")
        return dict(sorted(actors.items(), key=lambda item: actor_order(item[0])))

    @property
    def npcs(self) -> dict[str, Actor]:
        return {name: actor for name, actor in self.actors.items() if name != "ego"}


def actor_order(name: str) -> int:
    """Canonical order of actor names: ego first, then npc1, npc2, ..."""
    return 0 if name == "ego" else int(name[3:])
