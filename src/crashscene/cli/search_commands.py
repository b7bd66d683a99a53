"""`crashscene search`: adaptive search of a scenario's sampled parameters for ADS failures (test mode)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


@app.command()
def search(
    file: Annotated[Path, typer.Argument(help="Scenario file (DSL YAML).")],
    budget: Annotated[int, typer.Option("--budget", help="Variations to evaluate in total.")] = 400,
    sampler: Annotated[str, typer.Option("--sampler", help="random, halton, ce (VerifAI cross-entropy), bo "
                                                           "(Bayesian optimisation, Optuna TPE) or cmaes "
                                                           "(CMA-ES, pycma).")] = "ce",
    objective: Annotated[str, typer.Option("--objective", help="robustness (min rule robustness of the ADS, a "
                                                               "collision lowest) or ttc (its min time to "
                                                               "collision).")] = "robustness",
    seed: Annotated[int, typer.Option("--seed", help="Same seed, same search.")] = 0,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("out/search"),
    ads: Annotated[str | None, typer.Option("--ads", help="User ADS driver 'package.module:Class' "
                                                           "(default: the reference ADS).")] = None,
    rounds: Annotated[int, typer.Option("--rounds", help="Rounds of budget/rounds variations (each one batch).")] = 8,
    ego: Annotated[str, typer.Option("--ego", help="DSL role driven by the ADS under test; auto: the seat the "
                                                   "report's hazard came at (V2's when V1's own swerve caused "
                                                   "the crash; crashscene.search.seat).")] = "ego",
    as_json: Annotated[bool, typer.Option("--json", help="Summary as JSON on stdout.")] = False,
) -> None:
    """Search FILE's VerifaiRange parameters in rounds for variations where the ADS fails; write --out."""
    from crashscene.dsl import DslError, load_file
    from crashscene.search import SearchError, search_scenario
    from crashscene.search.run import SUMMARY_KEYS, check_request
    from crashscene.simulate.backend import SimulationError

    try:
        check_request(budget, sampler, objective, rounds)
        scenario = load_file(file)
        summary = search_scenario(scenario, out, budget=budget, sampler=sampler, objective=objective, seed=seed,
                                  ads=ads, rounds=rounds, ego_role=ego)
    except (SearchError, SimulationError) as exc:
        typer.echo(f"error: {file}: {exc}", err=True)
        raise typer.Exit(2) from None
    except DslError as exc:
        typer.echo(str(exc), err=True)
        raise typer.Exit(2) from None
    except OSError as exc:
        typer.echo(f"error: {file}: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None
    if as_json:
        typer.echo(json.dumps({key: summary[key] for key in SUMMARY_KEYS}, indent=2))
        return
    typer.echo(f"{summary['evaluated']} variations [{sampler}, {objective}] in {summary['seconds']:.1f} s -> {out}")
    typer.echo(f"  the ADS drives {summary['ego_role']}; failures: {summary['failures']}; "
               f"min objective: {summary['min_objective']}")
    typer.echo(f"  best parameters: {summary['best_parameters']}")
    for rule in summary["rules"]:
        typer.echo(f"  {rule['rule']}")
