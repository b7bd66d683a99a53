"""`crashscene eval`: score extracted scenarios against golden files (dsl.md section 4)."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


_GOLD_HELP = "Golden scenarios: <case>.yaml files or <case>/golden.yaml folders."
_PRED_HELP = "Predicted scenarios, same layouts (<case>.yaml, or <case>/ with golden.yaml, scenario.yaml or one .yaml)."
_FOLDS_HELP = ("Also split the cases into K folds (deterministic: ids ordered by SHA-256, dealt round-robin) and "
               "score each; a fold no extraction rule was written from (crashscene.extract.rule_sources) is "
               "reported as held out, with its per-field accuracy.")
_HELD_OUT_HELP = ("Instead of --pred: extract every <case>/ folder of --gold (its report and sketch) with the rules "
                  "backend, once with every rule on and once with each recorded rule written from that case (with "
                  "--folds K: from any case of its fold) switched off (crashscene.extract.rule_sources), and "
                  "report both figures per field and what each recorded rule wins on its sources and elsewhere.")
_MISSING_HELP = "Score golden cases without a prediction as 0 and ignore extra predictions instead of failing."


@app.command("eval")
def eval_command(
    gold: Annotated[Path, typer.Option("--gold", help=_GOLD_HELP)],
    pred: Annotated[Path | None, typer.Option("--pred", help=_PRED_HELP)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable result on stdout.")] = False,
    allow_missing: Annotated[bool, typer.Option("--allow-missing", help=_MISSING_HELP)] = False,
    diffs: Annotated[bool, typer.Option("--diffs/--no-diffs", help="Per-case diffs in the text report.")] = True,
    folds: Annotated[int | None, typer.Option("--folds", min=2, help=_FOLDS_HELP)] = None,
    held_out: Annotated[bool, typer.Option("--held-out", help=_HELD_OUT_HELP)] = False,
) -> None:
    """Score predictions against golden files (dsl.md section 4): per-component and overall accuracy, oracle
    precision, extensions, a per-field confusion table and per-case diffs. Exit 2 on unusable inputs."""
    from crashscene.evaluation.folds import evaluate_folds, format_folds
    from crashscene.evaluation.score import EvalError, evaluate, format_result, load_pairs
    from crashscene.extract.rule_sources import RULE_SOURCES

    if held_out or pred is None:
        _held_out(gold, pred, folds, held_out, as_json)
        return
    try:
        pairs, errors, extra = load_pairs(gold, pred, allow_missing=allow_missing)
        result = evaluate(pairs, errors)
        result.ignored_predictions = extra
        per_fold, held_out = evaluate_folds(pairs, folds, RULE_SOURCES, errors) if folds else ([], None)
    except EvalError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    if as_json:
        out = result.to_json()
        if folds:
            out["folds"] = [{"fold": f.fold, "cases": f.cases, "held_out": f.held_out, **_summary(f.result)}
                            for f in per_fold]
            out["held_out"] = _summary(held_out) if held_out else None
        typer.echo(json.dumps(out, indent=2))
    else:
        typer.echo(format_result(result, diffs=diffs))
        if folds:
            typer.echo("")
            typer.echo(format_folds(per_fold, held_out))


def _summary(result) -> dict:
    """The headline figures of one result (no per-case diffs)."""
    full = result.to_json()
    return {key: full[key] for key in ("overall", "components", "oracle_precision", "extensions", "fields")}


def _held_out(gold: Path, pred: Path | None, folds: int | None, held_out: bool, as_json: bool) -> None:
    """`eval --held-out`: the extraction is part of the measurement, so there is no --pred."""
    from crashscene.evaluation.score import EvalError
    from crashscene.extract.held_out import evaluate_held_out, format_held_out

    if not held_out:
        typer.echo("error: give --pred DIR (predictions to score) or --held-out (extract the cases of --gold here)",
                   err=True)
        raise typer.Exit(2)
    if pred is not None:
        typer.echo(f"error: --held-out extracts the cases itself; drop --pred {pred}", err=True)
        raise typer.Exit(2)
    try:
        result = evaluate_held_out(gold, folds)
    except EvalError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(json.dumps(result.to_json(), indent=2) if as_json else format_held_out(result))
