"""Test mode keeps a junction a real test: a stop- or yield-controlled NPC whose oracle says it does not yield
waits at (or near) its line and pulls out when the ADS is about PULL_OUT_TTA away from their conflict point (a
search samples that time as `<role>_PULL_OUT_TTA`), never later than the ADS's reaction plus braking distance
allows. When the ADS is already inside that distance as the NPC reaches its line, the plan cannot give it a
fair chance: the variation is invalid (`unavoidable`).

Reproduce mode uses the same wait for a written contact that happens on a turn out of a stop-controlled approach
(plan.VariationPlan.pull_out): the turner pulls out when its partner is as far in time from the touch as the
turner takes from rest to get there (from where it stands: `rest`, `touch_speed`); no fairness applies (`fair`
False: the crash is the report's).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crashscene.simulate.roads import STOP_LINE_SETBACK

PULL_OUT_TTA = 2.0  # [s] the NPC pulls out when the ADS is this far in time from the conflict point
ADS_REACTION = 1.0  # [s] perception-reaction time granted to the ADS (a human driver's; rules of the road)
MARGIN = 0.3  # [s] added to the ADS's reaction and braking time when that is longer than PULL_OUT_TTA
WAIT_DECEL = 6.0  # [m/s2] the NPC starts waiting (braking hard) where it can stop at this rate at its line
UNAVOIDABLE = "unavoidable: the ADS was inside its reaction plus braking distance of the conflict point " \
              "when the NPC reached its line"


def stopping_distance(v: np.ndarray, brake: np.ndarray | float) -> np.ndarray:
    """Reaction plus braking distance [m] from speed v [m/s] at `brake` [m/s2]."""
    return v * ADS_REACTION + v ** 2 / (2.0 * brake)


@dataclass
class PullOut:
    """Per variation (V,): the waiting NPC column (-1: none), the ADS column, the NPC's line station and both
    conflict stations [m], the ADS's time to the conflict point [s] at which the NPC pulls out; `released` /
    `judged` record the run."""

    npc: np.ndarray
    ads: np.ndarray
    line: np.ndarray
    cs_npc: np.ndarray
    cs_ads: np.ndarray
    ads_brake: float  # [m/s2] the ADS vehicle's braking limit
    released: np.ndarray
    judged: np.ndarray
    tta: np.ndarray  # [s]
    fair: np.ndarray  # (V,) bool: the partner is given its reaction plus braking time (test mode)
    rest: np.ndarray  # (V,) [m] the NPC's centre's station at rest for which `tta` holds (NaN: tta as it is)
    touch_speed: np.ndarray  # (V,) [m/s] ...and its speed where it is to be met: a start further back takes longer

    @classmethod
    def none(cls, n_v: int, ads_brake: float = 8.0) -> "PullOut":
        return cls(np.full(n_v, -1), np.full(n_v, -1), np.full(n_v, np.nan), np.full(n_v, np.nan),
                   np.full(n_v, np.nan), ads_brake, np.zeros(n_v, dtype=bool), np.zeros(n_v, dtype=bool),
                   np.full(n_v, PULL_OUT_TTA), np.ones(n_v, dtype=bool), np.full(n_v, np.nan), np.full(n_v, np.nan))

    def step(self, t: float, s: np.ndarray, v: np.ndarray, length: np.ndarray, hold_until: np.ndarray,
             invalid: list) -> None:
        """Hold or release each waiting NPC (writes hold_until (V, A) in place: the drivers read it), and
        mark `invalid` [v] unavoidable where the ADS was already too close."""
        idx = np.nonzero((self.npc >= 0) & ~self.released)[0]
        if len(idx) == 0:
            return
        n, a = self.npc[idx], self.ads[idx]
        v_n, v_a = v[idx, n], np.maximum(v[idx, a], 0.1)
        to_line = self.line[idx] - (s[idx, n] + length[idx, n] / 2)
        ads_dist = self.cs_ads[idx] - (s[idx, a] + length[idx, a] / 2)
        passed = ads_dist < -length[idx, a]
        fair = self.fair[idx]
        need = stopping_distance(v_a, self.ads_brake)
        # from rest further back than planned it takes longer, by the extra distance at its speed where it is met
        behind = np.where(np.isnan(self.rest[idx]), 0.0, (self.rest[idx] - s[idx, n]) / self.touch_speed[idx])
        pull_tta = np.where(fair, np.maximum(self.tta[idx], need / v_a + MARGIN), self.tta[idx] + behind)
        at_line = (to_line < v_n ** 2 / (2.0 * WAIT_DECEL) + 0.5) | self.judged[idx]
        first = at_line & ~self.judged[idx]
        for k in np.nonzero(first & fair & ~passed & (ads_dist >= 0) & (ads_dist < need))[0]:
            invalid[idx[k]] = invalid[idx[k]] or UNAVOIDABLE
        self.judged[idx] |= at_line
        go = passed | (ads_dist / v_a <= pull_tta) & at_line
        hold_until[idx, n] = np.where(go, t, np.where(at_line, np.inf, hold_until[idx, n]))
        self.released[idx] |= go


def line_station(entry_s: float) -> float:
    """Station [m] of the stop or yield line of a junction entry."""
    return entry_s - STOP_LINE_SETBACK
