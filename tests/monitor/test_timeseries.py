"""The vectorised time-axis helpers every rule builds on."""
from __future__ import annotations

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

from crashscene.monitor.timeseries import (
    crossings,
    first_index,
    last_index,
    run_length,
    runs,
    window_max,
    window_min,
)


@pytest.mark.parametrize("k", [1, 2, 3, 5, 10, 13, 16, 64])
def test_window_min_matches_sliding_window(k):
    rng = np.random.default_rng(k)
    x = rng.normal(size=(4, 3, 50))
    x[0, 1, 7] = np.nan
    filled = np.where(np.isnan(x), -np.inf, x)
    pad = np.full(x.shape[:-1] + (k - 1,), -np.inf)
    ref = sliding_window_view(np.concatenate([pad, filled], -1), k, axis=-1).min(-1)
    assert np.array_equal(window_min(x, k), ref)
    assert np.array_equal(window_max(-x, k), -ref)


def test_runs_and_indices():
    mask = np.array([[0, 1, 1, 0, 1, 1, 1], [0, 0, 0, 0, 0, 0, 0]], dtype=bool)
    assert run_length(mask).tolist()[0] == [0, 1, 2, 0, 1, 2, 3]
    assert first_index(mask).tolist() == [1, -1] and last_index(mask).tolist() == [6, -1]
    ids, n = runs(mask)
    assert n == 2 and ids[0].tolist() == [-1, 0, 0, -1, 1, 1, 1]


def test_crossings_ignore_nan():
    d = np.array([3.0, 1.0, -0.5, np.nan, 2.0, 0.0])
    assert np.nonzero(crossings(d))[0].tolist() == [2, 5]
