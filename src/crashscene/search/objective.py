"""Objectives of a search: lower is closer to (or further into) an ADS failure.

- `robustness`: the minimum rule robustness of the actors under test over the
  rulebook (rules.md: signed margin to each threshold, negative when
  violated), clipped to [-ROBUSTNESS_CAP, ROBUSTNESS_CAP]; a collision
  involving them is the lowest value, COLLISION_ROBUSTNESS minus the impact
  speed [m/s] (among collisions, a harder impact is the worse failure, so a
  search keeps a gradient after its first contact); no applicable rule scores
  ROBUSTNESS_CAP.
- `ttc`: their minimum time to collision [s] (crashscene.monitor.criticality),
  capped at TTC_CAP, continued on both sides so that no region of the
  parameter space is flat: below 0 at a contact, minus the time full braking
  (FULL_BRAKING, 1 g) would have needed to shed the impact speed (a harder
  impact is the worse failure); above TTC_CAP when never on a collision
  course, plus the closest gap [m] between the footprints over CLOSING_SPEED
  (how long that gap would take to close, at most TTC_CAP): a near miss
  ranks below a wide berth.

A failure is a valid variation whose verdict is `violation` or `collision`,
whatever the objective. Invalid variations have no objective (NaN); samplers
are told the cap instead, so they steer away from them.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from crashscene.monitor.criticality import ads_objectives

OBJECTIVES = ("robustness", "ttc")
FAILURE_VERDICTS = ("violation", "collision")
ROBUSTNESS_CAP = 100.0   # rule units ([s], [m], [m/s]): margins beyond this are all "far"
COLLISION_ROBUSTNESS = -2 * ROBUSTNESS_CAP  # below every clipped robustness
TTC_CAP = 20.0           # [s] the default horizon
FULL_BRAKING = 9.81      # [m/s2] 1 g: an impact speed [m/s] over it is the braking time [s] that was missing
CLOSING_SPEED = 10.0     # [m/s] a gap [m] over it is the time [s] it would take to close


def worst_value(objective: str) -> float:
    """What a sampler is told for a variation without an objective (invalid): the worst value there is."""
    return 2 * TTC_CAP if objective == "ttc" else ROBUSTNESS_CAP


def objective_values(objective: str, variations: np.ndarray, verdicts: pa.Table, rule_results: pa.Table,
                     collisions: pa.Table, criticality: pa.Table) -> np.ndarray:
    """(N,) objective per variation of `variations` (NaN for invalid ones)."""
    verdict = dict(zip(verdicts["variation"].to_pylist(), verdicts["verdict"].to_pylist()))
    invalid = np.array([verdict.get(int(v), "invalid") == "invalid" for v in variations])
    if objective == "ttc":
        per_var = ads_objectives(criticality)
        metric = lambda key: np.array([per_var.get(int(v), {}).get(key, np.nan) for v in variations], dtype=float)
        ttc, gap, impact = metric("min_ttc"), metric("min_gap"), metric("impact_speed")
        out = np.where(np.isfinite(ttc), np.minimum(ttc, TTC_CAP),
                       TTC_CAP + np.minimum(np.where(np.isfinite(gap), gap, 0.0) / CLOSING_SPEED, TTC_CAP))
        out = np.where(np.isfinite(impact), -impact / FULL_BRAKING, out)
    else:
        rr = rule_results.filter(pc.and_(rule_results["is_ads"], pc.is_finite(rule_results["robustness"])))
        lowest: dict[int, float] = {}
        for row in rr.group_by("variation").aggregate([("robustness", "min")]).to_pylist():
            lowest[int(row["variation"])] = row["robustness_min"]
        rob = np.array([lowest.get(int(v), ROBUSTNESS_CAP) for v in variations], dtype=float)
        out = np.clip(rob, -ROBUSTNESS_CAP, ROBUSTNESS_CAP)
        hit = collisions.filter(collisions["involves_ads"]) if collisions.num_rows else collisions
        collided = set(int(v) for v in hit["variation"].to_pylist()) if hit.num_rows else set()
        impact = ads_objectives(criticality)
        severity = np.array([impact.get(int(v), {}).get("impact_speed", np.nan) for v in variations], dtype=float)
        severity = np.where(np.isfinite(severity), severity, 0.0)
        out = np.where([int(v) in collided for v in variations], COLLISION_ROBUSTNESS - severity, out)
    return np.where(invalid, np.nan, out)
