"""`monitor_run`: re-evaluate the stored traces of a run directory and write the results beside them."""
from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq

from crashscene.dsl import DslError, load_file
from crashscene.monitor.errors import MonitorError, TraceError
from crashscene.monitor.check_traces import evaluate
from crashscene.monitor.result import MonitorResult
from crashscene.monitor.rulebook import Rulebook, load_rulebook
from crashscene.traces import read_table, scenario_digest, stored_digest

OUTPUT_FILES = ("rule_results.parquet", "collisions_classified.parquet", "verdicts.parquet", "monitor.json")


def read_run(run_dir: Path) -> tuple[dict, object]:
    """The trace tables and the scenario of a run directory."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise MonitorError(f"{run_dir}: not a run directory")
    scenario_path = run_dir / "scenario.yaml"
    if not scenario_path.exists():
        raise MonitorError(f"{scenario_path}: missing; a run directory holds scenario.yaml and the trace tables")
    try:
        scenario = load_file(scenario_path)
    except DslError as exc:
        raise MonitorError(f"{scenario_path}: invalid scenario:\n{exc}") from exc
    if (run_dir / "traces.parquet").exists():
        stored = stored_digest(run_dir)
        if stored is not None and stored != scenario_digest(scenario):
            raise MonitorError(f"{scenario_path}: is not the scenario the traces in {run_dir} were simulated "
                               f"from (scenario sha256 {scenario_digest(scenario)[:12]}, traces {stored[:12]}); "
                               f"simulate it again, or restore the scenario.yaml of that run")
    tables = {}
    for name in ("traces", "actors", "collisions", "variations"):
        try:
            tables[name] = read_table(run_dir, name)
        except FileNotFoundError as exc:
            if name in ("collisions", "variations"):
                continue  # optional: footprints give collisions; every variation is then valid
            raise TraceError(str(exc)) from exc
        except ValueError as exc:
            raise TraceError(str(exc)) from exc
    return tables, scenario


def write_results(run_dir: Path, result: MonitorResult) -> None:
    run_dir = Path(run_dir)
    pq.write_table(result.rule_results, run_dir / "rule_results.parquet", compression="zstd")
    pq.write_table(result.collisions, run_dir / "collisions_classified.parquet", compression="zstd")
    pq.write_table(result.verdicts, run_dir / "verdicts.parquet", compression="zstd")
    summary = {**result.summary(), "rule_parameters": {r["code"]: r["params"] for r in result.rules}}
    (run_dir / "monitor.json").write_text(json.dumps(summary, indent=2, sort_keys=False) + "\n", encoding="utf-8")


def monitor_run(run_dir: Path, rules_file: Path | None = None, allow_imports: bool = False) -> MonitorResult:
    """Evaluate the run directory's traces (scenario.yaml + Parquet tables) and write
    rule_results.parquet, collisions_classified.parquet, verdicts.parquet and monitor.json into it.
    The rulebook's `imports` run only with `allow_imports`."""
    rulebook = load_rulebook(rules_file, allow_imports) if rules_file is not None else Rulebook()
    tables, scenario = read_run(Path(run_dir))
    result = evaluate(tables, scenario, rulebook)
    write_results(Path(run_dir), result)
    return result
