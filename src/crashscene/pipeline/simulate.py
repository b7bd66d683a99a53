"""`simulate_scenario`: render -> sample -> simulate -> monitor -> run directory, for one scenario.

Run directory layout: scenario.yaml (canonical DSL), scenario.scenic, map.xodr,
render.json, scenes.jsonl, traces.parquet, actors.parquet, collisions.parquet,
variations.parquet, summary.json, and the monitor's outputs (rule_results.parquet,
collisions_classified.parquet, verdicts.parquet, monitor.json, criticality.parquet) when
`crashscene.monitor` is installed.
"""
from __future__ import annotations

import dataclasses
import functools
import itertools
import json
import multiprocessing
import os
import pickle
import shutil
import sys
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pyarrow as pa

from crashscene.dsl import Scenario, dump_file
from crashscene.geometry import classify_contact, heading_difference
from crashscene.simulate.backend import (
    DEFAULT_DT,
    DEFAULT_HORIZON,
    MODES,
    BatchResult,
    SimulationError,
    SimulationRequest,
    SimulationSettings,
    check_ego_role,
    create_simulator,
    get_simulator_class,
)
from crashscene.traces import SCENARIO_DIGEST_KEY, scenario_digest, write_table


def simulate_scenario(scenario: Scenario, out_dir: Path, n: int, seed: int, **options: Any) -> dict[str, Any]:
    """Simulate variations [first, first + n) of `scenario` and write the run directory `out_dir` atomically.

    Everything is written into a temporary sibling folder that replaces `out_dir` only when the run
    succeeded, so a failed run never leaves new files beside old traces (options: see `_write_run`).
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise SimulationError(f"--out {out_dir}: is a file; give a folder (created if missing, replaced when the "
                              f"run succeeds)")
    work = out_dir.with_name(f".{out_dir.name}.partial")
    old = out_dir.with_name(f".{out_dir.name}.old")
    for leftover in (work, old):
        if leftover.exists():
            shutil.rmtree(leftover)
    try:
        summary = _write_run(scenario, work, n, seed, final_dir=out_dir, **options)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    if out_dir.exists():
        out_dir.rename(old)
    work.rename(out_dir)
    shutil.rmtree(old, ignore_errors=True)
    return summary


def _write_run(scenario: Scenario, out_dir: Path, n: int, seed: int, first: int = 0, mode: str = "test",
               backend: str = "embedded", ego_role: str = "ego", map_mode: str = "generated",
               carla_maps: Path | None = None, ads: str | None = None,
               ads_params: dict[str, Any] | None = None, dt: float = DEFAULT_DT,
               horizon: float = DEFAULT_HORIZON, carla_host: str = "127.0.0.1", carla_port: int = 2000,
               monitor: bool = True, progress: Callable[[int], None] | None = None,
               workers: int = 1, sampler: str | None = None, final_dir: Path | None = None,
               rules_file: Path | None = None, allow_imports: bool = False,
               rendered_dir: Path | None = None, refine: bool = True) -> dict[str, Any]:
    """Simulate variations [first, first + n) of `scenario` into `out_dir` (paths in scenes.jsonl name
    `final_dir`, where the folder will live).

    `rules_file` is the monitor's rulebook (its `imports` only with `allow_imports`); its CVC_22350 condition
    factors and friction coefficients also reach the drivers. `rendered_dir` holds this scenario's rendered
    program and map (a campaign renders each case once): they are copied instead of rendered again.

    `workers` > 1 simulates contiguous blocks of variations in that many forked processes (embedded backend;
    with `sampler="scenic"` it also samples in them); the tables are the blocks' tables in index order, the
    same bytes as one process. Keep 1 when the caller already runs in a process pool (a campaign worker).
    `sampler`: "compiled" (numpy) or "scenic" (the reference), see `crashscene.render.sample.sample_scenes`; None: the
    backend's (`Simulator.scene_sampler`: compiled for embedded, scenic for backends that replay Scenic scenes).

    Returns the JSON summary (also written to summary.json): variations, valid,
    invalid (reason -> count), collisions (by class, by actor pair), seconds, and
    the monitor's violations, verdicts and reproduced counts when it is available.
    `progress` is called with the number of variations each time a chunk finishes. `refine`: reproduce mode
    checks each variation's plan against the simulator and replans one that misses the written crash sequence
    (embedded backend, `simulate.embedded.refine`); False keeps the analytic plans alone.
    """
    if mode not in MODES:
        raise SimulationError(f"mode {mode!r} is not allowed; allowed: {', '.join(MODES)}")
    if n < 1 or first < 0:
        raise SimulationError(f"n must be >= 1 and first >= 0 (got n={n}, first={first})")
    if workers < 1:
        raise SimulationError(f"workers must be >= 1 (got {workers})")
    rulebook = None
    if rules_file is not None:
        from crashscene.monitor.rulebook import load_rulebook

        rulebook = load_rulebook(rules_file, allow_imports)
    settings = SimulationSettings(dt=dt, horizon=horizon, mode=mode, ego_role=ego_role, ads=ads,
                                  ads_params=ads_params or {}, carla_host=carla_host, carla_port=carla_port,
                                  conditions=_conditions(rulebook), refine=refine)
    check_ego_role(scenario, settings)
    sampler = _sampler_for(backend, sampler)
    from crashscene.render import RenderError, render

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    timings: dict[str, float] = {}
    start = time.perf_counter()
    dump_file(scenario, out_dir / "scenario.yaml")
    try:
        if rendered_dir is not None:
            rendered = _copy_render(Path(rendered_dir), out_dir)
        else:
            rendered = render(scenario, out_dir, map_mode=map_mode, carla_maps=carla_maps)
    except RenderError as exc:
        raise SimulationError(f"render/sample failed: {exc}") from exc
    timings["render"] = time.perf_counter() - start
    sampling = BlockSampling(Path(rendered.program), n, seed, first, sampler, out_dir, final_dir)
    scenes: list = []
    if sampler == "compiled" and worker_count(backend, n, workers) > 1:
        in_blocks = sampling  # each worker samples its own block, in parallel
    else:
        in_blocks = None
        t0 = time.perf_counter()
        scenes = sampling.scenes(0, n, workers)
        timings["sample"] = time.perf_counter() - t0
        sampling.write([sampling.lines(scenes)])

    t0 = time.perf_counter()
    request = SimulationRequest(scenario=scenario, scenes=scenes, map_file=Path(rendered.map), settings=settings,
                                program=Path(rendered.program).read_text(encoding="utf-8"), progress=progress)
    judge = functools.partial(judge_block, scenario=scenario, rulebook=rulebook) if monitor else None
    digest = scenario_digest(scenario)
    written: list = []
    # the simulator's tables are written in a second thread (pyarrow writes without holding the GIL), from when
    # they are simulated, while the workers judge them and this thread summarises and writes the monitor's outputs
    with ThreadPoolExecutor(max_workers=1) as writer:
        def write(simulated: BatchResult) -> None:
            written.extend(writer.submit(write_table, out_dir, name,
                                         table.replace_schema_metadata({SCENARIO_DIGEST_KEY: digest}))
                           for name, table in simulated.tables.items())

        result, judged = simulate_blocks(backend, settings, request, workers, judge, simulated=write,
                                         sampling=in_blocks)
        if in_blocks is not None:
            timings["sample"] = in_blocks.seconds
        timings["simulate"] = (time.perf_counter() - t0 - (judged.seconds if judged is not None else 0.0)
                               - (in_blocks.seconds if in_blocks is not None else 0.0))
        summary = summarize(result.tables)
        summary.update({"backend": result.backend, "sampler": sampler, "workers": workers, "mode": mode,
                        "ego_role": ego_role, "seed": seed, "first": first,
                        "ads": ads or ("reference" if mode == "test" else None)})
        if result.notes:
            summary["notes"] = result.notes
        if rendered_dir is not None:
            summary["rendered_from"] = str(rendered_dir)  # a campaign's case render, copied rather than redone
        if judged is not None:
            t0 = time.perf_counter()
            monitored = _write_monitored(judged, out_dir)
            mc = monitored.pop("monitor_collisions")
            summary["collisions"].update(by_class=mc["by_class"], by_pair=mc["by_pair"])
            summary.update(monitored)
            timings["monitor"] = judged.seconds + time.perf_counter() - t0
    for future in written:
        future.result()  # a failed write fails the run
    summary["seconds"] = round(time.perf_counter() - start, 3)
    summary["timings"] = {k: round(v, 3) for k, v in timings.items()}
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary


class BlockSampling:
    """Scenes of variations [first, first + n) of a rendered program, drawn for any block [lo, hi) of them: by the
    parent for the whole run, or by each worker for its own block (`simulate_blocks`), in parallel and with no scene
    crossing a pipe. Scene i depends only on (program, seed, i), so the blocks' scenes are the scenes of one call.
    Their JSON lines go to `scenes.jsonl` in index order (`write`); map paths name `final_dir`, where the run folder
    will live, when given."""

    def __init__(self, program: Path, n: int, seed: int, first: int, sampler: str, work_dir: Path,
                 final_dir: Path | None):
        self.program, self.n, self.seed, self.first, self.sampler = program, n, seed, first, sampler
        self.work_dir, self.final_dir = work_dir, final_dir
        self.seconds = 0.0  # [s] the blocks' sampling time over the number of workers, when they sampled

    def scenes(self, lo: int, hi: int, workers: int = 1) -> list:
        """The scenes of variations [first + lo, first + hi) (`workers`: see `sample_scenes`)."""
        from crashscene.render import RenderError
        from crashscene.render.sample import sample_scenes

        try:
            scenes = sample_scenes(self.program, hi - lo, self.seed, first=self.first + lo, workers=workers,
                                   sampler=self.sampler)
        except RenderError as exc:
            raise SimulationError(f"render/sample failed: {exc}") from exc
        if self.final_dir is not None:
            moved: dict[str, str] = {}
            for scene in scenes:  # scenes of our own: set in place (a copy each costs 4 us)
                path = scene.map_file
                scene.map_file = moved.get(path) or moved.setdefault(path, _moved(path, self.work_dir,
                                                                                  Path(self.final_dir)))
        return scenes

    @staticmethod
    def lines(scenes: list) -> bytes:
        """The scenes as JSON lines (UTF-8)."""
        return "".join(scene.model_dump_json() + "\n" for scene in scenes).encode("utf-8")

    def write(self, parts: list[bytes]) -> None:
        """`scenes.jsonl`: the blocks' lines, in index order."""
        with open(self.work_dir / "scenes.jsonl", "wb") as fh:
            fh.writelines(parts)


def _moved(path: str, work: Path, final: Path) -> str:
    try:
        return str(final / Path(path).relative_to(work))
    except ValueError:  # a map outside the run folder (a CARLA town): unchanged
        return path


def _sampler_for(backend: str, sampler: str | None) -> str:
    needs = get_simulator_class(backend).scene_sampler
    if sampler is None:
        return needs
    if needs == "scenic" and sampler != "scenic":
        raise SimulationError(f"--sampler {sampler}: the {backend} backend re-generates every scene with Scenic "
                              "from (seed, index), so its scenes must come from --sampler scenic")
    return sampler


MIN_BLOCK = 100  # variations per process below which forking costs more than it saves
EARLY_WRITE_BYTES = 320 * 2**20  # [bytes] traces up to this size are written while the workers judge them
BLOCKS_PER_WORKER = 1  # one block a worker: the step loop's cost per step is mostly fixed, so larger blocks are cheaper
_INHERITED: dict[str, Any] = {}  # the request, read by forked children only


@dataclasses.dataclass
class Judged:
    """The monitor's result and the criticality metrics of a batch, and the wall time they took [s] (their
    blocks' time over the number of workers, when blocks ran in parallel)."""

    result: Any  # crashscene.monitor.result.MonitorResult
    criticality: pa.Table
    seconds: float


def judge_block(tables: dict[str, pa.Table], scenario: Scenario, rulebook=None) -> Judged:
    """Monitor and criticality metrics of one block of variations (each variation is judged by itself, so
    blocks judged apart and concatenated equal the whole batch judged at once).

    The traces table is read once into arrays and then dropped from `tables` (its memory is freed unless the
    caller holds it too): pass a dict of your own."""
    from crashscene.monitor import evaluate
    from crashscene.monitor.arrays import build_arrays
    from crashscene.monitor.criticality import criticality_table

    start = time.perf_counter()
    arrays = build_arrays(tables)  # once: the metrics read the whole traces, then the monitor truncates them
    tables.pop("traces", None)
    pa.default_memory_pool().release_unused()
    criticality = criticality_table(arrays, tables.get("collisions"))
    result = evaluate(tables, scenario, rulebook, arrays=arrays)
    return Judged(result, criticality, time.perf_counter() - start)


def worker_count(backend: str, n: int, workers: int) -> int:
    """Processes `simulate_blocks` uses for n variations: only the embedded backend is split, into blocks of at
    least MIN_BLOCK variations."""
    return min(workers, max(1, n // MIN_BLOCK)) if backend == "embedded" else 1


def simulate_blocks(backend: str, settings: SimulationSettings, request: SimulationRequest, workers: int,
                    judge: Callable[[dict[str, pa.Table]], Judged] | None = None,
                    simulated: Callable[[BatchResult], None] | None = None,
                    sampling: BlockSampling | None = None) -> tuple[BatchResult, Judged | None]:
    """`request` simulated in up to `workers` forked processes, in contiguous blocks of scenes (one per worker), each
    block judged (`judge`: monitor and metrics) in its process.

    Variation i depends only on its scene, so the concatenated tables equal one process's. Only the embedded
    backend is split (a CARLA server is one shared world; Newtonian runs scene by scene anyway). `simulated` is
    called with the simulator's tables as soon as every block has sent them, before the blocks are judged: the
    caller writes them while the workers judge (when the traces are at most EARLY_WRITE_BYTES, else once judged).

    `sampling` (more than one worker only): each block's worker draws its own scenes (`request.scenes` is not read)
    and sends their JSON lines first; `sampling.write` gets them, in index order, once every block's are in.
    """
    scenes = list(request.scenes)
    n = len(scenes) if sampling is None else sampling.n
    workers = worker_count(backend, n, workers)
    if sampling is not None and workers == 1:
        raise ValueError("sampling in the workers needs more than one worker")
    if workers == 1:
        with create_simulator(backend, settings) as simulator:
            result = simulator.simulate(request)
        early = simulated is not None and _write_early(result)
        if early:
            simulated(result)
        judged = judge(dict(result.tables)) if judge is not None else None
        if simulated is not None and not early:
            simulated(result)
        return result, judged
    start = time.perf_counter()
    from crashscene.simulate.embedded.simulator import chunk_size

    # one block a worker, or as many more as keep each block to one simulator chunk (bounds a judge's memory)
    chunk = chunk_size(scenes if sampling is None else sampling.scenes(0, 1))  # it depends on the actors per scene
    blocks = min(max(BLOCKS_PER_WORKER * workers, -(-n // chunk)), max(1, n // MIN_BLOCK))
    bounds = list(itertools.pairwise([n * k // blocks for k in range(blocks + 1)]))
    _INHERITED.update(backend=backend, settings=settings, request=request, judge=judge, sampling=sampling)
    _import_before_fork(judge is not None)
    parts: list[BatchResult | None] = [None] * len(bounds)
    judged: list[Judged | None] = [None] * len(bounds)
    lines: list[bytes | None] = [None] * len(bounds)
    result = None
    try:
        context = multiprocessing.get_context("fork")  # children inherit the imports and the parsed map
        with _Blocks(context, bounds, workers) as running:
            for k, kind, payload in running.messages(judge is not None):
                if kind == "scenes":
                    lines[k], seconds = payload
                    sampling.seconds += seconds / workers
                    if all(part is not None for part in lines):
                        sampling.write(lines)
                elif kind == "tables":
                    parts[k] = payload
                    if request.progress is not None:
                        request.progress(bounds[k][1] - bounds[k][0])
                    if all(part is not None for part in parts):
                        result = _concatenated(parts, start)
                        if simulated is not None and _write_early(result):
                            simulated(result)
                            simulated = None
                else:
                    judged[k] = payload
    finally:
        _INHERITED.clear()
    if simulated is not None:
        simulated(result)
    if judge is None:
        return result, None
    from crashscene.monitor.result import combine

    return result, Judged(combine([j.result for j in judged]), pa.concat_tables([j.criticality for j in judged]),
                          sum(j.seconds for j in judged) / workers)


def _write_early(result: BatchResult) -> bool:
    """Whether the tables can be written while the blocks are judged: `write_table` may copy the traces into one
    chunk (long strings, see `crashscene.traces._page_aligned`), which beside the judges' arrays would exceed the
    memory budget for large traces."""
    traces = result.tables.get("traces")
    return traces is None or traces.nbytes <= EARLY_WRITE_BYTES


def _concatenated(parts: list[BatchResult], start: float) -> BatchResult:
    """The blocks' tables in index order (`write_table` writes them as the same bytes as one process's)."""
    tables = {name: pa.concat_tables([part.tables[name] for part in parts]) for name in parts[0].tables}
    notes = list(dict.fromkeys(note for part in parts for note in part.notes))
    return BatchResult(backend=parts[0].backend, tables=tables, seconds=time.perf_counter() - start, notes=notes)


class _Blocks:
    """Forked processes, one per block of scenes and at most `workers` at a time; each sends its block's tables as
    soon as they are simulated, then its judgement (`_simulate_block`)."""

    def __init__(self, context, bounds: list[tuple[int, int]], workers: int):
        self.context, self.bounds, self.workers = context, bounds, workers
        self.running: dict[Any, tuple[int, Any]] = {}  # connection -> (block, process)
        self.spills: dict[Any, _Spill] = {}  # connection -> its block's memory file (where there are any)

    def __enter__(self) -> _Blocks:
        return self

    def __exit__(self, *exc) -> None:
        for conn, (_, process) in self.running.items():  # left over only after an error
            process.terminate()
            conn.close()
        for _, process in self.running.values():
            process.join()
        for spill in self.spills.values():
            spill.close()

    def _start(self, k: int) -> None:
        receive, send = self.context.Pipe(duplex=False)
        spill = _Spill.create(k)
        others = [other.fd for other in self.spills.values()]
        process = self.context.Process(target=_simulate_block, args=(*self.bounds[k], send, spill, others),
                                       daemon=True)
        process.start()
        send.close()
        self.running[receive] = (k, process)
        if spill is not None:
            self.spills[receive] = spill

    def messages(self, judging: bool):
        """(block, "scenes" | "tables" | "judged", payload) as the blocks send them."""
        from multiprocessing.connection import wait

        queued = list(range(len(self.bounds)))
        while queued or self.running:
            while queued and len(self.running) < self.workers:
                self._start(queued.pop(0))
            for conn in wait(list(self.running)):
                k, process = self.running[conn]
                try:
                    kind, payload = _receive(conn, self.spills.get(conn))
                except EOFError:
                    process.join()
                    raise SimulationError(f"the worker simulating variations {self.bounds[k][0]}-"
                                          f"{self.bounds[k][1] - 1} of the run died (exit code {process.exitcode})"
                                          ) from None
                if kind == "error":
                    raise payload
                if kind == "judged" or (kind == "tables" and not judging):
                    del self.running[conn]
                    conn.close()
                    process.join()
                    if conn in self.spills:
                        self.spills.pop(conn).close()  # the mapped buffers stay valid
                yield k, kind, payload


def arrow_without_pandas() -> None:
    """Spare this process (and the workers it forks) pyarrow's import of pandas, 0.15-0.25 s of CPU.

    The first time pyarrow is handed a Python list it imports pandas only to ask whether the list is a pandas
    object; crashscene hands it none. pyarrow asks once: here it finds pandas missing and does not look again.
    Nothing else changes: an explicit pandas conversion (`Table.to_pandas`) still imports pandas, and pyarrow's
    conversions of lists and numpy arrays do not depend on it. For processes that never use pandas (the command
    line); when pandas is loaded already, nothing is done."""
    if "pandas" in sys.modules:
        return
    sys.meta_path.insert(0, _PandasMissing)
    try:
        pa.array([0.0])
    finally:
        sys.meta_path.remove(_PandasMissing)


class _PandasMissing:
    """An import finder for which pandas does not exist (put first on `sys.meta_path` while pyarrow looks)."""

    @staticmethod
    def find_spec(name: str, path=None, target=None):
        if name.partition(".")[0] == "pandas":
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


def _import_before_fork(judging: bool) -> None:
    """Load once in the parent what every forked worker would otherwise load for itself: pyarrow's pandas
    integration, unless `arrow_without_pandas` spared it (pyarrow imports pandas on its first conversion of a
    list, 0.15-0.5 s a process; the parent converts anyway when it writes the tables), numpy.ma (numpy imports it
    on the first np.median or np.unique, 20 ms a process; the parent's criticality summary calls them too) and
    the monitor's modules."""
    pa.array([0.0])
    import numpy.ma  # noqa: F401
    if judging:
        import crashscene.monitor.arrays
        import crashscene.monitor.check_traces
        import crashscene.monitor.criticality  # noqa: F401


def _simulate_block(lo: int, hi: int, send, spill: _Spill | None = None, others: list[int] = ()) -> None:
    """In a forked child: simulate scenes [lo, hi) of the inherited request, send the tables, then judge them.

    `spill`: this block's memory file for the payloads' buffers (None: they go through the pipe); `others`: the
    descriptors of earlier blocks' memory files, inherited and closed here (their memory is freed with the parent's
    mappings, not when this child exits)."""
    for fd in others:
        os.close(fd)
    try:
        backend, settings, request = _INHERITED["backend"], _INHERITED["settings"], _INHERITED["request"]
        judge, sampling = _INHERITED["judge"], _INHERITED["sampling"]
        if sampling is None:
            scenes = list(request.scenes)[lo:hi]
        else:
            start = time.perf_counter()
            scenes = sampling.scenes(lo, hi)
            seconds = time.perf_counter() - start
            _send(send, "scenes", (sampling.lines(scenes), seconds), spill)
        block = dataclasses.replace(request, scenes=scenes, progress=None)
        with create_simulator(backend, settings) as simulator:
            result = simulator.simulate(block)
        _send(send, "tables", result, spill)
        if judge is not None:
            tables = dict(result.tables)
            del result  # the judge frees the traces once it has read them
            _send(send, "judged", judge(tables), spill)
    except BaseException as exc:  # the parent raises it
        try:
            _send(send, "error", exc, spill)
        except Exception:  # not picklable: its text
            _send(send, "error", SimulationError(f"{type(exc).__name__}: {exc}"), spill)
    finally:
        send.close()
        if spill is not None:
            spill.close()


class _Spill:
    """A block's out-of-band buffers in a memory file (Linux `memfd`) the parent creates before it forks the block's
    worker: the worker writes each buffer into it (one copy, into memory pages the parent then maps: no copy on the
    parent's side) and sends only where they are through the pipe, so it neither waits for the parent to read the
    pipe (nor does the parent read one worker's tables while the other waits) nor does the parent copy them."""

    ALIGN = 64  # [bytes] each buffer starts at a multiple of this (Arrow's alignment)

    def __init__(self, fd: int):
        self.fd = fd
        self.end = 0  # [bytes] in the worker: where the next buffer may start

    @classmethod
    def create(cls, k: int) -> _Spill | None:
        """Block k's memory file, or None where there is none (not Linux: the pipe carries the buffers)."""
        if not hasattr(os, "memfd_create"):
            return None
        return cls(os.memfd_create(f"crashscene-block-{k}", os.MFD_CLOEXEC))

    def write(self, raws: list[memoryview]) -> list[tuple[int, int]]:
        """In the worker: append the buffers; their (offset, size) [bytes] in the file."""
        layout = []
        for raw in raws:
            offset = -(-self.end // self.ALIGN) * self.ALIGN
            done = 0
            while done < raw.nbytes:
                done += os.pwrite(self.fd, raw[done:], offset + done)
            layout.append((offset, raw.nbytes))
            self.end = offset + raw.nbytes
        return layout

    def read(self, layout: list[tuple[int, int]]) -> list[pa.Buffer]:
        """In the parent: the buffers at `layout`, views of one shared read-only mapping of the file (valid after
        `close`; the pages are freed when the last view is)."""
        import mmap

        end = max((offset + size for offset, size in layout if size), default=0)  # an empty one may lie past it
        if end == 0:
            return [pa.py_buffer(b"") for _ in layout]
        flags = mmap.MAP_SHARED | getattr(mmap, "MAP_POPULATE", 0)  # one call maps every page, not a fault each
        whole = pa.py_buffer(mmap.mmap(self.fd, end, flags=flags, prot=mmap.PROT_READ))
        return [whole.slice(offset, size) if size else pa.py_buffer(b"") for offset, size in layout]

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def _send(conn, kind: str, payload: Any, spill: _Spill | None = None) -> None:
    """Pickle `payload` with its Arrow buffers out of band, each written as it is (no copy of the tables) into
    `spill` or else the pipe."""
    buffers: list = []
    head = pickle.dumps(payload, protocol=5, buffer_callback=buffers.append)
    raws = [buffer.raw() for buffer in buffers]
    if spill is not None:
        conn.send((kind, spill.write(raws)))
        conn.send_bytes(head)
        return
    conn.send((kind, [raw.nbytes for raw in raws]))
    conn.send_bytes(head)
    for raw in raws:
        done = 0
        while done < raw.nbytes:
            done += os.write(conn.fileno(), raw[done:])


def _receive(conn, spill: _Spill | None = None) -> tuple[str, Any]:
    """What `_send` sent: the out-of-band buffers mapped from `spill`, or else each read from the pipe straight
    into an Arrow buffer of its own (one copy, where `Connection.recv_bytes` makes three and faults twice the pages
    in)."""
    kind, layout = conn.recv()
    head = conn.recv_bytes()
    if spill is not None:
        return kind, pickle.loads(head, buffers=spill.read(layout))
    with open(conn.fileno(), "rb", buffering=0, closefd=False) as pipe:
        buffers = [_read_exactly(pipe, size) for size in layout]
    return kind, pickle.loads(head, buffers=buffers)


def _read_exactly(pipe, size: int) -> pa.Buffer:
    buffer = pa.allocate_buffer(size)
    view = memoryview(buffer).cast("B")
    done = 0
    while done < size:
        read = pipe.readinto(view[done:])
        if not read:
            raise EOFError(f"the pipe closed {size - done} bytes before the end of a buffer")
        done += read
    return buffer


def summarize(tables: dict[str, pa.Table]) -> dict[str, Any]:
    """Counts from the simulator's own tables (collision classes by relative heading until the monitor runs)."""
    variations = tables["variations"].to_pydict()
    valid = {v for v, ok in zip(variations["variation"], variations["valid"]) if ok}
    invalid = Counter(r for r, ok in zip(variations["invalid_reason"], variations["valid"]) if not ok)
    coll = tables["collisions"].to_pylist()
    by_class: Counter = Counter()
    by_pair: dict[str, Counter] = {}
    for row in coll:
        if row["variation"] not in valid:
            continue
        klass = classify_contact(heading_difference(row["yaw_a"], row["yaw_b"])).item()
        by_class[klass] += 1
        by_pair.setdefault(f"{row['actor_a']}-{row['actor_b']}", Counter())[klass] += 1
    collided = {row["variation"] for row in coll if row["variation"] in valid}
    return {
        "collision_classes_by": "relative_heading",
        "variations": len(variations["variation"]),
        "valid": len(valid),
        "invalid": dict(invalid),
        "collisions": {"total": sum(by_class.values()), "variations_with_collision": len(collided),
                       "by_class": dict(by_class), "by_pair": {k: dict(v) for k, v in sorted(by_pair.items())}},
    }


def _conditions(rulebook) -> dict[str, float]:
    """The rulebook's CVC_22350 condition factors and friction coefficients, for the drivers ({}: defaults)."""
    params = rulebook.params.get("CVC_22350") if rulebook is not None else None
    if params is None:
        return {}
    return {k: float(v) for k, v in params.model_dump().items()
            if k.startswith(("factor_", "friction_")) and isinstance(v, (int, float))}


def _copy_render(src: Path, out_dir: Path):
    """The rendered program, map and render.json of `src`, copied into `out_dir` (no second render)."""
    from crashscene.render import Rendered

    out_dir.mkdir(parents=True, exist_ok=True)
    meta = json.loads((src / "render.json").read_text(encoding="utf-8"))
    for path in src.iterdir():  # program, map, render.json, the compiled sampler's sampler.json, Scenic's .snet
        if path.is_file():
            shutil.copyfile(path, out_dir / path.name)
    return Rendered(program=out_dir / meta["program"], map=out_dir / meta["map"],
                    scenario_hash=meta["scenario_hash"], town=meta.get("town"))


def _write_monitored(judged: Judged, out_dir: Path) -> dict[str, Any]:
    """Write the monitor's outputs and criticality.parquet; the summary keys they contribute."""
    import pyarrow.parquet as pq

    from crashscene.monitor.criticality import summarize as summarize_criticality
    from crashscene.monitor.run_folder import write_results

    result = judged.result
    write_results(out_dir, result)
    pq.write_table(judged.criticality, out_dir / "criticality.parquet", compression="zstd")
    s = result.summary()
    by_class = {k: v for k, v in s.get("collisions", {}).items() if v}
    return {
        "violations": s.get("violations", {}),
        "verdicts": s.get("verdicts", {}),
        "reproduced": s.get("reproduced"),
        "reproduction_rate": s.get("reproduction_rate"),
        "first_contact_rate": s.get("first_contact_rate"),
        "sequence_rate": s.get("sequence_rate"),
        "area_match_rate": s.get("area_match_rate"),
        "collision_classes_by": "monitor",
        "monitor_collisions": {"by_class": by_class, "by_pair": s.get("collision_pairs", {}),
                               "total": sum(by_class.values())},
        "expected_collision": s.get("expected_collision"),
        "expected_sequence": s.get("expected_sequence"),
        "criticality": summarize_criticality(judged.criticality),
    }
