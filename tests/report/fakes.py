"""A stand-in worker that keeps traces for the report too (`campaign.keep`): two cars meeting at the fake contact.

Rows come from `tests.campaign.fakes.fake_chunk`; traces are synthetic (V1 eastbound, V2 northbound, meeting
at the fake contact point x = 1, y = 2 [m] at t = 5 s), so the report draws without simulating.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from crashscene.campaign import keep
from crashscene.campaign.model import ChunkResult, ChunkTask
from crashscene.monitor.result import RULE_RESULT_SCHEMA
from tests.campaign.fakes import fake_chunk

DT = 0.1  # [s]


def _traces(variations: list[int]) -> tuple[pa.Table, pa.Table]:
    t = np.arange(0.0, 7.0, DT)
    rows, actors = [], []
    for v in variations:
        for role, label, x, y, yaw in (("ego", "V1", 1.0 + 8.0 * (t - 5.0), np.full_like(t, 2.0), 0.0),
                                       ("npc1", "V2", np.full_like(t, 1.0), 2.0 + 6.0 * (t - 5.0), np.pi / 2)):
            rows += [{"variation": v, "actor": role, "t": float(ti), "x": float(xi), "y": float(yi), "yaw": yaw,
                      "speed": 7.0} for ti, xi, yi in zip(t, x, y)]
            actors.append({"variation": v, "actor": role, "label": label, "type": "car", "is_ads": role == "ego",
                           "length": 4.5, "width": 1.8})
    return pa.Table.from_pylist(rows, keep.SHOWN_TRACE_ROWS), pa.Table.from_pylist(actors, keep.SHOWN_ACTOR_ROWS)


def fake_chunk_with_traces(task: ChunkTask) -> ChunkResult:
    result = fake_chunk(task)
    viol = result.violations.to_pylist()
    rules = pa.Table.from_pylist([{"variation": r["variation"], "actor": r["actor"], "code": r["code"],
                                   "violation": r["violation"], "verdict": "violated", "robustness": r["robustness"],
                                   "is_ads": r["is_ads"]} for r in viol], RULE_RESULT_SCHEMA)
    collisions = result.collisions.append_column("involves_ads", pc.equal(result.collisions.column("actor_a"), "ego"))
    result.shown = keep.pick(result.variations.to_pylist(), rules, collisions)
    result.shown_traces, result.shown_actors = keep.traces_of(result.shown, *_traces(
        sorted(set(result.shown.column("variation").to_pylist()))))
    return result
