"""`search_scenario`: rounds of pinned variations through render -> sample -> simulate -> monitor.

Output directory: scenario.yaml, scenario.scenic, map.xodr (as rendered),
`evaluations.parquet` (EVALUATION columns + one column per parameter),
`criticality.parquet` (per variation and actor pair), `search.json` (the
summary, per-round convergence and the failure-region rules).
"""
from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from crashscene.dsl import Scenario, dump_file
from crashscene.search.errors import SearchError
from crashscene.search.objective import FAILURE_VERDICTS, OBJECTIVES, objective_values, worst_value
from crashscene.search.samplers import SAMPLERS, create_sampler
from crashscene.search.seat import resolve_seat
from crashscene.search.space import ParameterSpace, PinnedScenes, parameter_space

DEFAULT_ROUNDS = 8
MIN_ROUND = 8   # variations per round below which the batched simulator gains nothing
SUMMARY_KEYS = ("evaluated", "failures", "min_objective", "best_parameters", "sampler", "objective", "seconds")


def round_size(budget: int, rounds: int = DEFAULT_ROUNDS) -> int:
    """Variations per round: budget / rounds, at least MIN_ROUND."""
    return max(MIN_ROUND, math.ceil(budget / max(1, rounds)))


def check_request(budget: int, sampler: str, objective: str, rounds: int = DEFAULT_ROUNDS) -> int:
    """Validate the cheap arguments before any rendering; the round size."""
    if sampler not in SAMPLERS:
        raise SearchError(f"--sampler {sampler!r} is not allowed; allowed: {', '.join(SAMPLERS)}")
    if objective not in OBJECTIVES:
        raise SearchError(f"--objective {objective!r} is not allowed; allowed: {', '.join(OBJECTIVES)}")
    if rounds < 1:
        raise SearchError(f"--rounds {rounds}: must be >= 1")
    size = round_size(budget, rounds)
    if budget < size:
        raise SearchError(f"--budget {budget} is below the round size {size} (at least {MIN_ROUND} variations "
                          f"per round); give --budget >= {size}")
    return size


def search_scenario(scenario: Scenario, out_dir: Path, *, budget: int, sampler: str = "ce",
                    objective: str = "robustness", seed: int = 0, ads: str | None = None,
                    ads_params: dict[str, Any] | None = None, rounds: int = DEFAULT_ROUNDS, ego_role: str = "ego",
                    map_mode: str = "generated", carla_maps: Path | None = None,
                    progress: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Search `scenario`'s sampled parameters for ADS failures in test mode; write `out_dir`; the summary.

    `ego_role`: the role the ADS drives, or `auto` (`seat.ads_seat`). The returned dict has SUMMARY_KEYS plus
    `ego_role`, `rounds` (convergence), `rules` (failure region), `parameters`.
    """
    from crashscene.render import RenderError, render
    from crashscene.simulate.backend import SimulationSettings, check_ego_role, create_simulator

    start = time.perf_counter()
    size = check_request(budget, sampler, objective, rounds)
    ego_role = resolve_seat(scenario, ego_role)
    settings = SimulationSettings(mode="test", ego_role=ego_role, ads=ads, ads_params=ads_params or {})
    check_ego_role(scenario, settings)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    dump_file(scenario, out_dir / "scenario.yaml")
    try:
        rendered = render(scenario, out_dir, map_mode=map_mode, carla_maps=carla_maps, search_ads=ego_role)
        program = Path(rendered.program)
    except RenderError as exc:
        raise SearchError(f"render failed: {exc}") from exc
    space = parameter_space(program)
    pinned = PinnedScenes(program, space)
    chooser = create_sampler(sampler, space.dimension, seed, size)
    rows: list[dict[str, Any]] = []
    crit_parts: list[pa.Table] = []
    convergence: list[dict[str, Any]] = []
    with create_simulator("embedded", settings) as simulator:
        for number in range(math.ceil(budget / size)):
            first = number * size
            k = min(size, budget - first)
            points = chooser.ask(k)
            values = space.values(points)
            batch, crit = _evaluate(simulator, settings, scenario, pinned, program, rendered, values, seed, first,
                                    objective)
            crit_parts.append(crit)
            for i, row in enumerate(batch):
                row.update(round=number, **{name: float(values[i, j]) for j, name in enumerate(space.names)})
            rows.extend(batch)
            told = np.array([r["objective"] if np.isfinite(r["objective"]) else worst_value(objective) for r in batch])
            chooser.tell(points, told)
            convergence.append(_round_stats(number, rows, batch))
            if progress is not None:
                progress(k)
    summary = _write(out_dir, space, rows, crit_parts, convergence, sampler, objective, seed, budget, ads, ego_role,
                     start)
    return summary


def _evaluate(simulator, settings, scenario, pinned: PinnedScenes, program: Path, rendered, values: np.ndarray,
              seed: int, first: int, objective: str) -> tuple[list[dict[str, Any]], pa.Table]:
    """Simulate and monitor one round; one row per variation (objective NaN for invalid ones)."""
    from crashscene.monitor.criticality import CRITICALITY_SCHEMA, ads_objectives
    from crashscene.pipeline.simulate import judge_block
    from crashscene.simulate.backend import SimulationRequest

    drawn = pinned(values, seed, first)
    scenes = [s for s in drawn if not isinstance(s, str)]
    rows = [{"variation": first + i, "objective": math.nan, "verdict": "invalid", "failure": False,
             "min_ttc": math.nan, "reason": s if isinstance(s, str) else None} for i, s in enumerate(drawn)]
    if not scenes:
        return rows, CRITICALITY_SCHEMA.empty_table()
    request = SimulationRequest(scenario=scenario, scenes=scenes, map_file=Path(rendered.map), settings=settings,
                                program=program.read_text(encoding="utf-8"))
    judged = judge_block(simulator.simulate(request).tables, scenario)
    result, crit = judged.result, judged.criticality
    variations = np.array([s.index for s in scenes])
    obj = objective_values(objective, variations, result.verdicts, result.rule_results, result.collisions, crit)
    verdict = dict(zip(result.verdicts["variation"].to_pylist(), result.verdicts["verdict"].to_pylist()))
    reason = dict(zip(result.verdicts["variation"].to_pylist(), result.verdicts["reason"].to_pylist()))
    ttc = ads_objectives(crit)
    for v, value in zip(variations, obj):
        row = rows[int(v) - first]
        row.update(objective=float(value), verdict=verdict.get(int(v), "invalid"),
                   min_ttc=ttc.get(int(v), {}).get("min_ttc", math.nan), reason=reason.get(int(v)))
        row["failure"] = row["verdict"] in FAILURE_VERDICTS
    return rows, crit


def _finite_min(rows: list[dict[str, Any]]) -> float | None:
    values = [r["objective"] for r in rows if np.isfinite(r["objective"])]
    return round(float(min(values)), 6) if values else None


def _round_stats(number: int, rows: list[dict[str, Any]], batch: list[dict[str, Any]]) -> dict[str, Any]:
    return {"round": number, "evaluated": len(rows), "round_min": _finite_min(batch), "best": _finite_min(rows),
            "round_failures": sum(r["failure"] for r in batch), "failures": sum(r["failure"] for r in rows)}


def _write(out_dir: Path, space: ParameterSpace, rows: list[dict[str, Any]], crit_parts: list[pa.Table],
           convergence: list[dict[str, Any]], sampler: str, objective: str, seed: int, budget: int,
           ads: str | None, ego_role: str, start: float) -> dict[str, Any]:
    from crashscene.search.region import failure_rules

    columns: dict[str, pa.Array] = {
        "variation": pa.array([r["variation"] for r in rows], pa.int32()),
        "round": pa.array([r["round"] for r in rows], pa.int32()),
        "objective": pa.array([r["objective"] for r in rows], pa.float64()),
        "verdict": pa.array([r["verdict"] for r in rows], pa.string()),
        "failure": pa.array([r["failure"] for r in rows], pa.bool_()),
        "min_ttc": pa.array([r["min_ttc"] for r in rows], pa.float64()),
        "reason": pa.array([r["reason"] for r in rows], pa.string()),
    }
    for name in space.names:
        columns[name] = pa.array([r[name] for r in rows], pa.float64())
    pq.write_table(pa.table(columns), out_dir / "evaluations.parquet", compression="zstd")
    pq.write_table(pa.concat_tables(crit_parts), out_dir / "criticality.parquet", compression="zstd")
    objectives = np.array([r["objective"] for r in rows], dtype=float)
    valid = np.isfinite(objectives)
    best = int(np.argmin(np.where(valid, objectives, np.inf))) if valid.any() else None
    checked = [r for r in rows if r["verdict"] != "invalid"]
    rules = failure_rules(list(space.names), np.array([[r[n] for n in space.names] for r in checked]),
                          [r["verdict"] for r in checked], seed) if checked else []
    summary: dict[str, Any] = {
        "evaluated": len(rows),
        "failures": int(sum(r["failure"] for r in rows)),
        "min_objective": _finite_min(rows),
        "best_parameters": {n: round(rows[best][n], 6) for n in space.names} if best is not None else None,
        "sampler": sampler,
        "objective": objective,
        "seconds": round(time.perf_counter() - start, 3),
    }
    report = {**summary, "seed": seed, "budget": budget, "ads": ads or "reference", "ego_role": ego_role,
              "invalid": int((~valid).sum()),
              "parameters": [{"name": n, "low": float(lo), "high": float(hi)}
                             for n, lo, hi in zip(space.names, space.low, space.high)],
              "rounds": convergence, "rules": [r.to_json() for r in rules]}
    (out_dir / "search.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return report
