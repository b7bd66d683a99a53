"""`crashscene render` (DSL -> Scenic program + OpenDRIVE map) and `crashscene sample` (program -> scenes)."""
from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


def _town_overrides(values: list[str]) -> dict[str, str]:
    out = {}
    for item in values:
        town, sep, other = item.partition("=")
        if not sep or not town or not other:
            raise typer.BadParameter(f"{item!r}: expected TOWN=OTHER, e.g. Town05=Town10HD", param_hint="--town")
        out[town] = other
    return out


@app.command()
def render(
    file: Annotated[Path, typer.Argument(help="Scenario file (DSL YAML).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Directory to write scenario.scenic and map.xodr into.")],
    map_mode: Annotated[str, typer.Option("--map", help="generated (OpenDRIVE built for the scenario) or carla "
                                                         "(a CARLA town from --carla-maps).")] = "generated",
    carla_maps: Annotated[Path | None, typer.Option("--carla-maps", help="Folder of CARLA town .xodr files "
                                                                             "(Town02, Town04, Town05).")] = None,
    town: Annotated[list[str], typer.Option("--town", help="Substitute a town, e.g. Town05=Town10HD "
                                                          "(repeatable).")] = [],  # noqa: B006
    cache_dir: Annotated[Path | None, typer.Option("--cache-dir", help="Map cache (default "
                                                                          "~/.cache/crashscene/maps).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the written paths and hash as JSON.")] = False,
) -> None:
    """Render FILE into OUT/scenario.scenic (Scenic 3.1, 2D, CARLA or Newtonian model) and OUT/map.xodr."""
    from crashscene.dsl import DslError, load_file
    from crashscene.render import RenderError
    from crashscene.render import render as render_scenario

    if map_mode not in ("generated", "carla"):
        raise typer.BadParameter(f"{map_mode!r}; allowed: generated, carla", param_hint="--map")
    if out.exists() and not out.is_dir():
        typer.echo(f"error: -o {out}: is a file; give a folder to write scenario.scenic and map.xodr into", err=True)
        raise typer.Exit(2)
    try:
        scenario = load_file(file)
        rendered = render_scenario(scenario, out, map_mode=map_mode, carla_maps=carla_maps, cache_dir=cache_dir,
                                   town_override=_town_overrides(town))
    except DslError as exc:
        for diag in exc.diagnostics:
            typer.echo(str(diag), err=True)
        raise typer.Exit(1) from None
    except (RenderError, OSError) as exc:
        typer.echo(f"{file}: render failed: {exc}", err=True)
        raise typer.Exit(1) from None
    info = {"program": str(rendered.program), "map": str(rendered.map), "scenario_hash": rendered.scenario_hash,
            "town": rendered.town}
    if as_json:
        typer.echo(json.dumps(info, indent=2))
    else:
        typer.echo(f"wrote {rendered.program} and {rendered.map} (hash {rendered.scenario_hash}"
                   + (f", {rendered.town}" if rendered.town else "") + ")")


@app.command()
def sample(
    program: Annotated[Path, typer.Argument(help="Rendered program (DIR/scenario.scenic).")],
    n: Annotated[int, typer.Option("-n", min=0, help="Number of scenes.")] = 10,
    seed: Annotated[int, typer.Option("--seed", help="Scene i depends only on (program, seed, i).")] = 0,
    first: Annotated[int, typer.Option("--first", min=0, help="Index of the first scene.")] = 0,
    model: Annotated[str, typer.Option("--model", help="carla or newtonian world model (2D mode).")] = "carla",
    as_json: Annotated[bool, typer.Option("--json", help="One JSON scene per line (SampledScene) instead of a "
                                                         "table.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the JSON lines to this file.")]
    = None,
    sampler: Annotated[str, typer.Option("--sampler", help="compiled (numpy, from render's sampler.json) or scenic "
                                                         "(Scenic's own sampler; needed for --model newtonian).")]
    = "compiled",
) -> None:
    """Sample N scenes from a rendered program: positions, headings, speeds, properties, parameter values."""
    import warnings

    from crashscene.render import RenderError
    from crashscene.render.sample import CARLA_MODEL, NEWTONIAN_MODEL, sample_scenes

    models = {"carla": CARLA_MODEL, "newtonian": NEWTONIAN_MODEL}
    if model not in models:
        raise typer.BadParameter(f"{model!r}; allowed: carla, newtonian", param_hint="--model")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "carla package not installed": irrelevant to sampling
            scenes = sample_scenes(program, n, seed, first=first, model=models[model], sampler=sampler)
    except RenderError as exc:
        typer.echo(f"sample failed: {exc}", err=True)
        raise typer.Exit(1) from None
    lines = [scene.model_dump_json() for scene in scenes]
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text("".join(line + "\n" for line in lines), encoding="utf-8")
    if as_json:
        sys.stdout.write("".join(line + "\n" for line in lines))
    elif output is None or not as_json:
        for scene in scenes:
            typer.echo(f"scene {scene.index}: " + "; ".join(
                f"{a.role} ({a.x:.1f}, {a.y:.1f}) yaw {a.yaw:.2f} rad {a.speed:.1f} m/s {a.route_intent}"
                for a in scene.actors))
        if output is not None:
            typer.echo(f"wrote {len(scenes)} scenes to {output}")
