"""Render stage: a DSL scenario -> a Scenic 3.1 program (`scenario.scenic`), its map (`map.xodr`) and sampler.

The stage flows one way, each step importing only the steps before it:

1. `plan`: DSL -> `RenderPlan`, every default decided (tokens and numbers only);
2. `maps` (+ `opendrive`): the plan's map, generated or a CARLA town, cached;
3. `program` (+ `scenic_support`, imported by every program): the plan printed into Scenic;
4. `sampling_plan`, `compiled_sampler`, `sample`: the program's distribution as data, and
   scenes drawn from it (numpy) or from the program itself (Scenic, the reference).

`render` below runs steps 1-3 and writes the sampling plan; `crashscene.render.sample`
draws scenes from what it wrote. Errors: `crashscene.render.errors`.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from crashscene.dsl.model import Scenario
from crashscene.render.errors import RenderError, SampleError
from crashscene.render.maps import install_map, prepare_map
from crashscene.render.plan import RenderPlan, convert, scenario_hash
from crashscene.render.program import MAP_NAME, PROGRAM_NAME, program_context, program_text, render_program
from crashscene.render.sampling_plan import SAMPLING_PLAN_NAME, sampling_plan, write_sampling_plan

__all__ = ["RenderError", "Rendered", "SampleError", "render", "render_program"]


@dataclass(frozen=True)
class Rendered:
    program: Path
    map: Path
    scenario_hash: str
    town: str | None = None


def render(scenario: Scenario, out_dir: Path, map_mode: str = "generated", carla_maps: Path | None = None,
           cache_dir: Path | None = None, town_override: dict[str, str] | None = None,
           search_ads: str | None = None) -> Rendered:
    """Write out_dir/scenario.scenic, map.xodr, sampler.json and render.json for the scenario.

    `search_ads`: for a test-mode search, the role the ADS takes; the program then also declares the timing
    choices the embedded simulator otherwise draws per variation for the other actors (`plan.search_parameters`),
    so that the search can steer them. None (default): the program is unchanged."""
    out_dir = Path(out_dir)
    plan = convert(scenario)
    cached, town = prepare_map(plan, map_mode, carla_maps, cache_dir, town_override)
    digest = scenario_hash(scenario, map_mode=map_mode, town=town or "")
    context = program_context(plan, carla_town=town, search_ads=search_ads)
    text = program_text(context, scenario_hash_value=digest, summary=scenario.summary)
    out_dir.mkdir(parents=True, exist_ok=True)
    map_path = install_map(cached, out_dir, MAP_NAME)
    program = out_dir / PROGRAM_NAME
    program.write_text(text, encoding="utf-8")
    write_sampling_plan(out_dir / SAMPLING_PLAN_NAME, sampling_plan(context, text))
    (out_dir / "render.json").write_text(_meta_json(plan, digest, map_mode, town), encoding="utf-8")
    return Rendered(program=program, map=map_path, scenario_hash=digest, town=town)


def _meta_json(plan: RenderPlan, digest: str, map_mode: str, town: str | None) -> str:
    return json.dumps({"scenario_hash": digest, "map_mode": map_mode, "town": town, "program": PROGRAM_NAME,
                       "map": MAP_NAME, "plan": plan.model_dump(mode="json")}, indent=2, sort_keys=True) + "\n"
