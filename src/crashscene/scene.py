"""Sampled scenes: the contract between `sample` (render stage) and `simulate`.

A scene is one concrete variation drawn from a rendered Scenic program: where
each actor starts, how fast, and the DSL properties that drive it. Any backend
reads scenes from here, never from Scenic objects directly.

Coordinates are the map's OpenDRIVE frame [m]. Angles use the OpenDRIVE/ENU
convention everywhere in crashscene: yaw [rad], 0 = +x (east), counter-clockwise.
Scenic's heading (0 = +y) is converted at the edge: yaw = scenic_heading + pi/2.
"""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class SampledActor(BaseModel):
    """One actor of one sampled scene."""

    model_config = ConfigDict(extra="forbid")

    role: str = Field(description="DSL role: ego, npc1, ...")
    label: str | None = Field(default=None, description="report label, e.g. V2")
    type: str = Field(description="DSL actor type token: car, truck, motorcycle")
    blueprint: str = Field(description="CARLA blueprint, e.g. vehicle.lincoln.mkz_2017")
    behavior: str = Field(description="DSL behavior token")
    x: float = Field(description="[m] centre, map frame")
    y: float = Field(description="[m] centre, map frame")
    yaw: float = Field(description="[rad] 0 = +x, counter-clockwise")
    speed: float = Field(ge=0, description="[m/s] initial and desired cruise speed")
    length: float = Field(gt=0, description="[m]")
    width: float = Field(gt=0, description="[m]")
    lane_id: str | None = Field(default=None, description="Scenic/OpenDRIVE lane uid at the start, if on a lane")
    route_intent: str = Field(description="straight | left | right | u_turn | lane_change_left | lane_change_right "
                                          "| none: the manoeuvre the actor will take at its next junction or on its road")
    reference: str = Field(description="DSL position.reference")
    relation: str = Field(description="DSL position.relation")
    heading_relation: str | None = Field(default=None, description="DSL position.heading")
    dispositions: list[str] = Field(default_factory=list,
                                    description="oracle codes attributed to this actor (CVC_21453, ...)")
    properties: dict[str, float | int | str | bool | None] = Field(default_factory=dict,
                                                                   description="any further scalar properties")


class SampledScene(BaseModel):
    """One variation: the sampled actors and the values of every sampled parameter."""

    model_config = ConfigDict(extra="forbid")

    index: int = Field(ge=0, description="variation index within the batch")
    seed: int = Field(description="the batch seed")
    scenario_hash: str = Field(description="hash of the DSL scenario (and render options)")
    map_file: str = Field(description="OpenDRIVE map the scene is placed on (path as written by render)")
    params: dict[str, float | int | str] = Field(default_factory=dict,
                                                 description="sampled global parameters, e.g. EGO_INIT_DIST")
    actors: list[SampledActor]
