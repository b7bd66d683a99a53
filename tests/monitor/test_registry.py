"""The rule class is the one declaration of its code: every list elsewhere is derived from the registry.

Binds the declarations (code, token, rank, trace columns, prompt guidance,
reproduce-mode disposition) to what uses them: the DSL's monitored codes, the
extraction prompt, the drivers, the rulebook order, and the trace columns each
rule really reads (a rule evaluated on traces with every other column blanked
gives the same results).
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

import pyarrow as pa
import pytest

from crashscene.dsl import load_file
from crashscene.dsl.tokens import MONITORED_CODES, monitored_codes
from crashscene.monitor import Rulebook, evaluate
from crashscene.monitor.rules import BUILTIN_ORDER, Disposition, dispositions_of, registered_rules
from crashscene.traces import TRACE_SCHEMA, read_table

BUILTIN = [cls for cls in registered_rules().values() if cls.__module__.startswith("crashscene.monitor.rules.")]
SCENARIOS = Path(__file__).resolve().parent / "scenarios"
KEYS = ("variation", "actor", "step")


@pytest.mark.parametrize("cls", BUILTIN, ids=lambda c: c.code)
def test_builtin_rule_declares_everything(cls):
    assert cls.rank < float("inf") and cls.guide and cls.summary
    assert set(cls.columns) <= set(TRACE_SCHEMA.names), set(cls.columns) - set(TRACE_SCHEMA.names)
    assert all(isinstance(trait, Disposition) for trait in cls.disposition)


def test_rulebook_order_is_the_declared_rank():
    ranks = [cls.rank for cls in BUILTIN]
    assert ranks == sorted(ranks) and len(set(ranks)) == len(ranks)
    assert list(BUILTIN_ORDER) == [cls.code for cls in BUILTIN]


def test_monitored_codes_are_the_registry():
    assert MONITORED_CODES == monitored_codes() == {cls.code: cls.violation for cls in registered_rules().values()}


def test_prompt_shows_each_rules_guidance_with_its_token():
    from crashscene.extract.prompt import system_prompt

    prompt = system_prompt()
    for cls in BUILTIN:
        assert f"{cls.code} ({cls.violation}): {cls.guide}" in prompt


@pytest.mark.parametrize("cls", BUILTIN, ids=lambda c: c.code)
def test_a_driver_charged_with_the_code_gets_the_declared_traits(cls):
    from crashscene.simulate.drivers.behaviors import rules_for, speed_factor

    assert dispositions_of({cls.code}) == cls.disposition
    rules = rules_for(frozenset({cls.code}))
    assert rules.yields == (Disposition.NO_YIELD not in cls.disposition)
    assert rules.obey_red == (Disposition.RUNS_RED not in cls.disposition)
    assert rules.obey_stop == (Disposition.RUNS_STOP not in cls.disposition)
    assert rules.curve_speed == (Disposition.CARELESS not in cls.disposition)
    assert (speed_factor(frozenset({cls.code})) > 1.0) == (Disposition.SPEEDING in cls.disposition)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """Every end-to-end scenario (one per rule), simulated in reproduce mode: (scenario, tables) pairs."""
    from crashscene.pipeline.simulate import simulate_scenario

    runs = []
    for path in sorted(SCENARIOS.glob("*.yaml")):
        out = tmp_path_factory.mktemp(path.stem)
        scenario = load_file(path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scenario(scenario, out, n=4, seed=5, mode="reproduce", monitor=False)
        runs.append((scenario, {name: read_table(out, name) for name in ("traces", "actors", "collisions",
                                                                         "variations")}))
    return runs


def _blank_except(traces: pa.Table, keep: set[str]) -> pa.Table:
    columns = [col if name in keep or name in KEYS else pa.nulls(len(col), col.type)
               for name, col in zip(traces.column_names, traces.columns)]
    return pa.table(columns, schema=traces.schema)


def _rows(table: pa.Table) -> list[dict]:
    """Rows with NaN as None (NaN never equals itself)."""
    return [{k: None if isinstance(v, float) and math.isnan(v) else v for k, v in row.items()}
            for row in table.to_pylist()]


@pytest.mark.slow
@pytest.mark.parametrize("cls", BUILTIN, ids=lambda c: c.code)
def test_a_rule_reads_only_its_declared_columns(cls, simulated):
    only = Rulebook(params={code: other.Params(enabled=False) for code, other in registered_rules().items()
                            if code != cls.code})
    applicable = 0
    for scenario, tables in simulated:
        full = evaluate(tables, scenario, only).rule_results
        blanked = evaluate({**tables, "traces": _blank_except(tables["traces"], set(cls.columns))}, scenario,
                           only).rule_results
        assert _rows(blanked) == _rows(full), (cls.code, scenario.summary)
        applicable += sum(v != "not_applicable" for v in full.column("verdict").to_pylist())
    assert applicable > 0  # the comparison saw the rule at work
