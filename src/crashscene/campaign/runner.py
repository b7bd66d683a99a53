"""Run a campaign: prepare cases, plan chunks, run them on an engine, store each chunk atomically.

`run_campaign` is the importable entry point behind `crashscene campaign` (and
`crashscene run`, which is a one-case campaign that keeps its traces). With
`resume=True` it reopens the database in `out_dir`, skips every chunk already
marked done and runs the rest; without it, an `out_dir` holding results is an
error rather than silently mixed.
"""
from __future__ import annotations

import json
import math
import shlex
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from crashscene.campaign.cases import PreparedCase, PrepareTask, case_id_of, discover_cases, prepare_task
from crashscene.campaign.engines import make_engine, quiet_scenic_warnings
from crashscene.campaign.errors import CampaignError
from crashscene.campaign.model import MODES, ChunkResult, ChunkTask, SimOptions
from crashscene.campaign.progress import CampaignProgress
from crashscene.campaign.search import SearchPlan, check_plan
from crashscene.campaign.store import Store

PARALLEL_PREPARE_MIN = 4  # cases from which preparation runs in the process pool
DEFAULT_CHUNK = 250  # variations per chunk: big enough to batch well, small enough to lose little on a kill


class CampaignConfig(BaseModel):
    """The options of one campaign invocation."""

    model_config = ConfigDict(extra="forbid")

    n: int = Field(ge=0, description="variations per case and mode (0: searches only)")
    seed: int = 0
    modes: tuple[str, ...] = MODES
    engine: str = "local"
    workers: int | None = Field(default=None, ge=1)
    address: str | None = None
    resume: bool = False
    chunk_size: int = Field(default=DEFAULT_CHUNK, gt=0)
    keep_traces: bool = Field(default=False, description="keep each chunk's run directory (traces) under OUT")
    extract_backend: str = "rules"
    dsl_name: str | None = Field(default=None, description="use CASE/<dsl_name> when present instead of extracting")
    llm: dict[str, str] = Field(default_factory=dict, description="model, base_url, model_path for the LLM extractors")
    sim: SimOptions = SimOptions()
    search: SearchPlan | None = Field(default=None, description="`--search`: searches per case after the runs")


class RunSummary(BaseModel):
    case_id: str
    mode: str
    scenario_hash: str
    n: int  # variations planned
    variations: int  # variations stored
    valid: int
    verdicts: dict[str, int]
    reproduced: int
    reproduction_rate: float | None
    first_contact_rate: float | None = None  # share of valid variations whose first contact is the reported one
    sequence_rate: float | None = None  # ... in which the whole reported crash sequence happened
    area_match_rate: float | None = None  # ... with the reported areas (None without a written sequence)
    violations: dict[str, dict[str, int]]  # code -> actor -> variations
    collisions: dict[str, int]  # class -> count
    invalid_reasons: dict[str, int] = {}  # reason -> count of invalid variations


class CampaignSummary(BaseModel):
    out_dir: str
    database: str
    engine: str
    workers: int
    seconds: float
    chunks_run: int
    chunks_skipped: int
    chunks_failed: int
    variations_run: int
    throughput: float  # [variations/s] of this invocation
    failures: list[dict] = []  # chunks that failed in this invocation: key, error
    cases: list[dict]
    runs: list[RunSummary]
    complete: bool
    searches: list[dict] = []  # one per stored search: case, sampler, objective, budget, failures, min objective


# the options that shape the stored rows, by the flag that sets them (where and how fast a campaign runs,
# --engine, --workers, --address, --keep-traces, does not change a row)
_RESULT_FLAGS = {"n": "-n", "seed": "--seed", "modes": "--mode", "chunk_size": "--chunk-size",
                 "extract_backend": "--extractor", "dsl_name": "--dsl", "llm": "--model/--base-url/--model-path"}
_SIM_FLAGS = {"backend": "--backend", "ego_role": "--ego", "ads": "--ads", "ads_params": "--ads-param",
              "dt": "--dt", "horizon": "--horizon", "carla_host": "--carla-host", "carla_port": "--carla-port",
              "map_mode": "--map", "carla_maps": "--carla-maps", "rules_digest": "--rules (sha256 of its contents)",
              "allow_imports": "--allow-imports", "sampler": "--sampler"}


def result_settings(config: CampaignConfig) -> dict:
    """Every option that shapes the stored rows, keyed by its flag; a rulebook counts by its contents."""
    top = config.model_dump(mode="json")
    sim = config.sim.model_dump(mode="json")
    return {**{flag: top[name] for name, flag in _RESULT_FLAGS.items()},
            **{flag: sim[name] for name, flag in _SIM_FLAGS.items()}}


def plan_chunks(n: int, chunk_size: int) -> list[tuple[int, int]]:
    """(first, count) ranges covering [0, n)."""
    return [(first, min(chunk_size, n - first)) for first in range(0, n, chunk_size)]


def run_campaign(cases: str | Path | Sequence[str | Path], out_dir: str | Path, config: CampaignConfig,
                 worker: Callable[[ChunkTask], ChunkResult] | None = None, live: bool | None = None,
                 quiet: bool = False) -> CampaignSummary:
    """Run (or resume) a campaign over `cases` into `out_dir`; returns its summary.

    `cases` is a folder (see `cases.discover_cases`) or a list of case folders / DSL files.
    `worker(task) -> ChunkResult` must be a picklable top-level function (default: the real
    pipeline, `worker.simulate_chunk`). The local engine spawns its processes, so a script
    calling this must guard its entry point with `if __name__ == "__main__":`.
    `live` forces the progress bars on/off (default: on when stderr is a terminal).
    """
    quiet_scenic_warnings()
    if worker is None:
        from crashscene.campaign.worker import simulate_chunk as worker
    bad_modes = [m for m in config.modes if m not in MODES]
    if bad_modes or not config.modes:
        raise CampaignError(f"unknown mode(s) {bad_modes}; allowed: {', '.join(MODES)}")
    out = Path(out_dir)
    paths = (discover_cases(cases, config.dsl_name) if isinstance(cases, (str, Path))
             else [Path(c) for c in cases])
    ids = [p.stem if p.is_file() else p.resolve().name for p in paths]
    dupes = sorted({i for i in ids if ids.count(i) > 1})
    if dupes:
        raise CampaignError(f"several cases share the id(s) {dupes}; case ids are folder or file names")
    start = time.perf_counter()
    if config.engine not in ("local", "ray"):
        raise CampaignError(f"unknown engine {config.engine!r}; allowed: local, ray")
    if config.n == 0 and config.search is None:
        raise CampaignError("-n 0 runs nothing; give -n N or --search SAMPLER")
    if config.search is not None:
        check_plan(config.search)
    if config.address and config.engine != "ray":
        raise CampaignError("--address joins a Ray cluster; use it with --engine ray")
    with Store(out) as store:
        if store.has_results() and not config.resume:
            raise CampaignError(f"{out} already holds a campaign ({store.path.name}); add --resume to continue it "
                                "or choose another --out")
        store.check_settings(result_settings(config), config.resume)
        engine = make_engine(config.engine, config.workers, config.address)
        try:
            session = store.start_session(shlex.join(sys.argv), engine.name, engine.workers)
            prepared = _prepare_all(paths, out, config, engine)
            tasks, skipped = _plan(store, prepared, config, out)
            for case in prepared:
                store.put_case(case.case_id, case.case_dir, case.status, case.error, case.scenario_hash,
                               case.extract_backend, case.warnings, case.seconds)
            ran, failures = _run_chunks(store, engine, tasks, worker, session, prepared, skipped, live, quiet)
            if config.search is not None:
                from crashscene.campaign.search import run_searches

                note = (lambda line: None) if quiet else (lambda line: print(line, file=sys.stderr, flush=True))
                failures += run_searches(store, engine, prepared, config.search, config.seed, config.sim.ego_role,
                                         out, note)[2]
        except BaseException:  # Ctrl-C or a store error: stop the workers now, finished chunks are stored
            engine.abort()
            raise
        engine.close()
        failed = len(failures)
        variations = sum(t.count for t in tasks) - sum(f["count"] for f in failures)
        seconds = time.perf_counter() - start
        return CampaignSummary(
            out_dir=str(out), database=str(store.path), engine=engine.name, workers=engine.workers,
            seconds=round(seconds, 3), chunks_run=ran, chunks_skipped=skipped, chunks_failed=failed,
            variations_run=variations, throughput=round(variations / seconds, 2) if seconds else 0.0,
            failures=[{k: f[k] for k in ("chunk", "error")} for f in failures],
            cases=[c.model_dump(include={"case_id", "status", "error", "scenario_hash", "extract_backend"})
                   for c in prepared],
            runs=summarize_runs(store), complete=failed == 0 and all(c.status == "ok" for c in prepared),
            searches=store.query("SELECT case_id, sampler, objective, budget, evaluated, failures, min_objective "
                                 "FROM searches ORDER BY case_id, sampler"))


def _run_chunks(store: Store, engine, tasks: list[ChunkTask], worker, session: int, prepared: list[PreparedCase],
                skipped: int, live: bool | None, quiet: bool) -> tuple[int, list[dict]]:
    """Run every chunk on the engine, storing each one as it finishes; returns (chunks stored, failures)."""
    ran = 0
    failures: list[dict] = []
    with CampaignProgress(sum(t.count for t in tasks), len(tasks), live=live, quiet=quiet) as progress:
        for case in prepared:
            if case.status != "ok":
                progress.note(f"case {case.case_id}: skipped, {case.error}")
        if skipped:
            progress.note(f"resuming: {skipped} chunk(s) already done, {len(tasks)} to run")
        for task, outcome in engine.run(tasks, worker):
            if not isinstance(outcome, BaseException):
                try:
                    store.write_chunk(task, outcome, session)
                except CampaignError as exc:  # rows that break the contract: this chunk fails
                    outcome = exc
            if isinstance(outcome, BaseException):
                message = f"{type(outcome).__name__}: {outcome}"
                store.write_chunk_error(task, session, message)
                failures.append({"chunk": task.key, "error": message, "count": task.count})
                progress.chunk_done(task.key, task.count, 0.0, failed=message)
                continue
            ran += 1
            progress.chunk_done(task.key, task.count, outcome.seconds)
    return ran, failures


def _prepare_all(paths: list[Path], out: Path, config: CampaignConfig, engine) -> list[PreparedCase]:
    """Extract/validate/render every case: in the local pool when there are several, else in the driver."""
    tasks = [PrepareTask(path=p, out_dir=out, options=config.sim, extract_backend=config.extract_backend,
                         dsl_name=config.dsl_name, llm=config.llm) for p in paths]
    # a pool worker pays ~3 s of imports (Scenic, OCR) first: worth it from a handful of cases on;
    # Ray nodes may not share OUT, so with Ray the driver renders where the files are kept
    # an LLM extractor runs one server or client in the driver, not one per worker
    if len(tasks) < PARALLEL_PREPARE_MIN or engine.name != "local" or config.extract_backend != "rules":
        return [prepare_task(t) for t in tasks]
    done: dict[Path, PreparedCase] = {}
    for task, outcome in engine.run(tasks, prepare_task):
        if isinstance(outcome, BaseException):
            outcome = PreparedCase(case_id=case_id_of(task.path), case_dir=str(task.path), work_dir="",
                                   status="error", error=f"{type(outcome).__name__}: {outcome}")
        done[task.path] = outcome
    return [done[p] for p in paths]


def _plan(store: Store, prepared: list[PreparedCase], config: CampaignConfig, out: Path) -> tuple[list[ChunkTask], int]:
    tasks: list[ChunkTask] = []
    skipped = 0
    seen: set[tuple[str, str]] = set()
    options_json = config.sim.model_dump_json()
    for case in prepared:
        if case.status != "ok":
            continue
        for mode in (config.modes if config.n else ()):
            if (case.scenario_hash, mode) in seen:  # two cases with the same scenario share its rows
                continue
            seen.add((case.scenario_hash, mode))
            store.ensure_run(case.case_id, case.scenario_hash, config.seed, mode, config.n, config.chunk_size,
                             options_json, case.scenario_yaml)
            done = store.done_chunks(case.scenario_hash, config.seed, mode)
            for first, count in plan_chunks(config.n, config.chunk_size):
                if first in done:
                    skipped += 1
                    continue
                keep = (str(Path(case.work_dir) / "runs" / mode / f"{first:06d}-{first + count - 1:06d}")
                        if config.keep_traces else None)
                rendered = Path(case.work_dir) / "render"
                tasks.append(ChunkTask(case_id=case.case_id, scenario_yaml=case.scenario_yaml,
                                       scenario_hash=case.scenario_hash, seed=config.seed, mode=mode, first=first,
                                       count=count, options=config.sim, keep_dir=keep,
                                       render_dir=str(rendered) if (rendered / "render.json").is_file() else None))
    return tasks, skipped


def summarize_runs(store: Store) -> list[RunSummary]:
    """Per (case, mode): counts of verdicts, reproduction, violations by code and actor, collisions by class."""
    out = []
    # a run whose scenario no case has any more (the case's input changed since) is history, not a row
    current = ("WHERE scenario_hash IN (SELECT scenario_hash FROM cases WHERE scenario_hash IS NOT NULL) "
               "OR case_id NOT IN (SELECT case_id FROM cases WHERE scenario_hash IS NOT NULL)")
    for run in store.query(f"SELECT case_id, scenario_hash, seed, mode, n FROM runs {current} "
                           "ORDER BY case_id, mode"):
        key = [run["scenario_hash"], run["seed"], run["mode"]]
        where = "scenario_hash=? AND seed=? AND mode=?"
        counts = store.query(f"SELECT count(*) AS n, count(*) FILTER (WHERE valid) AS valid, "
                             f"count(*) FILTER (WHERE reproduced) AS reproduced, "
                             f"count(*) FILTER (WHERE valid AND first_contact) AS first_contact, "
                             f"count(*) FILTER (WHERE valid AND sequence) AS sequence, "
                             f"count(*) FILTER (WHERE valid AND area_match) AS area_match, "
                             f"count(*) FILTER (WHERE valid AND area_match IS NOT NULL) AS area_known "
                             f"FROM variations WHERE {where}", key)[0]
        verdicts = {r["verdict"]: r["c"] for r in store.query(
            f"SELECT verdict, count(*) AS c FROM variations WHERE {where} GROUP BY verdict ORDER BY verdict", key)}
        violations: dict[str, dict[str, int]] = {}
        valid = f"AND variation IN (SELECT variation FROM variations WHERE {where} AND valid)"  # as the monitor counts
        for r in store.query(f"SELECT code, actor, count(DISTINCT variation) AS c FROM violations WHERE {where} "
                             f"{valid} GROUP BY code, actor ORDER BY code, actor", key + key):
            violations.setdefault(r["code"], {})[r["actor"]] = r["c"]
        collisions = {r["collision_class"]: r["c"] for r in store.query(
            f"SELECT collision_class, count(*) AS c FROM collisions WHERE {where} {valid} GROUP BY collision_class "
            "ORDER BY collision_class", key + key)}
        invalid = {r["reason"]: r["c"] for r in store.query(
            f"SELECT coalesce(invalid_reason, 'no reason given') AS reason, count(*) AS c FROM variations "
            f"WHERE {where} AND NOT valid GROUP BY ALL ORDER BY c DESC, reason LIMIT 10", key)}
        rate = counts["reproduced"] / counts["valid"] if counts["valid"] else None
        out.append(RunSummary(case_id=run["case_id"], mode=run["mode"], scenario_hash=run["scenario_hash"],
                              n=run["n"], variations=counts["n"], valid=counts["valid"], verdicts=verdicts,
                              reproduced=counts["reproduced"],
                              reproduction_rate=None if rate is None else round(rate, 4),
                              first_contact_rate=_rate(counts["first_contact"], counts["valid"]),
                              sequence_rate=_rate(counts["sequence"], counts["valid"]),
                              area_match_rate=(_rate(counts["area_match"], counts["valid"])
                                               if counts["area_known"] else None),
                              violations=violations, collisions=collisions, invalid_reasons=invalid))
    return out


def _rate(count: int, valid: int) -> float | None:
    return round(count / valid, 4) if valid else None


def summary_json(summary: CampaignSummary) -> str:
    return json.dumps(summary.model_dump(mode="json"), indent=2)
