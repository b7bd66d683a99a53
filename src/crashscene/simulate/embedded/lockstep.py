"""Many variations' plans run in lockstep, so that a costly step each of them takes is computed for all at once.

A plan is per-variation Python (`plan.VariationPlan.build`), but some of its steps integrate a motion over many
steps for a few candidates (a clip's slide, `cascade.clip_slides`): one small numpy call per step and candidate,
where one call for every candidate of every variation costs about the same. `run` gives each job (a variation's
plan) a thread of its own, but lets only one run at a time, in a fixed order: a job runs until it asks for such a
step (`together(fn, items)`), then the next job runs; when every job waits or is done, `fn` is called once on
the items of all the jobs that asked for it (in job order) and the jobs resume, in order, each with its own
results. The threads only hold the jobs' places: nothing runs concurrently, so a job computes exactly what it
computes alone, provided `fn` computes each item as it would alone (element-wise numpy arithmetic does).
Outside `run`, `together(fn, items)` is `fn(items)`.
"""
from __future__ import annotations

import contextvars
import threading
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

T = TypeVar("T")

GROUP = 256  # [-] jobs run in lockstep at a time (threads alive at once)

_current = threading.local()  # in a job's thread: (runner, job index)


def together(fn: Callable[[list], list], items: list) -> list:
    """`fn(items)`; inside `run`, computed in one call of `fn` with the items of every job that asks for `fn`
    (fn must map a list of items to the list of their results, each item computed as it would be alone)."""
    here = getattr(_current, "job", None)
    if here is None:
        return fn(items)
    runner, k = here
    return runner.ask(k, fn, items)


def run(jobs: Sequence[Callable[[], T]]) -> list[T]:
    """The results of `jobs` (called with no arguments), run in lockstep in groups of GROUP; the first job's
    exception (in job order) is raised, as running them one after the other would."""
    results: list[Any] = []
    for lo in range(0, len(jobs), GROUP):
        results.extend(_Runner(jobs[lo:lo + GROUP]).results())
    return results


class _Runner:
    """One group of jobs in lockstep: each has a thread, which runs only while the runner waits for it."""

    def __init__(self, jobs: Sequence[Callable[[], Any]]):
        self.jobs = list(jobs)
        n = len(self.jobs)
        self.go = [threading.Semaphore(0) for _ in range(n)]  # the job's turn
        self.back = threading.Semaphore(0)  # the runner's turn
        self.asked: dict[int, tuple[Callable[[list], list], list]] = {}
        self.next: list[int | None] = [None] * n  # the job that runs after each in this turn (None: the runner)
        self.answer: list[Any] = [None] * n
        self.out: list[Any] = [None] * n
        self.error: list[BaseException | None] = [None] * n
        self.context = contextvars.copy_context()  # numpy's error state and the like, as the caller has them

    def ask(self, k: int, fn: Callable[[list], list], items: list) -> list:
        self.asked[k] = (fn, items)
        self._pass(k)
        self.go[k].acquire()
        answer, self.answer[k] = self.answer[k], None
        if isinstance(answer, _Failed):
            raise answer.error
        return answer

    def _body(self, k: int) -> None:
        self.go[k].acquire()
        _current.job = (self, k)
        try:
            self.out[k] = self.context.copy().run(self.jobs[k])
        except BaseException as exc:  # raised by the runner, in job order
            self.error[k] = exc
        finally:
            _current.job = None
            self._pass(k)

    def _pass(self, k: int) -> None:
        """Job k asked or ended: the next job of this turn runs, or the runner after the last."""
        nxt = self.next[k]
        (self.back if nxt is None else self.go[nxt]).release()

    def results(self) -> list[Any]:
        threads = [threading.Thread(target=self._body, args=(k,), daemon=True) for k in range(len(self.jobs))]
        for thread in threads:
            thread.start()
        turn = list(range(len(self.jobs)))
        while turn:
            for k, nxt in zip(turn, turn[1:] + [None]):  # each runs until it asks or ends, then the next runs
                self.next[k] = nxt
            self.go[turn[0]].release()
            self.back.acquire()
            turn = sorted(self.asked)
            by_fn: dict[Callable[[list], list], list[int]] = {}
            for k in turn:
                by_fn.setdefault(self.asked[k][0], []).append(k)
            for fn, ks in by_fn.items():
                items = [item for k in ks for item in self.asked[k][1]]
                try:
                    got = fn(items)
                except BaseException as exc:  # each job asking raises it, where it asked
                    for k in ks:
                        self.answer[k] = _Failed(exc)
                    continue
                i = 0
                for k in ks:
                    n = len(self.asked[k][1])
                    self.answer[k] = list(got[i:i + n])
                    i += n
            self.asked.clear()
        for thread in threads:
            thread.join()
        for exc in self.error:
            if exc is not None:
                raise exc
        return self.out


class _Failed:
    def __init__(self, error: BaseException):
        self.error = error
