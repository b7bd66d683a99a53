"""Objectives of a search: lower is closer to (or further into) an ADS failure.

- `robustness`: the minimum rule robustness of the actors under test over the
  rulebook (rules.md: signed margin to each threshold, negative when
  violated), clipped to [-ROBUSTNESS_CAP, ROBUSTNESS_CAP]; a collision
  involving them is the lowest value, COLLISION_ROBUSTNESS minus the impact
  speed [m/s] (among collisions, a harder impact is the worse failure, so a
  search keeps a gradient after its first contact); no applicable rule scores
  ROBUSTNESS_CAP.
- `ttc`: their minimum time to collision [s] (crashscene.monitor.criticality),
  0 at a contact, TTC_CAP when never on a collision course.

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


def worst_value(objective: str) -> float:
    """What a sampler is told for a variation without an objective (invalid)."""
    return TTC_CAP if objective == "ttc" else ROBUSTNESS_CAP


def objective_values(objective: str, variations: np.ndarray, verdicts: pa.Table, rule_results: pa.Table,
                     collisions: pa.Table, criticality: pa.Table) -> np.ndarray:
    """(N,) objective per variation of `variations` (NaN for invalid ones)."""
    verdict = dict(zip(verdicts["variation"].to_pylist(), verdicts["verdict"].to_pylist()))
    invalid = np.array([verdict.get(int(v), "invalid") == "invalid" for v in variations])
    if objective == "ttc":
        per_var = ads_objectives(criticality)
        ttc = np.array([per_var.get(int(v), {}).get("min_ttc", np.nan) for v in variations], dtype=float)
        out = np.where(np.isfinite(ttc), np.minimum(ttc, TTC_CAP), TTC_CAP)
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
