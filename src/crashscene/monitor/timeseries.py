"""Vectorised helpers over the last (time) axis of monitor arrays.

All functions accept arrays of any leading shape (variation, actor[, actor])
and work along axis -1, so a rule never loops over variations.
"""
from __future__ import annotations

import numpy as np


def steps_for(duration: float, dt: float) -> int:
    """Samples spanning `duration` [s] at step `dt` [s] (at least 1)."""
    return max(1, round(duration / dt))


def first_index(mask: np.ndarray) -> np.ndarray:
    """Index of the first True along time, -1 when none."""
    idx = np.argmax(mask, axis=-1)
    return np.where(mask.any(axis=-1), idx, -1)


def last_index(mask: np.ndarray) -> np.ndarray:
    """Index of the last True along time, -1 when none."""
    n = mask.shape[-1]
    idx = n - 1 - np.argmax(mask[..., ::-1], axis=-1)
    return np.where(mask.any(axis=-1), idx, -1)


def take(values: np.ndarray, index: np.ndarray, fill: float = np.nan) -> np.ndarray:
    """values[..., index] per leading element; `fill` where index is -1."""
    safe = np.clip(index, 0, values.shape[-1] - 1)
    out = np.take_along_axis(values, safe[..., None], axis=-1)[..., 0]
    return np.where(index >= 0, out, fill)


def run_length(mask: np.ndarray) -> np.ndarray:
    """Number of consecutive True samples ending at each step (0 where False)."""
    n = mask.shape[-1]
    steps = np.broadcast_to(np.arange(n), mask.shape)
    last_false = np.where(mask, -1, steps)
    last_false = np.maximum.accumulate(last_false, axis=-1)
    return np.where(mask, steps - last_false, 0)


def window_min(values: np.ndarray, k: int) -> np.ndarray:
    """Minimum over the k samples ending at each step; NaN counts as -inf (breaks a sustained run).

    Windows reaching before the first sample count as -inf too. Built from
    power-of-two windows (van Herk style), a handful of array passes for any k.
    """
    filled = np.where(np.isnan(values), -np.inf, values)
    if k <= 1:
        return filled

    def shifted(x: np.ndarray, by: int) -> np.ndarray:
        if by == 0:
            return x
        out = np.full(x.shape, -np.inf)
        if by < x.shape[-1]:
            out[..., by:] = x[..., :-by]
        return out

    acc = None
    block, size, done = filled, 1, 0
    while k:
        if k & 1:
            part = shifted(block, done)
            acc = part if acc is None else np.minimum(acc, part)
            done += size
        k >>= 1
        if k:
            block = np.minimum(block, shifted(block, size))
            size *= 2
    return acc


def window_max(values: np.ndarray, k: int) -> np.ndarray:
    """Maximum over the k samples ending at each step; NaN counts as +inf (breaks a sustained run)."""
    return -window_min(-values, k)


def crossings(dist: np.ndarray) -> np.ndarray:
    """Steps where a signed distance goes from > 0 to <= 0 (a front bumper crossing a line)."""
    out = np.zeros(dist.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        out[..., 1:] = (dist[..., :-1] > 0) & (dist[..., 1:] <= 0)
    return out


def segment_running_min(values: np.ndarray, include: np.ndarray, reset: np.ndarray) -> np.ndarray:
    """Running minimum of `values` over included steps, restarting after each `reset` step.

    Loops over time only (a few hundred steps), each step vectorised over all
    leading elements.
    """
    out = np.full(values.shape, np.inf)
    current = np.full(values.shape[:-1], np.inf)
    for step in range(values.shape[-1]):
        v = np.where(include[..., step], values[..., step], np.inf)
        current = np.fmin(current, v)
        out[..., step] = current
        current = np.where(reset[..., step], np.inf, current)
    return out


def runs(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """Label consecutive True runs: (ids with -1 outside runs, number of runs); ids are global."""
    starts = mask.copy()
    starts[..., 1:] &= ~mask[..., :-1]
    ids = np.cumsum(starts.ravel()).reshape(mask.shape) - 1
    return np.where(mask, ids, -1), int(starts.sum())


def margin_in(primary_threshold: np.ndarray | float, margin: np.ndarray,
              threshold: np.ndarray | float) -> np.ndarray:
    """A secondary criterion's margin expressed in the primary threshold's unit (relative scaling).

    Lets a rule with two criteria (e.g. time gap and braking) report one
    robustness value in one unit: the secondary margin as a share of its own
    threshold, times the primary threshold.
    """
    return margin / np.abs(threshold) * np.abs(primary_threshold)
