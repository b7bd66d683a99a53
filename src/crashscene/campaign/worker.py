"""The default chunk worker: simulate one chunk of variations, monitor it, return its rows.

Runs in a worker process (or Ray task): it gets the scenario as DSL text, so it
needs no shared filesystem; it writes the chunk's run directory to `keep_dir`
when traces are to be kept, else to a temporary folder removed afterwards.
"""
from __future__ import annotations

import json
import math
import tempfile
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc

from crashscene.campaign.model import COLLISION_ROWS, VARIATION_ROWS, VIOLATION_ROWS, ChunkResult, ChunkTask
from crashscene.dsl import loads


def simulate_chunk(task: ChunkTask) -> ChunkResult:
    """simulate + monitor variations [first, first + count) of the task's scenario."""
    start = time.perf_counter()
    if task.keep_dir:
        run_dir = Path(task.keep_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        result = _simulate_and_monitor(task, run_dir)
    else:
        with tempfile.TemporaryDirectory(prefix="crashscene-chunk-") as tmp:
            result = _simulate_and_monitor(task, Path(tmp))
    result.seconds = time.perf_counter() - start
    return result


def _simulate_and_monitor(task: ChunkTask, run_dir: Path) -> ChunkResult:
    from crashscene.monitor import evaluate
    from crashscene.simulate.pipeline import simulate_scenario
    from crashscene.traces import TABLES, read_table

    scenario = loads(task.scenario_yaml, source=f"{task.case_id}/scenario.yaml")
    opts = task.options
    simulate_scenario(scenario, run_dir, n=task.count, seed=task.seed, first=task.first, mode=task.mode,
                      backend=opts.backend, ego_role=opts.ego_role, map_mode=opts.map_mode,
                      carla_maps=Path(opts.carla_maps) if opts.carla_maps else None)
    tables = {name: read_table(run_dir, name) for name in TABLES}
    monitored = evaluate(tables, scenario)
    return rows_from(tables, monitored, run_dir)


def rows_from(tables: dict[str, pa.Table], monitored: object, run_dir: Path | None = None) -> ChunkResult:
    """Turn the simulate tables and the monitor's result into the campaign's row tables."""
    variations = tables["variations"]
    actors = tables["actors"]
    verdicts = {r["variation"]: r for r in monitored.verdicts.to_pylist()}
    collisions = monitored.collisions.to_pylist()
    collided = {r["variation"] for r in collisions}
    starts = _actor_starts(tables["traces"])
    var_rows = []
    for row in variations.to_pylist():
        i = row["variation"]
        verdict = verdicts.get(i, {})
        params = json.loads(row["params"] or "{}")
        params.update(starts.get(i, {}))
        var_rows.append(dict(variation=i, valid=bool(row["valid"]), invalid_reason=row["invalid_reason"],
                             verdict=verdict.get("verdict", "invalid" if not row["valid"] else "pass"),
                             reproduced=bool(verdict.get("reproduced", False)), collided=i in collided,
                             params=json.dumps(params, sort_keys=True)))
    ads = {(r["variation"], r["actor"]): bool(r["is_ads"]) for r in actors.select(["variation", "actor", "is_ads"]).to_pylist()}
    rules = monitored.rule_results
    violated = rules.filter(pc.equal(rules.column("verdict"), "violated")).to_pylist()
    viol_rows = [dict(variation=r["variation"], actor=r["actor"], is_ads=ads.get((r["variation"], r["actor"]), False),
                      code=r["code"], violation=r.get("violation"), t_first=r.get("t_first"), value=r.get("value"),
                      threshold=r.get("threshold"), unit=r.get("unit"), robustness=r.get("robustness"))
                 for r in violated]
    coll_rows = [dict(variation=r["variation"], t=r["t"], actor_a=r["actor_a"], actor_b=r["actor_b"],
                      collision_class=r.get("class") or r.get("collision_class") or r.get("kind"),
                      speed_a=r.get("speed_a"), speed_b=r.get("speed_b"), x=r.get("x"), y=r.get("y"))
                 for r in collisions]
    return ChunkResult(variations=pa.Table.from_pylist(var_rows, VARIATION_ROWS),
                       violations=pa.Table.from_pylist(viol_rows, VIOLATION_ROWS),
                       collisions=pa.Table.from_pylist(coll_rows, COLLISION_ROWS))


def _actor_starts(traces: pa.Table) -> dict[int, dict[str, float]]:
    """Per variation, each actor's initial speed [m/s] and the ego-to-actor start distance [m] (for the report)."""
    first = traces.filter(pc.equal(traces.column("step"), 0)).select(["variation", "actor", "x", "y", "speed"])
    by_var: dict[int, dict[str, tuple[float, float, float]]] = {}
    for r in first.to_pylist():
        by_var.setdefault(r["variation"], {})[r["actor"]] = (r["x"], r["y"], r["speed"])
    out: dict[int, dict[str, float]] = {}
    for i, actors in by_var.items():
        values: dict[str, float] = {}
        ego = actors.get("ego")
        for role, (x, y, v) in actors.items():
            if v is not None and math.isfinite(v):
                values[f"{role}.speed"] = round(v, 4)
            if ego is not None and role != "ego":
                values[f"{role}.distance"] = round(math.hypot(x - ego[0], y - ego[1]), 4)
        out[i] = values
    return out
