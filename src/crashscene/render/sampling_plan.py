"""The compiled sampling plan: the distribution of a rendered Scenic program, written as data (`sampler.json`).

`render` writes the program and, from the same template context, this plan:
the sampled global parameters (uniform ranges, in declaration order), the
program's constant parameters, each actor's placement rule, blueprint pool
(in a search's program, also the parameter that picks from it) and `cs_*`
tokens, and the arguments the program hands to `scenic_support.candidates`.
`crashscene.render.compiled_sampler` draws scenes from it with numpy instead
of Scenic's interpreter: same candidates, same placement
arithmetic, same built-in requirements (every car inside road-or-shoulder, no
two cars overlapping). The plan carries the sha256 of the program it was
written with, so a hand-edited program is never sampled from a stale plan.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from crashscene.render.plan import BLUEPRINT_DIMS

SAMPLING_PLAN_NAME = "sampler.json"
PLAN_FORMAT = 1
ATTRIBUTES = ("label", "type", "behavior", "route_intent", "reference", "relation", "heading_relation",
              "placement", "maneuver", "controlled_by")  # written onto every Scenic object as cs_<name>


def program_digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _range(value: Any) -> tuple[float, float]:
    low, high = (value["low"], value["high"]) if isinstance(value, dict) else (value.low, value.high)
    return float(low), float(high)


def sampling_plan(context: dict[str, Any], program_text: str) -> dict[str, Any]:
    """The plan for a program rendered from `context` (see `crashscene.render.program.program_context`)."""
    plan = context["plan"]
    params = []
    actors = []
    for a in context["actors"]:
        for name, value, _ in a["params"]:
            low, high = _range(value)
            params.append({"name": name, "low": low, "high": high})
        actors.append({
            "role": a["role"], "prefix": a["prefix"], "ref": a["placement_ref"], "along": a["along"],
            "gap": float(a["gap"]), "oncoming_sign": float(a["oncoming_sign"]),
            "blueprints": list(a["blueprint_pool"]),
            "dims": [[float(v) for v in BLUEPRINT_DIMS[bp]] for bp in a["blueprint_pool"]],  # [m] length, width
            "dispositions": ",".join(a["dispositions"]),
            **{name: a[name] for name in ATTRIBUTES}})
        if a["model_param"]:  # a search's program picks the blueprint with this parameter (plan.search_parameters)
            actors[-1]["model_param"] = a["model_param"]
    constants = [[k, v] for k, v in {"weather": plan.carla_weather, "time_of_day_hour": float(plan.hour),
                 "cs_topology": plan.topology, "cs_horizon": float(plan.horizon),
                 "cs_speed_limit": float(plan.speed_limit or 0.0), "cs_road_surface": plan.road_surface,
                 "cs_time_of_day": plan.time_of_day, "cs_weather": plan.weather}.items()]  # declaration order
    return {
        "format": PLAN_FORMAT,
        "program_sha256": program_digest(program_text),
        "map": context["map_name"],
        "carla_map": context["carla_town"],
        "constants": constants,
        "params": params,
        "actors": actors,
        "candidates": {"actors": context["actor_specs"], "topology": plan.topology,
                       "hint": float(context["anchor_hint"]), "curve_sign": int(context["curve_sign"]),
                       "ego_roads": list(context["ego_roads"]), "map_name": context["map_name"],
                       "room": [float(v) for v in context["room"]]},
    }


def write_sampling_plan(path: Path, plan: dict[str, Any]) -> None:
    Path(path).write_text(json.dumps(plan, indent=1, sort_keys=True) + "\n", encoding="utf-8")
