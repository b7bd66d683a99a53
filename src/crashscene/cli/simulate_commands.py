"""`crashscene simulate`: render, sample and simulate one scenario file into a run directory."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from crashscene.cli import app
from crashscene.cli.simulation_options import (
    AdsOpt,
    CarlaHostOpt,
    CarlaPortOpt,
    DtOpt,
    HorizonOpt,
    MapOpt,
    parse_ads_params,
)


@app.command()
def simulate(
    file: Annotated[Path, typer.Argument(help="Scenario file (DSL YAML).")],
    n: Annotated[int, typer.Option("-n", min=1, help="Number of variations.")] = 100,
    seed: Annotated[int, typer.Option("--seed", help="Variation i depends only on (scenario, seed, i).")] = 0,
    first: Annotated[int, typer.Option("--first", min=0, help="Index of the first variation.")] = 0,
    mode: Annotated[str, typer.Option("--mode", help="test: the ego role is the ADS under test; "
                                                    "reproduce: every actor replays the report.")] = "test",
    backend: Annotated[str, typer.Option("--backend", "--simulator", help="embedded (default), newtonian, carla, "
                                                          "a plugin's name or 'package.module:Class'.")] = "embedded",
    ego: Annotated[str, typer.Option("--ego", help="DSL role handed to the ADS under test.")] = "ego",
    out: Annotated[Path, typer.Option("--out", "-o", help="Run directory to write.")] = Path("out/simulate"),
    ads: AdsOpt = None,
    ads_param: Annotated[list[str], typer.Option("--ads-param", help="ADS parameter KEY=VALUE (repeatable), "
                                                                   "e.g. reaction_time=0.8.")] = [],  # noqa: B006
    dt: DtOpt = 0.1,
    horizon: HorizonOpt = 20.0,
    workers: Annotated[Optional[int], typer.Option("--workers", min=1, help="Processes simulating blocks of "
                                                  "variations (same bytes for any value) (default: all cores).")] = None,
    sampler: Annotated[Optional[str], typer.Option("--sampler", help="compiled (numpy, from render's sampler.json) "
                                                   "or scenic (Scenic's own sampler, the reference) (default: "
                                                   "compiled; scenic for newtonian and carla).")] = None,
    map_mode: MapOpt = "generated",
    carla_maps: Annotated[Path | None, typer.Option("--carla-maps", help="Folder of CARLA .xodr towns.")] = None,
    carla_host: CarlaHostOpt = "127.0.0.1",
    carla_port: CarlaPortOpt = 2000,
    as_json: Annotated[bool, typer.Option("--json", help="Summary as JSON on stdout.")] = False,
    refine: Annotated[bool, typer.Option("--refine/--no-refine", help="Reproduce mode: check each variation's plan "
                                         "against the simulator and replan one that misses the written crash "
                                         "sequence (embedded backend); --no-refine: the analytic plans alone.")
                      ] = True,
) -> None:
    """Render, sample and simulate FILE; write traces, the monitor's verdicts and summary.json into --out."""
    from crashscene.dsl import DslError, load_file
    from crashscene.pipeline.simulate import arrow_without_pandas, simulate_scenario
    from crashscene.simulate.backend import AdsError, SimulationError

    arrow_without_pandas()
    try:
        scenario = load_file(file)
    except DslError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    except OSError as exc:
        typer.echo(f"error: {file}: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None
    params = parse_ads_params(ads_param)
    show_bar = not as_json and sys.stderr.isatty()
    try:
        if show_bar:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TimeElapsedColumn,
            )

            with Progress("[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(),
                          TimeElapsedColumn(), transient=True) as bar:
                task = bar.add_task(f"simulating {file.name}", total=n)
                summary = simulate_scenario(
                    scenario, out, n=n, seed=seed, first=first, mode=mode, backend=backend, ego_role=ego,
                    map_mode=map_mode, carla_maps=carla_maps, ads=ads, ads_params=params, dt=dt, horizon=horizon,
                    carla_host=carla_host, carla_port=carla_port, progress=lambda k: bar.advance(task, k),
                    workers=workers or os.cpu_count() or 1, sampler=sampler, refine=refine)
        else:
            summary = simulate_scenario(
                scenario, out, n=n, seed=seed, first=first, mode=mode, backend=backend, ego_role=ego,
                map_mode=map_mode, carla_maps=carla_maps, ads=ads, ads_params=params, dt=dt, horizon=horizon,
                carla_host=carla_host, carla_port=carla_port, workers=workers or os.cpu_count() or 1, sampler=sampler,
                refine=refine)
    except AdsError as exc:  # the ADS under test failed, not the scenario file
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    except SimulationError as exc:
        typer.echo(f"error: {file}: {exc}", err=True)
        raise typer.Exit(2) from None
    except Exception as exc:  # other stages' families (render, monitor) and pydantic validation of options
        typer.echo(f"error: {file}: {type(exc).__name__}: {exc}", err=True)
        raise typer.Exit(2) from None
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    coll = summary["collisions"]
    typer.echo(f"{summary['variations']} variations ({summary['valid']} valid) in {summary['seconds']:.1f} s "
               f"[{summary['backend']}, {summary['mode']}] -> {out}")
    for reason, count in summary["invalid"].items():
        typer.echo(f"  invalid x{count}: {reason}")
    typer.echo(f"  collisions: {coll['variations_with_collision']} variations; by class {coll['by_class']}")
    if "verdicts" in summary:
        typer.echo(f"  verdicts: {summary['verdicts']}; reproduced: {summary.get('reproduced')}; first contact "
                   f"rate: {summary.get('first_contact_rate')}")
        for code, actors in summary.get("violations", {}).items():
            typer.echo(f"  {code}: {actors}")
