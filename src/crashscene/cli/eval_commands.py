"""`crashscene eval`: score extracted scenarios against golden files (dsl.md section 4)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


_GOLD_HELP = "Golden scenarios: <case>.yaml files or <case>/golden.yaml folders."
_PRED_HELP = "Predicted scenarios, same layouts (<case>.yaml, or <case>/ with golden.yaml, scenario.yaml or one .yaml)."
_MISSING_HELP = "Score golden cases without a prediction as 0 and ignore extra predictions instead of failing."


@app.command("eval")
def eval_command(
    gold: Annotated[Path, typer.Option("--gold", help=_GOLD_HELP)],
    pred: Annotated[Path, typer.Option("--pred", help=_PRED_HELP)],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable result on stdout.")] = False,
    allow_missing: Annotated[bool, typer.Option("--allow-missing", help=_MISSING_HELP)] = False,
    diffs: Annotated[bool, typer.Option("--diffs/--no-diffs", help="Per-case diffs in the text report.")] = True,
) -> None:
    """Score predictions against golden files (dsl.md section 4): per-component and overall accuracy, oracle
    precision, extensions, a per-field confusion table and per-case diffs. Exit 2 on unusable inputs."""
    from crashscene.evaluate import EvalError, evaluate_dirs, format_result

    try:
        result = evaluate_dirs(gold, pred, allow_missing=allow_missing)
    except EvalError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    if as_json:
        typer.echo(json.dumps(result.to_json(), indent=2))
    else:
        typer.echo(format_result(result, diffs=diffs))
