"""`crashscene eval --folds K`: deterministic balanced folds, per-fold scores, the held-out figure."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.dsl import load_file
from crashscene.evaluation.folds import assign_folds, evaluate_folds
from crashscene.evaluation.score import EvalError
from crashscene.extract.rule_sources import (
    DEDUCED_FROM_THE_SPECS,
    FIRES_ON_NO_BUNDLED_CASE,
    FROM_CONVENTIONS,
    RULE_SOURCES,
)

CIREN = Path(__file__).resolve().parents[2] / "examples" / "ciren"
CASES = sorted(p.name for p in CIREN.resolve().iterdir() if p.is_dir())


def test_folds_are_balanced_deterministic_and_order_independent():
    folds = assign_folds(CASES, 4)
    assert folds == assign_folds(list(reversed(CASES)), 4)
    sizes = [list(folds.values()).count(k) for k in range(4)]
    assert max(sizes) - min(sizes) <= 1 and sum(sizes) == len(CASES)
    with pytest.raises(EvalError, match="at least 2"):
        assign_folds(CASES, 1)
    with pytest.raises(EvalError, match="only 2 case"):
        assign_folds(["a", "b"], 3)


def test_a_fold_is_held_out_only_when_no_rule_names_its_cases():
    cases = CASES[:8]
    pairs = {case: (load_file(CIREN / case / "golden.yaml"),) * 2 for case in cases}
    folds = assign_folds(cases, 2)
    looked = [case for case in cases if folds[case] == 0][:2]
    per_fold, pooled = evaluate_folds(pairs, 2, {"some_rule": looked})
    assert [f.held_out for f in per_fold] == [False, True]
    assert pooled is not None and pooled.overall.accuracy == 1.0
    assert len(pooled.cases) == len(per_fold[1].cases)
    _, none = evaluate_folds(pairs, 2, {"a": [per_fold[0].cases[0], per_fold[1].cases[0]]})
    assert none is None


def test_record_of_rule_sources_names_real_cases_and_never_one_alone():
    for rule, cases in RULE_SOURCES.items():
        # a deduction rests on the specs' sentences, not on its case's phrasing (its case is held out all the same)
        assert len(set(cases)) >= 2 or rule in FROM_CONVENTIONS | FIRES_ON_NO_BUNDLED_CASE | DEDUCED_FROM_THE_SPECS, \
            f"{rule} rests on a single case"
        assert set(cases) <= set(CASES), f"{rule} names unknown cases"


def test_cli_folds_json_and_text():
    runner = CliRunner()
    result = runner.invoke(app, ["eval", "--gold", str(CIREN), "--pred", str(CIREN), "--folds", "4", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert [f["fold"] for f in data["folds"]] == [0, 1, 2, 3]
    held = [f for f in data["folds"] if f["held_out"]]
    assert (data["held_out"] is None) == (not held)
    assert all(f["overall"]["accuracy"] == 1.0 for f in data["folds"])
    text = runner.invoke(app, ["eval", "--gold", str(CIREN), "--pred", str(CIREN), "--folds", "4", "--no-diffs"])
    assert "held out" in text.output and "fold 3:" in text.output
