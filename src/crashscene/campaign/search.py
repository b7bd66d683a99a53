"""`campaign --search SAMPLER --budget N`: one search per case (and sampler), run on the campaign's engine.

A search is the unit of resume: its summary row (`searches`) and its evaluated
variations (`search_evaluations`) are written in one transaction when it
finishes, and a resumed campaign skips every search already stored; a search
killed half-way is run again from its start (it is deterministic, so the rows
are the same). The search's folder is kept under OUT/<case>/search/<sampler>.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
from pydantic import BaseModel, ConfigDict, Field

from crashscene.campaign.errors import CampaignError
from crashscene.campaign.store import Store, _now


class SearchPlan(BaseModel):
    """The searches a campaign runs per case."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    samplers: tuple[str, ...] = Field(description="one search per sampler (random, halton, ce, bo, cmaes)")
    budget: int = Field(gt=0, description="variations per search")
    objective: str = "robustness"
    rounds: int = Field(default=8, ge=1)


class SearchTask(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    case_id: str
    scenario_yaml: str
    scenario_hash: str
    seed: int
    sampler: str
    objective: str
    budget: int
    rounds: int
    ego_role: str = "ego"
    out_dir: str

    @property
    def key(self) -> str:
        return f"{self.case_id}/search/{self.sampler}"

    @property
    def count(self) -> int:
        return self.budget


@dataclass
class SearchOutcome:
    summary: dict
    evaluations: pa.Table
    seconds: float = 0.0


def check_plan(plan: SearchPlan) -> None:
    """Fail before any case is prepared on a bad sampler, objective or budget."""
    from crashscene.search import SearchError
    from crashscene.search.run import check_request

    try:
        for sampler in plan.samplers:
            check_request(plan.budget, sampler, plan.objective, plan.rounds)
    except SearchError as exc:
        raise CampaignError(str(exc)) from exc


def run_search_task(task: SearchTask) -> SearchOutcome:
    """Run one search (in a worker process); its summary and evaluated variations."""
    from crashscene.dsl import loads
    from crashscene.search import search_scenario

    scenario = loads(task.scenario_yaml, source=f"{task.case_id}/scenario.yaml")
    out = Path(task.out_dir)
    summary = search_scenario(scenario, out, budget=task.budget, sampler=task.sampler, objective=task.objective,
                              seed=task.seed, rounds=task.rounds, ego_role=task.ego_role)
    return SearchOutcome(summary=summary, evaluations=pq.read_table(out / "evaluations.parquet"),
                         seconds=summary["seconds"])


def plan_searches(store: Store, prepared, plan: SearchPlan, seed: int, ego_role: str, out: Path) -> tuple[list, int]:
    """Search tasks not stored yet, and how many were skipped as done."""
    tasks, skipped, seen = [], 0, set()
    for case in prepared:
        if case.status != "ok" or case.scenario_hash in seen:
            continue
        seen.add(case.scenario_hash)
        for sampler in plan.samplers:
            done = store.con.execute(
                "SELECT count(*) FROM searches WHERE scenario_hash=? AND seed=? AND sampler=? AND objective=? "
                "AND budget=?", [case.scenario_hash, seed, sampler, plan.objective, plan.budget]).fetchone()[0]
            if done:
                skipped += 1
                continue
            tasks.append(SearchTask(case_id=case.case_id, scenario_yaml=case.scenario_yaml,
                                    scenario_hash=case.scenario_hash, seed=seed, sampler=sampler,
                                    objective=plan.objective, budget=plan.budget, rounds=plan.rounds,
                                    ego_role=ego_role, out_dir=str(out / case.case_id / "search" / sampler)))
    return tasks, skipped


def store_search(store: Store, task: SearchTask, outcome: SearchOutcome) -> None:
    """The search's summary row and its evaluations, in one transaction."""
    s = outcome.summary
    keys = [task.scenario_hash, task.seed, task.sampler, task.objective, task.budget]
    ev = outcome.evaluations
    fixed = {"variation", "round", "objective", "verdict", "failure", "min_ttc", "reason"}
    names = [c for c in ev.column_names if c not in fixed]
    params = [json.dumps(dict(zip(names, values)), sort_keys=True)
              for values in zip(*(ev.column(n).to_pylist() for n in names))] if names else ["{}"] * ev.num_rows
    rows = pa.table({"variation": ev["variation"], "round": ev["round"], "objective_value": ev["objective"],
                     "verdict": ev["verdict"], "failure": ev["failure"], "min_ttc": ev["min_ttc"],
                     "params": pa.array(params, pa.string())})
    con = store.con
    con.execute("BEGIN TRANSACTION")
    try:
        con.register("search_rows", rows)
        con.execute("INSERT INTO search_evaluations SELECT ?, ?, ?, ?, ?, variation, round, objective_value, "
                    "verdict, failure, min_ttc, params FROM search_rows", keys)
        con.unregister("search_rows")
        con.execute("INSERT INTO searches VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    [*keys, task.case_id, s["evaluated"], s["failures"], s["min_objective"],
                     json.dumps(s["best_parameters"]), json.dumps(s), s["seconds"], _now()])
        con.execute("COMMIT")
    except BaseException:
        con.execute("ROLLBACK")
        raise


def run_searches(store: Store, engine, prepared, plan: SearchPlan, seed: int, ego_role: str, out: Path,
                 note=print) -> tuple[int, int, list[dict]]:
    """Run and store every pending search: (run, skipped, failures)."""
    tasks, skipped = plan_searches(store, prepared, plan, seed, ego_role, out)
    ran, failures = 0, []
    for task, outcome in engine.run(tasks, run_search_task):
        if isinstance(outcome, BaseException):
            failures.append({"chunk": task.key, "error": f"{type(outcome).__name__}: {outcome}", "count": 0})
            note(f"search {task.key} failed: {outcome}")
            continue
        store_search(store, task, outcome)
        ran += 1
        note(f"search {task.key}: {outcome.summary['failures']} failures, min objective "
             f"{outcome.summary['min_objective']} ({outcome.seconds:.0f} s)")
    return ran, skipped, failures
