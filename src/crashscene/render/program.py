"""Render step 3, program: a `RenderPlan` printed into a Scenic 3.1 program (`scenario.scenic`).

One universal Jinja2 template (templates/scenario.scenic.j2); placement helpers
live in `crashscene.render.scenic_support`, which every program imports. The
plan (step 1) supplies only tokens and numbers. Every value printed into
code goes through `py` (closed-vocabulary tokens and finite numbers only, else
RenderError); free text goes through `comment` (one escaped ASCII line) and
only into comments.

What a program offers its readers (backends, `crashscene.render.sample`):
- global parameters: `EGO_SPEED` [m/s], `EGO_INIT_DIST` [m], `EGO_MANEUVER_TIME` [s], the same per NPC as
  `npc1_SPEED`, `npc1_INIT_DIST`, ..., `npcN_ARRIVAL_OFFSET` [s] for junction approaches, `*_SIDE_OFFSET` [m],
  `*_STOP_DURATION` [s], `*_PROCEED_SPEED` [m/s], `*_LOSS_STEER` [-]; for a search also `*_LEAD_TIME`,
  `*_PULL_OUT_TTA` [s], `*_SKID_ROTATION` [-] and `SIGNAL_GREEN_REMAINING` [s]; `weather` (CARLA preset),
  `time_of_day_hour` [h], `cs_topology`, `cs_speed_limit` [m/s], `cs_horizon` [s], `cs_weather`, ...
- on every object: `cs_role`, `cs_label`, `cs_type`, `cs_behavior`, `cs_route_intent`, `cs_reference`,
  `cs_relation`, `cs_heading_relation`, `cs_dispositions` (comma-joined codes), `cs_placement`,
  `cs_maneuver`, `cs_controlled_by`, `cs_lane_id`, `cs_route_lanes`, `cs_target_speed` [m/s], and a Scenic
  behaviour per DSL behaviour token (CsCruise, CsChangeLane, CsCrossCenterline, CsStop, ...).
"""
from __future__ import annotations

import math
import re
from typing import Any

import jinja2

from crashscene.dsl.tokens import JUNCTIONS, LANE_CHANGES, OPPOSING_PASSES
from crashscene.render.errors import RenderError
from crashscene.render.plan import (
    BLUEPRINT_DIMS,
    Placement,
    Range,
    RenderPlan,
    model_pool,
    placement_order,
    speed_basis,
)
from crashscene.render.plan import search_parameters as plan_search_parameters

__all__ = ["comment", "program_context", "program_text", "py", "render_program", "rng"]

PROGRAM_NAME = "scenario.scenic"
MAP_NAME = "map.xodr"
SAFE_TOKEN = re.compile(r"^[A-Za-z0-9_.,\-]{0,200}$")  # tokens, blueprint ids, comma-joined code lists
LOSS_STEER = (-0.6, 0.6)  # [-] steering held after losing control


def py(value: Any) -> str:
    """Print a value as a Python literal, refusing anything but tokens, numbers, None and containers of them."""
    if value is None or isinstance(value, bool):
        return repr(value)
    if isinstance(value, int):
        return repr(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise RenderError(f"non-finite number {value!r} cannot be rendered")
        return repr(float(value))
    if isinstance(value, str):
        if not SAFE_TOKEN.match(value):
            raise RenderError(f"value {value!r} is not a closed-vocabulary token; refusing to render it into code")
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(py(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{py(str(k))}: {py(v)}" for k, v in value.items()) + "}"
    raise RenderError(f"cannot render a {type(value).__name__} into code")


def comment(value: Any) -> str:
    """Free text as one inert comment line: printable ASCII, escapes for everything else, Jinja kept literal."""
    text = "" if value is None else str(value)
    text = text.encode("unicode_escape").decode("ascii")
    return "".join(ch if 32 <= ord(ch) < 127 else "?" for ch in text)[:500]


def rng(value: Range | dict) -> str:
    """A sampled parameter as Scenic code: VerifaiRange(low, high), or a constant when low == high."""
    low, high = (value["low"], value["high"]) if isinstance(value, dict) else (value.low, value.high)
    if low == high:
        return py(float(low))
    return f"VerifaiRange({py(float(low))}, {py(float(high))})"


_ENV = jinja2.Environment(loader=jinja2.PackageLoader("crashscene.render", "templates"), autoescape=False,
                          undefined=jinja2.StrictUndefined, keep_trailing_newline=True)
_ENV.filters.update(py=py, comment=comment, rng=rng)


def _behavior_call(actor: dict[str, Any]) -> str:
    p = "globalParameters." + actor["prefix"]
    b = actor["behavior"]
    if b == "static":
        return "CsStatic()"
    if b == "stop":
        return f"CsStop({p}_STOP_DURATION, {p}_PROCEED_SPEED)"
    if b == "decelerate":
        return f"CsDecelerate({p}_SPEED, {p}_MANEUVER_TIME)"
    if b in LANE_CHANGES:
        return f"CsChangeLane({p}_SPEED, {p}_MANEUVER_TIME, {py(b.rsplit('_', 1)[1])})"
    if b == "cross_centerline":
        return f"CsCrossCenterline({p}_SPEED, {p}_MANEUVER_TIME, 0)"
    if b == "overtake":
        return f"CsCrossCenterline({p}_SPEED, {p}_MANEUVER_TIME, 3)"
    if b == "lose_control":
        return f"CsLoseControl({p}_SPEED, {p}_MANEUVER_TIME, {p}_LOSS_STEER)"
    if b == "leave_road":
        return f"CsLeaveRoad({p}_SPEED, {p}_MANEUVER_TIME)"
    return f"CsCruise({p}_SPEED)"  # go_forward, turn_left, turn_right, u_turn


def _needs(actor, actors) -> dict[str, int]:
    """Lanes an actor's start lane must offer: same-direction lanes left/right, an oncoming lane; "centre": no
    same-direction lane on its left (the lane beside the centre line, `ActorPlan.centre_lane`; a preference)."""
    left = right = 0
    oncoming = actor.behavior in OPPOSING_PASSES
    if actor.behavior == "change_lane_left":
        left = 1
    if actor.behavior == "change_lane_right":
        right = 1
    for other in actors:
        if other.placement_ref != actor.role or other.role == actor.role:
            continue
        if other.placement is Placement.SIDE_LEFT:
            left = max(left, 1)
        elif other.placement is Placement.SIDE_RIGHT:
            right = max(right, 1)
        elif other.placement is Placement.ONCOMING:
            oncoming = True
    needs = {"left": left, "right": right, "oncoming": int(oncoming)}
    if actor.centre_lane:  # only where set, so that the programs of every other scenario stay as they were
        needs["centre"] = 1
    return needs


def _actor_params(a: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """(name, range, unit note) of every global parameter an actor's program section declares, in order."""
    p = a["prefix"]
    out = [(f"{p}_SPEED", a["speed"], "[m/s]"), (f"{p}_INIT_DIST", a["init_dist"], "[m]")]
    if a["placement"] in ("side_left", "side_right"):
        out.append((f"{p}_SIDE_OFFSET", a["side_offset"], "[m], + = ahead of the reference"))
    if a["arrival_offset"]:
        out.append((f"{p}_ARRIVAL_OFFSET", a["arrival_offset"], "[s] arrival at the conflict point minus the ego's"))
    out.append((f"{p}_MANEUVER_TIME", a["maneuver_time"], "[s]"))
    if a["behavior"] == "stop":
        out += [(f"{p}_STOP_DURATION", a["stop_duration"], "[s]"), (f"{p}_PROCEED_SPEED", a["cruise_speed"], "[m/s]")]
    if a["behavior"] == "lose_control":
        out.append((f"{p}_LOSS_STEER", a["loss_steer"], "[-1, 1] steering held after control is lost"))
    return out


def render_program(plan: RenderPlan, *, scenario_hash_value: str, summary: str | None = None,
                   carla_town: str | None = None, map_name: str = MAP_NAME) -> str:
    """The Scenic program text for a plan (pure: no files touched)."""
    return program_text(program_context(plan, carla_town=carla_town, map_name=map_name),
                        scenario_hash_value=scenario_hash_value, summary=summary)


def program_context(plan: RenderPlan, *, carla_town: str | None = None, map_name: str = MAP_NAME,
                    search_ads: str | None = None) -> dict[str, Any]:
    """What the template needs (and the compiled sampling plan reads): actors in placement order with their
    parameters, the placement specs handed to `scenic_support.candidates`, and the program's constants.
    `search_ads`: the role of the ADS in a search; the other actors' timing choices are declared too
    (`plan.search_parameters`)."""
    actors = []
    lengths = {}
    for actor in placement_order(plan.actors):
        prefix = "EGO" if actor.role == "ego" else actor.role
        pool = actor.blueprints
        model_param = None
        if search_ads is not None and len(pool) > 1:   # the search picks the model (plan.search_parameters)
            pool, model_param = model_pool(pool), f"{prefix}_MODEL_INDEX"
        for bp in pool:
            if bp not in BLUEPRINT_DIMS:
                raise RenderError(f"blueprint {bp!r} has no dimensions in crashscene.render.plan.BLUEPRINT_DIMS")
        if len(pool) == 1:
            bp_expr = py(pool[0])
            length_expr, width_expr = py(BLUEPRINT_DIMS[pool[0]][0]), py(BLUEPRINT_DIMS[pool[0]][1])
        else:
            bp_expr = f"_bp_{actor.role}"
            length_expr, width_expr = f"_dim({bp_expr}, 0)", f"_dim({bp_expr}, 1)"
        lengths[actor.role] = max(BLUEPRINT_DIMS[bp][0] for bp in pool)
        data = actor.model_dump()
        data.update(
            prefix=prefix, blueprint_expr=bp_expr, length_expr=length_expr, width_expr=width_expr,
            blueprint_pool=pool, model_param=model_param,
            gap=0.5 * (lengths[actor.role] + lengths.get(actor.placement_ref, lengths[actor.role])),
            oncoming_sign=-1.0 if actor.along == "behind" else 1.0,
            cruise_speed=_cruise(actor, plan), loss_steer=Range(low=LOSS_STEER[0], high=LOSS_STEER[1]),
            placement=actor.placement.value)
        data["behavior_call"] = _behavior_call(data)
        data["params"] = _actor_params(data)
        if search_ads is not None:
            data["params"] += plan_search_parameters(plan, actor, prefix, is_ads=actor.role == search_ads)
        actors.append(data)
    actor_specs = [{"role": a["role"], "placement": a["placement"], "ref": a["placement_ref"],
                    "heading": a["relative_heading"], "maneuver": a["maneuver"], "behavior": a["behavior"],
                    "needs": _needs(next(x for x in plan.actors if x.role == a["role"]), plan.actors),
                    "dist": [a["init_dist"]["low"], a["init_dist"]["high"]], "along": a["along"],
                    "gap": a["gap"]}
                   for a in actors]
    return dict(
        room=_room(actors), plan=plan, actors=actors, actor_specs=actor_specs, notes=plan.notes,
        scenario_id=plan.scenario_id, map_name=map_name, carla_town=carla_town,
        ego_roads=[] if carla_town else ["road1"],
        anchor_hint=float(plan.map.back_length) if carla_town is None else 40.0,
        curve_sign=1 if (plan.map.curve_direction or "left") == "left" else -1)


def program_text(context: dict[str, Any], *, scenario_hash_value: str, summary: str | None) -> str:
    """The program text for a `program_context` (pure)."""
    from crashscene import __version__ as version

    actors = context["actors"]
    text = _ENV.get_template("scenario.scenic.j2").render(
        summary=summary, scenario_hash=scenario_hash_value, version=version, **context)
    pools = {a["role"]: a["blueprint_pool"] for a in actors if len(a["blueprint_pool"]) > 1}
    if pools:
        head, marker, tail = text.partition("# ---- actors ----\n")
        dims = {bp: list(BLUEPRINT_DIMS[bp]) for pool in pools.values() for bp in pool}
        extra = [f"_DIMS = {py(dims)}  # [m] (length, width) per blueprint", "",
                 "@_distributionFunction", "def _dim(bp, index):", "    return _DIMS[bp][index]", ""]
        picked = {a["role"]: a["model_param"] for a in actors if a["model_param"]}
        if picked:
            extra += ["@_distributionFunction", "def _model(pool, value):",
                      "    return pool[min(max(int(value), 0), len(pool) - 1)]", ""]
        extra += [f"_bp_{role} = _model({py(pool)}, globalParameters.{picked[role]})" if role in picked
                  else f"_bp_{role} = Uniform(*{py(pool)})" for role, pool in pools.items()]
        text = head + marker + "\n".join(extra) + "\n" + tail
    return text


def _room(actors: list[dict[str, Any]]) -> list[float]:
    """[m] (behind, ahead) of the anchor, along the ego's route, that the actors placed from it reach at most."""
    extent: dict[str, float] = {}  # [m] position along the ego's route, relative to the anchor
    direction: dict[str, float] = {}  # +1: drives the ego's way, -1: oncoming
    for a in actors:
        dist = a["init_dist"]["high"]
        sign = 1.0 if a["along"] == "front" else -1.0
        ref = a["placement_ref"]
        if a["placement"] == "anchor":
            extent[a["role"]], direction[a["role"]] = sign * dist, 1.0
        elif a["placement"] == "follow" and ref in extent:
            extent[a["role"]] = extent[ref] + direction[ref] * sign * (dist + a["gap"])
            direction[a["role"]] = direction[ref]
        elif a["placement"] == "oncoming" and ref in extent:
            # placed by projecting a point of the reference's route: that point must exist
            extent[a["role"]], direction[a["role"]] = extent[ref] + direction[ref] * sign * dist, -direction[ref]
        elif a["placement"] in ("side_left", "side_right") and ref in extent:
            extent[a["role"]] = extent[ref] + direction[ref] * a["side_offset"]["high"]
            direction[a["role"]] = direction[ref]
    behind = max([-v for v in extent.values()] + [0.0]) + 10.0
    ahead = max([*extent.values(), 0.0]) + 10.0
    return [round(behind, 1), round(ahead, 1)]


def _cruise(actor, plan: RenderPlan) -> Range:
    """[m/s] speed a stopped actor proceeds at."""
    if actor.speed.high > 0:
        return actor.speed
    limit = speed_basis(plan.speed_limit, plan.topology in JUNCTIONS, plan.number_of_ways, plan.number_of_lanes)
    return Range(low=round(max(2.0, 0.5 * limit - 2.0), 3), high=round(0.5 * limit + 2.0, 3))
