"""Plans run in lockstep (simulate.embedded.lockstep, greenlets) compute exactly what they compute alone, and the costly steps
they batch (a clip's slide, a pull-out's path, the touch and areas of a skid's contacts) give each element the
bits it has when computed by itself."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.embedded import cascade, lockstep, skid, swerve


def _job(k: int, seen: list):
    def run():
        got = []
        for step in range(k % 4):  # jobs ask different numbers of times
            got.append(lockstep.together(_doubled, [(k, step)] * (1 + k % 3)))
            seen.append(k)
        return k, got
    return run


def _doubled(items: list) -> list:
    _doubled.calls.append(len(items))
    return [2 * k + step for k, step in items]


def test_jobs_in_lockstep_get_their_own_answers_from_one_call_per_round():
    _doubled.calls = []
    seen: list = []
    n = lockstep.GROUP + 7  # two groups
    out = lockstep.run([_job(k, seen) for k in range(n)])
    alone = [(k, [[2 * k + s] * (1 + k % 3) for s in range(k % 4)]) for k in range(n)]
    assert out == alone
    # one call per round and group (3 rounds: jobs ask at most three times), every asking job's items in it
    assert len(_doubled.calls) == 6
    assert sum(_doubled.calls) == sum((1 + k % 3) * (k % 4) for k in range(n))
    # in job order within a round
    first_round = seen[:sum(1 for k in range(lockstep.GROUP) if k % 4)]
    assert first_round == sorted(first_round)


def test_outside_a_run_together_is_the_call_itself():
    _doubled.calls = []
    assert lockstep.together(_doubled, [(3, 1), (4, 0)]) == [7, 8]
    assert _doubled.calls == [2]


def test_the_first_failing_job_in_job_order_raises():
    def job(k):
        def run():
            lockstep.together(_doubled, [(k, 0)])
            if k in (5, 9):
                raise ValueError(f"job {k}")
            return k
        return run

    _doubled.calls = []
    with pytest.raises(ValueError, match="job 5"):
        lockstep.run([job(k) for k in range(12)])


def test_a_failing_batch_raises_in_every_job_that_asked():
    def broken(items):
        raise RuntimeError("broken batch")

    def job():
        try:
            lockstep.together(broken, [1])
        except RuntimeError as exc:
            return str(exc)
        return "no error"

    assert lockstep.run([job, job]) == ["broken batch", "broken batch"]


def test_clip_slides_at_once_equal_each_alone():
    rng = np.random.default_rng(4)
    dt = 0.1
    clips = []
    for i in range(9):
        speed = rng.uniform(12, 25)
        t = dt * np.arange(1, 61)
        rows = (speed * t, rng.uniform(0.0, 0.05) * t ** 2, rng.uniform(0.0, 0.02) * t)
        clips.append(cascade.Clip(rows, float(rng.choice([-1.0, 1.0])), speed, rng.uniform(-0.5, 0.5),
                                  rng.uniform(6, 12), speed - rng.uniform(3, 8), rng.uniform(-1.5, 1.5),
                                  0.0 if i == 0 else dt * int(rng.integers(2, 30)), dt,
                                  (rng.uniform(4, 5), 1.8, 1500.0, 0.6), (rng.uniform(4, 6), 1.9, 1800.0, 0.6),
                                  0.8))
    together = cascade.clip_slides(clips)
    assert together[0] is None  # its rows do not reach the meeting
    for clip, got in zip(clips, together):
        alone = cascade.clip_slides([clip])[0]
        assert (got is None) == (alone is None)
        if got is not None:
            assert got[0] == alone[0]
            for a, b in zip(got[1], alone[1]):
                assert np.array_equal(a, b)


def test_swerve_paths_at_once_equal_each_alone():
    rng = np.random.default_rng(5)
    requests = [(rng.uniform(5, 30), rng.uniform(-4, 4), rng.uniform(0.5, 2.5), rng.uniform(2.4, 3.2),
                 np.radians(60), np.radians(35), 0.1) for _ in range(7)]
    for got, request in zip(swerve.paths(requests), requests):
        for a, b in zip(got, swerve.path(*request)):
            assert a.shape == (1, 60) and np.array_equal(a, b)


def test_skid_touches_and_areas_at_once_equal_each_alone():
    rng = np.random.default_rng(6)
    items = []
    for n in (3, 1, 8):
        before = [rng.uniform(-6, -4, n), rng.uniform(-1, 1, n), rng.uniform(-0.5, 0.5, n)]
        after = [b + rng.uniform(0.5, 2.0, n) for b in before]
        items.append((before, after, skid.Body(4.5, 1.8), skid.Body(rng.uniform(4, 6), 1.9), float(rng.uniform(0, 3))))
    touched = skid._touches(items)
    for item, got in zip(items, touched):
        for a, b in zip(got, skid._touches([item])[0]):
            assert np.array_equal(a, b)
    area_items = [(*got, item[2], item[3], item[4]) for item, got in zip(items, touched)]
    for item, got in zip(area_items, skid._areas(area_items)):
        for a, b in zip(got, skid._areas([item])[0]):
            assert list(a) == list(b)


def test_jobs_run_with_the_callers_numpy_error_state():
    def job():
        lockstep.together(_doubled, [(0, 0)])
        return np.array([1.0]) / np.array([0.0])

    _doubled.calls = []
    with np.errstate(divide="raise"):
        with pytest.raises(FloatingPointError):
            lockstep.run([job])
    with np.errstate(divide="ignore"):
        assert lockstep.run([job])[0][0] == np.inf
