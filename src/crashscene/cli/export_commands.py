"""`crashscene export`: a scenario (and a simulated run of it) to ASAM OpenSCENARIO XML 1.2 and OpenDRIVE 1.8."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


@app.command("export")
def export(
    scenario: Annotated[Path, typer.Argument(help="Scenario file (DSL YAML).")],
    out: Annotated[Path, typer.Option("--out", help="Directory for scenario.xosc, distribution.xosc, map.xodr and "
                                                    "variations/<i>.xosc.")],
    run_dir: Annotated[Path | None, typer.Option("--from", help="Run directory of `crashscene simulate` for this "
                                                                "scenario: its variations become concrete "
                                                                "scenarios (all valid ones by default).")] = None,
    variations: Annotated[str | None, typer.Option("--variations", help="Comma-separated variation indices to "
                                                                        "export, e.g. 3,17 (needs --from).")] = None,
    failing: Annotated[bool, typer.Option("--failing", help="Export the variations whose verdict is violation or "
                                                            "collision (needs --from and the monitor's "
                                                            "verdicts).")] = False,
    n: Annotated[int, typer.Option("-n", min=1, help="numberOfTestRuns of distribution.xosc without --from "
                                                     "(with --from: the run's count).")] = 100,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the reference scene and of distribution.xosc "
                                                     "without --from (with --from: the run's).")] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="Print the written paths as JSON.")] = False,
) -> None:
    """Export SCENARIO to OUT: the logical scenario, its parameter distribution, its map and, from a run, replays."""
    from crashscene.export import ExportError
    from crashscene.export.pipeline import export_scenario, parse_variations

    try:
        chosen = parse_variations(variations) if variations is not None else None
        result = export_scenario(scenario, out, run_dir=run_dir, variations=chosen, failing=failing, n=n, seed=seed)
    except ExportError as exc:
        typer.echo(f"export failed: {exc}", err=True)
        raise typer.Exit(1) from None
    if as_json:
        typer.echo(json.dumps(result.to_json(), indent=2))
    else:
        typer.echo(f"wrote {result.scenario}, {result.distribution}, {result.map}"
                   + (f", {result.parameter_sets} and {len(result.variations)} variation(s) in {out / 'variations'}"
                      if result.variations else ""))
