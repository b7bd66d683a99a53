"""Many variations' plans run in lockstep, so that a costly step each of them takes is computed for all at once.

A plan is per-variation Python (`plan.VariationPlan.build`), but some of its steps integrate a motion over many
steps for a few candidates (a clip's slide, `cascade.clip_slides`): one small numpy call per step and candidate,
where one call for every candidate of every variation costs about the same. `run` runs each job (a variation's
plan) in a greenlet of its own, one at a time, in a fixed order: a job runs until it asks for such a step
(`together(fn, items)`), then the next job runs; when every job waits or is done, `fn` is called once on the
items of all the jobs that asked for it (in job order) and the jobs resume, in order, each with its own results.
Nothing runs concurrently, so a job computes exactly what it computes alone, provided `fn` computes each item as
it would alone (element-wise numpy arithmetic does). Outside `run`, `together(fn, items)` is `fn(items)`.
"""
from __future__ import annotations

import contextvars
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import greenlet
import numpy as np

T = TypeVar("T")

GROUP = 256  # [-] jobs run in lockstep at a time


class _Ask:
    """What a job's greenlet hands back to the runner when it asks for a batched step."""

    __slots__ = ("fn", "items")

    def __init__(self, fn: Callable[[list], list], items: list):
        self.fn, self.items = fn, items


class _Failed:
    """A batched step that raised: every job that asked for it raises the error where it asked."""

    __slots__ = ("error",)

    def __init__(self, error: BaseException):
        self.error = error


_running: set = set()  # the greenlets of the jobs now in a lockstep run


def together(fn: Callable[[list], list], items: list) -> list:
    """`fn(items)`; inside `run`, computed in one call of `fn` with the items of every job that asks for `fn`
    (fn must map a list of items to the list of their results, each item computed as it would be alone)."""
    here = greenlet.getcurrent()
    if here not in _running:
        return fn(items)
    answer = here.parent.switch(_Ask(fn, items))
    if isinstance(answer, _Failed):
        raise answer.error
    return answer


def per_element(values, sizes: Sequence[int]) -> np.ndarray:
    """A batched step's inputs: one value per item, repeated over that item's `sizes` elements (the items'
    elements concatenated in item order)."""
    return np.repeat(np.array(list(values), dtype=float), sizes)


def per_item(arrays: Sequence[np.ndarray], sizes: Sequence[int]) -> list[tuple[np.ndarray, ...]]:
    """A batched step's results back by item: each item's `sizes` elements of every one of `arrays` (the items'
    elements concatenated in item order)."""
    ends = np.cumsum(sizes)
    return [tuple(a[e - m:e] for a in arrays) for e, m in zip(ends, sizes)]


def run(jobs: Sequence[Callable[[], T]]) -> list[T]:
    """The results of `jobs` (called with no arguments), run in lockstep in groups of GROUP; the first job's
    exception (in job order) is raised, as running them one after the other would."""
    results: list[Any] = []
    for lo in range(0, len(jobs), GROUP):
        results.extend(_group(jobs[lo:lo + GROUP]))
    return results


def _group(jobs: Sequence[Callable[[], Any]]) -> list[Any]:
    n = len(jobs)
    out: list[Any] = [None] * n
    error: list[BaseException | None] = [None] * n
    lets = [greenlet.greenlet(job) for job in jobs]
    for let in lets:
        let.gr_context = contextvars.copy_context()  # numpy's error state and the like, as the caller has them
    asked: dict[int, _Ask] = {}
    answer: list[Any] = [None] * n  # what each waiting job resumes with
    turn = list(range(n))
    _running.update(lets)
    try:
        while turn:
            for k in turn:  # each runs until it asks or ends
                try:
                    got = lets[k].switch(answer[k]) if lets[k] else lets[k].switch()
                except BaseException as exc:  # raised by run, in job order
                    error[k] = exc
                    continue
                if isinstance(got, _Ask):
                    asked[k] = got
                else:
                    out[k] = got
            turn = sorted(asked)
            by_fn: dict[Callable[[list], list], list[int]] = {}
            for k in turn:
                by_fn.setdefault(asked[k].fn, []).append(k)
            for fn, ks in by_fn.items():
                items = [item for k in ks for item in asked[k].items]
                try:
                    results = fn(items)
                except BaseException as exc:  # each job that asked raises it, where it asked
                    for k in ks:
                        answer[k] = _Failed(exc)
                    continue
                i = 0
                for k in ks:
                    m = len(asked[k].items)
                    answer[k] = list(results[i:i + m])
                    i += m
            asked.clear()
    finally:
        _running.difference_update(lets)
    for exc in error:
        if exc is not None:
            raise exc
    return out
