"""Extraction accuracy per fold: the bundled cases split into K folds, deterministically (issue 11).

Rules written while looking at some cases must be judged on the others. `assign_folds` orders the case ids
by their SHA-256 and deals them round-robin into K folds, so a case's fold depends only on the set of ids
and K (never on file order or a random seed). `evaluate_folds` scores every fold apart with
`crashscene.evaluation.score.evaluate` and marks a fold *held out* when the record of rule sources
(`crashscene.extract.rule_sources.RULE_SOURCES`) names none of its cases; the held-out figure pools the
held-out folds.
"""
from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping

from pydantic import BaseModel

from crashscene.dsl import Scenario
from crashscene.evaluation.score import EvalError, EvalResult, evaluate
from crashscene.evaluation.score import _pct  # one percentage format for both reports


class FoldResult(BaseModel):
    """One fold's cases, whether any rule was written from them, and their scores."""

    fold: int
    cases: list[str]
    held_out: bool
    result: EvalResult


def assign_folds(cases: Iterable[str], k: int) -> dict[str, int]:
    """Case id -> fold in 0..k-1: ids ordered by SHA-256, dealt round-robin (balanced, order-independent)."""
    if k < 2:
        raise EvalError(f"--folds must be at least 2, got {k}")
    ordered = sorted(set(cases), key=lambda case: hashlib.sha256(case.encode()).hexdigest())
    if len(ordered) < k:
        raise EvalError(f"--folds {k}: only {len(ordered)} case(s); give at most {len(ordered)} folds")
    return {case: index % k for index, case in enumerate(ordered)}


def looked_at(sources: Mapping[str, Iterable[str]]) -> set[str]:
    """Every case some rule was written from."""
    return {case for cases in sources.values() for case in cases}


def evaluate_folds(pairs: dict[str, tuple[Scenario, Scenario | None]], k: int,
                   sources: Mapping[str, Iterable[str]] | None = None,
                   errors: dict[str, str] | None = None) -> tuple[list[FoldResult], EvalResult | None]:
    """Per-fold results and the pooled result of the held-out folds (None when every fold was looked at)."""
    errors = errors or {}
    folds = assign_folds(pairs, k)
    seen = looked_at(sources or {})
    out: list[FoldResult] = []
    held_out_cases: list[str] = []
    for fold in range(k):
        cases = sorted(case for case, f in folds.items() if f == fold)
        held_out = not (seen & set(cases))
        result = evaluate({case: pairs[case] for case in cases}, {c: errors[c] for c in cases if c in errors})
        out.append(FoldResult(fold=fold, cases=cases, held_out=held_out, result=result))
        if held_out:
            held_out_cases += cases
    pooled = evaluate({case: pairs[case] for case in held_out_cases},
                      {c: errors[c] for c in held_out_cases if c in errors}) if held_out_cases else None
    return out, pooled


def format_folds(folds: list[FoldResult], pooled: EvalResult | None) -> str:
    """A table: one row per fold (overall, components, oracle precision), then the held-out per-field figures."""
    components = list(folds[0].result.components) if folds else []
    head = f"{'fold':<6} {'cases':>5} {'held out':>8} {'overall':>8} " + " ".join(f"{c[:12]:>12}" for c in components)
    lines = [head + f" {'oracle prec.':>12}"]
    for fold in folds:
        r = fold.result
        cells = " ".join(f"{_pct(r.components[c].accuracy):>12}" for c in components)
        lines.append(f"{fold.fold:<6} {len(fold.cases):>5} {'yes' if fold.held_out else 'no':>8} "
                     f"{_pct(r.overall.accuracy):>8} {cells} {_pct(r.oracle_precision.precision):>12}")
    for fold in folds:
        lines.append(f"fold {fold.fold}: {', '.join(fold.cases)}")
    if pooled is None:
        lines.append("held out: none (every fold holds a case some rule was written from)")
    else:
        lines.append(f"held out (folds no rule was written from): overall {_pct(pooled.overall.accuracy)}, "
                     + ", ".join(f"{name} {_pct(score.accuracy)}" for name, score in pooled.components.items())
                     + f", oracle precision {_pct(pooled.oracle_precision.precision)}")
        lines.append("held out per field: " + ", ".join(f"{name} {_pct(score.accuracy)}"
                                                        for name, score in pooled.fields.items()))
        extensions = ", ".join(f"{name} {score.correct}/{score.total}" for name, score in pooled.extensions.items()
                               if score.total)
        if extensions:
            lines.append(f"held out extensions: {extensions}")
    return "\n".join(lines)

