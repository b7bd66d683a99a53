"""`evaluate`: the rulebook, collisions and verdicts for a batch of trace tables (any backend's)."""
from __future__ import annotations

from typing import Literal

import numpy as np
import pyarrow as pa

from crashscene.dsl.model import Scenario
from crashscene.monitor.arrays import TraceArrays, build_arrays
from crashscene.monitor.collisions import classify_collisions, first_contact_steps
from crashscene.monitor.context import EvalContext, Whole
from crashscene.monitor.errors import MonitorError
from crashscene.monitor.judging import judged_until, upset_steps
from crashscene.monitor.result import MonitorResult, rule_results_table
from crashscene.monitor.rulebook import Rulebook
from crashscene.monitor.verdicts import (
    ExpectedCollision,
    ads_mask,
    expected_collision,
    invalid_reasons,
    verdict_table,
)


def evaluate(tables: dict[str, pa.Table], scenario: Scenario | None, rulebook: Rulebook | None = None, *,
             expected: ExpectedCollision | None | Literal["auto"] = "auto",
             stop_at_collision: bool = True, after_collision: float = 0.5,
             arrays: TraceArrays | None = None) -> MonitorResult:
    """Evaluate every actor of every variation in `tables` (see `crashscene.traces`).

    `scenario` supplies the environment (condition factors), the posted limit,
    the road layout, the oracle and the crash sequence (`collisions`) to
    reproduce. `expected` overrides the collision the report implies ("auto":
    the DSL's `collisions` when written, else derived from its actors; None:
    none).
    With `stop_at_collision`, an actor's rules see its trace up to
    `after_collision` [s] past its first collision that takes it out of its
    driver's control (`crashscene.monitor.judging`): what an upset vehicle does
    afterwards is not driving. A driver a light contact leaves in control is
    judged on.
    `arrays`: `build_arrays(tables)` when the caller has built them already (they are truncated in place).
    """
    rulebook = rulebook or Rulebook()
    arrays = build_arrays(tables) if arrays is None else arrays
    ads = ads_mask(arrays)                        # is_ads, or the ego standing in (reproduce mode): verdicts
    under_test = arrays.is_ads & arrays.present    # the tables report is_ads as the simulator set it
    collisions = classify_collisions(arrays, tables.get("collisions"), under_test)
    contact = first_contact_steps(arrays, collisions)
    invalid = invalid_reasons(arrays, ads, contact >= 0)   # on whole traces, before truncation
    upset, grace, whole = None, 0, None
    rules = rulebook.rules()
    if stop_at_collision:
        grace = round(after_collision / arrays.dt)
        upset = upset_steps(arrays, collisions, grace)
        whole = _whole_traces(arrays, rules, upset, grace)
        arrays.truncate(judged_until(upset, grace))
    ctx = EvalContext(arrays=arrays, scenario=scenario, collisions=collisions, driven_until=upset, grace=grace,
                      whole=whole)
    outcomes = []
    for rule in rules:
        try:
            outcome = rule.evaluate(ctx)
        except MonitorError:
            raise
        except Exception as exc:  # a user rule's bug must say which rule failed
            raise MonitorError(f"rule {rule.code} ({type(rule).__module__}.{type(rule).__qualname__}) failed: "
                               f"{type(exc).__name__}: {exc}") from exc
        outcomes.append((rule, outcome.finalize()))
    rule_results = rule_results_table(arrays.variations, arrays.roles, arrays.present, under_test, outcomes)
    if expected == "auto":  # the written crash sequence, else the collision the actors imply (older files)
        expected = expected_collision(scenario) if scenario is None or scenario.collisions is None else None
    verdicts, oracle = verdict_table(arrays, {r.code: o for r, o in outcomes}, collisions, scenario, ads, expected,
                                     invalid)
    rules = [{"code": r.code, "violation": r.violation, "unit": r.unit, "summary": r.summary,
              "params": r.params.model_dump(mode="json")} for r, _ in outcomes]
    return MonitorResult(rule_results=rule_results, collisions=collisions, verdicts=verdicts, rules=rules,
                         oracle=oracle, rulebook=rulebook.source)


def _whole_traces(arrays: TraceArrays, rules, upset: np.ndarray, grace: int) -> Whole | None:
    """A copy of the variations some rule reads past the judging end (`Rule.past_judging`), None when none does."""
    wanted = np.zeros(arrays.shape[0], dtype=bool)
    for rule in rules:
        asked = rule.past_judging(arrays, upset, grace)
        if asked is not None:
            wanted |= asked
    if not wanted.any():
        return None
    rows = np.nonzero(wanted)[0]
    return Whole(rows=rows, arrays=arrays.select(rows))
