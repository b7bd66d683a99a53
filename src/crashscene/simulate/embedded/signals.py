"""Traffic-light phase plans: two signal groups per junction (the anchor's axis and the cross axis).

Each junction cycles group 0 green -> yellow -> all red -> group 1 green ->
yellow -> all red. The phase is chosen per variation so that the anchor actor
(the ADS under test) meets a green light at its nominal arrival, with a sampled
remaining green time (short remainders put it in the dilemma zone), unless the
anchor itself runs the red light in reproduce mode, in which case its axis is red.
"""
from __future__ import annotations

import numpy as np

GREEN = 20.0  # [s] per group
YELLOW = 3.0  # [s]
ALL_RED = 1.0  # [s]
CYCLE = 2 * (GREEN + YELLOW + ALL_RED)  # [s]

# SIGNAL_* codes of drivers.base
_GREEN, _YELLOW, _RED = 1, 2, 3


def signal_state(group: np.ndarray, t: float, phase: np.ndarray) -> np.ndarray:
    """Signal code (1 green, 2 yellow, 3 red) of `group` (0 or 1) at time t [s] with per-variation `phase` [s]."""
    local = np.mod(t + phase - group * (GREEN + YELLOW + ALL_RED), CYCLE)
    return np.where(local < GREEN, _GREEN, np.where(local < GREEN + YELLOW, _YELLOW, _RED)).astype(np.int8)


def phase_for(arrival: np.ndarray, green_remaining: np.ndarray, anchor_runs_red: bool) -> np.ndarray:
    """Phase [s] that gives the anchor's group (0) `green_remaining` [s] of green at `arrival` [s],
    or, when the anchor runs the red, gives the cross group that much green (so group 0 is red)."""
    if anchor_runs_red:
        target = (GREEN + YELLOW + ALL_RED) + GREEN - green_remaining
    else:
        target = GREEN - green_remaining
    return np.mod(target - arrival, CYCLE)
