"""Where chunks run: a local process pool or Ray tasks, behind one small interface.

Both engines take the same `ChunkTask`s and a worker function
`worker(task) -> ChunkResult` (a picklable top-level function) and yield
`(task, result_or_exception)` as chunks finish, in completion order. The driver
alone writes to the database, so workers share nothing.
"""
from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import signal
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from crashscene.campaign.errors import CampaignError
from crashscene.campaign.model import ChunkResult, ChunkTask

Worker = Callable[[ChunkTask], ChunkResult]
Outcome = tuple[ChunkTask, "ChunkResult | BaseException"]
RAY_OBJECT_STORE = 100 * 1024 * 1024  # [bytes] chunk results are small; keep Ray's shared memory modest
_PR_SET_PDEATHSIG = 1


def quiet_scenic_warnings() -> None:
    """Scenic warns on import that `carla` is missing and that it cannot hook sys.excepthook: noise here."""
    warnings.filterwarnings("ignore", message='the "carla" package is not installed')
    warnings.filterwarnings("ignore", message="unable to install sys.excepthook")


def _die_with_parent() -> None:
    """Pool initializer: a worker gets SIGKILL when its parent dies (a killed campaign leaves no orphans)."""
    quiet_scenic_warnings()
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    except OSError:  # not Linux: orphans finish their chunk and exit
        pass
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's to handle


class LocalEngine:
    """A pool of `workers` processes on this machine (spawned: no state inherited from the driver)."""

    name = "local"

    def __init__(self, workers: int | None = None):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self._pool: ProcessPoolExecutor | None = None

    def run(self, tasks: Iterable[ChunkTask], worker: Worker) -> Iterator[Outcome]:
        tasks = list(tasks)
        if not tasks:
            return
        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=mp.get_context("spawn"),
                                             initializer=_die_with_parent)
        pending: dict[Future, ChunkTask] = {self._pool.submit(worker, t): t for t in tasks}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                task = pending.pop(fut)
                try:
                    yield task, fut.result()
                except BrokenProcessPool as exc:
                    raise CampaignError(f"a worker process died while running {task.key} "
                                        "(out of memory or killed?); rerun with --resume") from exc
                except Exception as exc:  # noqa: BLE001  (a chunk's failure is data, not a crash)
                    yield task, exc

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def abort(self) -> None:
        """Stop at once: kill the workers (their unfinished chunks are simply not stored)."""
        if self._pool is not None:
            for proc in list(getattr(self._pool, "_processes", {}).values()):
                proc.kill()
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None


def _ray_call(worker: Worker, task: ChunkTask) -> ChunkResult | BaseException:
    quiet_scenic_warnings()
    try:
        return worker(task)
    except Exception as exc:  # noqa: BLE001  (returned so one failed chunk does not fail the campaign)
        return CampaignError(f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}")


class RayEngine:
    """The same chunks as Ray tasks: joins `address` when given, else starts a small local Ray.

    Joining a cluster started with `ray start` (token authentication by default since Ray 2.5x) needs the
    cluster's token in this process's environment (`RAY_AUTH_MODE=token` and `RAY_AUTH_TOKEN` or
    `RAY_AUTH_TOKEN_PATH`), and its workers must be able to import crashscene.
    """

    name = "ray"

    def __init__(self, workers: int | None = None, address: str | None = None,
                 object_store_memory: int = RAY_OBJECT_STORE):
        try:
            import ray
        except ImportError as exc:
            raise CampaignError("--engine ray needs Ray: pip install 'crashscene[ray]'") from exc
        self._ray = ray
        self.workers = max(1, workers or os.cpu_count() or 1)
        self._started = False
        if not ray.is_initialized():
            kwargs = dict(include_dashboard=False, log_to_driver=False, logging_level="ERROR")
            try:
                if address:
                    ray.init(address=address, **kwargs)
                else:
                    ray.init(num_cpus=self.workers, object_store_memory=object_store_memory, **kwargs)
            except Exception as exc:  # noqa: BLE001  (ray raises ConnectionError, RuntimeError, ValueError...)
                where = f"the Ray cluster at {address}" if address else "a local Ray"
                raise CampaignError(f"cannot start or join {where}: {exc}") from exc
            self._started = True
        if address:  # a cluster's size is its own, not this machine's
            self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))

    def run(self, tasks: Iterable[ChunkTask], worker: Worker) -> Iterator[Outcome]:
        ray = self._ray
        remote = ray.remote(num_cpus=1, max_retries=2)(_ray_call)
        worker_ref = ray.put(worker)
        pending = {remote.remote(worker_ref, t): t for t in tasks}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                task = pending.pop(ref)
                try:
                    yield task, ray.get(ref)
                except Exception as exc:  # noqa: BLE001  (task lost: worker died, node gone)
                    yield task, CampaignError(f"Ray task failed: {exc}")

    def close(self) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False

    abort = close


def make_engine(name: str, workers: int | None = None, address: str | None = None) -> LocalEngine | RayEngine:
    if name == "local":
        if address:
            raise CampaignError("--address joins a Ray cluster; use it with --engine ray")
        return LocalEngine(workers)
    if name == "ray":
        return RayEngine(workers, address)
    raise CampaignError(f"unknown engine {name!r}; allowed: local, ray")
