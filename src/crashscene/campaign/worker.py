"""The default chunk worker: simulate one chunk of variations, monitor it, return its rows.

Runs in a worker process (or Ray task): it gets the scenario as DSL text, so it
needs no shared filesystem; it writes the chunk's run directory to `keep_dir`
when traces are to be kept, else to a temporary folder removed afterwards.
"""
from __future__ import annotations

import json
import math
import shutil
import tempfile
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from crashscene.campaign import keep
from crashscene.campaign.model import (
    COLLISION_ROWS,
    CRITICALITY_ROWS,
    VARIATION_ROWS,
    VIOLATION_ROWS,
    ChunkResult,
    ChunkTask,
)
from crashscene.dsl import loads


def simulate_chunk(task: ChunkTask) -> ChunkResult:
    """simulate + monitor variations [first, first + count) of the task's scenario."""
    start = time.perf_counter()
    if task.keep_dir:
        run_dir = Path(task.keep_dir)
        if run_dir.exists():  # left by an attempt that was killed before its chunk was stored: start clean
            shutil.rmtree(run_dir)
        run_dir.mkdir(parents=True)
        result = _simulate_and_monitor(task, run_dir)
    else:
        with tempfile.TemporaryDirectory(prefix="crashscene-chunk-") as tmp:
            result = _simulate_and_monitor(task, Path(tmp))
    result.seconds = time.perf_counter() - start
    return result


def _simulate_and_monitor(task: ChunkTask, run_dir: Path) -> ChunkResult:
    from crashscene.pipeline.simulate import simulate_scenario
    from crashscene.traces import TABLES, read_table

    scenario = loads(task.scenario_yaml, source=f"{task.case_id}/scenario.yaml")
    opts = task.options
    rendered = Path(task.render_dir) if task.render_dir and Path(task.render_dir).is_dir() else None
    simulate_scenario(scenario, run_dir, n=task.count, seed=task.seed, first=task.first, mode=task.mode,
                      backend=opts.backend_target or opts.backend, ego_role=opts.ego_role, map_mode=opts.map_mode,
                      carla_maps=Path(opts.carla_maps) if opts.carla_maps else None, ads=opts.ads,
                      ads_params=dict(opts.ads_params), dt=opts.dt, horizon=opts.horizon,
                      carla_host=opts.carla_host, carla_port=opts.carla_port,
                      rules_file=Path(opts.rules_file) if opts.rules_file else None,
                      allow_imports=opts.allow_imports, rendered_dir=rendered,
                      sampler=opts.sampler)
    tables = {name: read_table(run_dir, name) for name in TABLES if (run_dir / f"{name}.parquet").exists()}
    path = run_dir / "criticality.parquet"
    criticality = pq.read_table(path) if path.exists() else None   # written when the monitor ran
    result = rows_from(tables, _monitored(run_dir), _ads_ttc(criticality))
    if criticality is not None:
        result.criticality = criticality.select(CRITICALITY_ROWS.names)
    return result


def _ads_ttc(criticality: pa.Table | None) -> dict[int, float] | None:
    """Per variation, the lowest time to collision [s] of a pair with the ADS, where one was on a collision
    course (`monitor.criticality.ads_objectives`)."""
    if criticality is None:
        return None
    from crashscene.monitor.criticality import ads_objectives

    return {v: m["min_ttc"] for v, m in ads_objectives(criticality).items() if math.isfinite(m["min_ttc"])}


def _monitored(run_dir: Path) -> dict[str, pa.Table]:
    """The monitor's tables simulate wrote for the run (with the campaign's rulebook: monitored once)."""
    names = {"rule_results": "rule_results.parquet", "collisions": "collisions_classified.parquet",
             "verdicts": "verdicts.parquet"}
    return {key: pq.read_table(run_dir / f) for key, f in names.items()}


def rows_from(tables: dict[str, pa.Table], monitored: dict[str, pa.Table],
              ttc: dict[int, float] | None = None) -> ChunkResult:
    """Turn the simulate tables and the monitor's tables into the campaign's row tables, with the traces of the
    chunk's candidates for the report (`keep`; `ttc` [s] per variation ranks the ADS's closest calls)."""
    verdicts = {r["variation"]: r for r in monitored["verdicts"].to_pylist()}
    collisions = monitored["collisions"].to_pylist()
    collided = {r["variation"] for r in collisions}
    starts = _actor_starts(tables["traces"]) if "traces" in tables else {}
    var_rows = []
    for row in tables["variations"].to_pylist():
        i = row["variation"]
        verdict = verdicts.get(i, {})
        params = json.loads(row["params"] or "{}")
        params.update(starts.get(i, {}))
        var_rows.append(dict(variation=i, valid=bool(row["valid"]) and verdict.get("verdict") != "invalid",
                             invalid_reason=row["invalid_reason"] or (verdict.get("reason") if verdict.get("verdict") == "invalid"
                                                                     else None),
                             verdict=verdict.get("verdict") or ("pass" if row["valid"] else "invalid"),
                             reproduced=bool(verdict.get("reproduced")), collided=i in collided,
                             params=json.dumps(params, sort_keys=True), first_contact=verdict.get("first_contact"),
                             sequence=verdict.get("sequence"), area_match=verdict.get("area_match")))
    rules = monitored["rule_results"]
    violated = rules.filter(pc.equal(rules.column("verdict"), "violated")).to_pylist()
    viol_rows = [dict(variation=r["variation"], actor=r["actor"], is_ads=bool(r["is_ads"]), code=r["code"],
                      violation=r["violation"], t_first=r["first_violation_t"], value=r["measured"],
                      threshold=r["threshold"], unit=r["unit"], robustness=r["robustness"]) for r in violated]
    coll_rows = [dict(variation=r["variation"], t=r["t"], actor_a=r["actor_a"], actor_b=r["actor_b"],
                      collision_class=r["class"], speed_a=r.get("speed_a"), speed_b=r.get("speed_b"),
                      x=r.get("x"), y=r.get("y"), contact_index=r.get("contact_index"), area_a=r.get("area_a"),
                      area_b=r.get("area_b"), delta_v_a=r.get("delta_v_a"), delta_v_b=r.get("delta_v_b"))
                 for r in collisions]
    result = ChunkResult(variations=pa.Table.from_pylist(var_rows, VARIATION_ROWS),
                         violations=pa.Table.from_pylist(viol_rows, VIOLATION_ROWS),
                         collisions=pa.Table.from_pylist(coll_rows, COLLISION_ROWS))
    if "traces" in tables and "actors" in tables:
        result.shown = keep.pick(var_rows, rules, monitored["collisions"], ttc)
        result.shown_traces, result.shown_actors = keep.traces_of(result.shown, tables["traces"], tables["actors"])
    return result


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
