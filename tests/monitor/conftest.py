"""Monitor test fixtures: evaluate hand-built tables and pick one rule's row."""
from __future__ import annotations

import pytest

from crashscene.monitor import evaluate


def rule_row(result, code: str, actor: str, variation: int = 0) -> dict:
    rows = result.rule_results.to_pylist()
    for row in rows:
        if row["code"] == code and row["actor"] == actor and row["variation"] == variation:
            return row
    raise AssertionError(f"no row for {code} {actor} variation {variation}")


@pytest.fixture
def check():
    """check(tables, code, actor, scenario=None) -> the rule_results row."""

    def run(tables, code, actor, scenario=None, rulebook=None):
        return rule_row(evaluate(tables, scenario, rulebook), code, actor)

    return run
