"""A deterministic stand-in worker: rows depend only on (scenario_hash, seed, mode, variation).

It lets the scheduler, store and resume logic be tested in seconds, independent
of the simulator. `CRASHSCENE_FAKE_SLEEP` [s] slows each chunk so a test can
kill a campaign mid-way; `CRASHSCENE_FAKE_FAIL` makes chunks starting at that
index raise.
"""
from __future__ import annotations

import hashlib
import json
import os
import time

import pyarrow as pa

from crashscene.campaign.model import COLLISION_ROWS, VARIATION_ROWS, VIOLATION_ROWS, ChunkResult, ChunkTask


def _unit(*parts: object) -> float:
    digest = hashlib.sha256("/".join(map(str, parts)).encode()).digest()
    return int.from_bytes(digest[:8], "little") / 2**64


def fake_chunk(task: ChunkTask) -> ChunkResult:
    start = time.perf_counter()
    time.sleep(float(os.environ.get("CRASHSCENE_FAKE_SLEEP", "0")))
    if os.environ.get("CRASHSCENE_FAKE_FAIL") == str(task.first):
        raise RuntimeError(f"injected failure at {task.first}")
    var, viol, coll = [], [], []
    for i in range(task.first, task.first + task.count):
        u = _unit(task.scenario_hash, task.seed, task.mode, i)
        verdict = "pass" if u < 0.5 else "collision" if u < 0.8 else "violation" if u < 0.95 else "invalid"
        var.append(dict(variation=i, valid=verdict != "invalid", invalid_reason="spawn" if verdict == "invalid" else None,
                        verdict=verdict, reproduced=verdict == "collision", collided=verdict == "collision",
                        params=json.dumps({"npc1_speed": round(8 + 4 * u, 3), "NPC_INIT_DIST": round(15 + 5 * u, 3)})))
        if verdict == "violation":
            viol.append(dict(variation=i, actor="ego", is_ads=True, code="CVC_21703", violation="following_too_closely",
                             t_first=3.0 + u, value=1.2, threshold=2.0, unit="s", robustness=-0.8))
        if verdict == "collision":
            coll.append(dict(variation=i, t=5.0 + u, actor_a="ego", actor_b="npc1", collision_class="rear_end",
                             speed_a=10.0, speed_b=2.0, x=1.0, y=2.0))
    return ChunkResult(variations=pa.Table.from_pylist(var, VARIATION_ROWS),
                       violations=pa.Table.from_pylist(viol, VIOLATION_ROWS),
                       collisions=pa.Table.from_pylist(coll, COLLISION_ROWS),
                       seconds=time.perf_counter() - start)
