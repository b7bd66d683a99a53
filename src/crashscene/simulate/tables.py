"""Building the tables of `crashscene.traces` from what a backend simulated.

Shared by every backend, so that who is the ADS, which dispositions an actor
carries and how the rows are laid out never depend on the engine.
"""
from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np
import pyarrow as pa

from crashscene.scene import SampledActor, SampledScene
from crashscene.simulate.backend import SceneResult, SimulationSettings
from crashscene.traces import (
    ACTOR_SCHEMA,
    COLLISION_SCHEMA,
    TRACE_SCHEMA,
    VARIATION_SCHEMA,
)


def is_ads(role: str, settings: SimulationSettings) -> bool:
    """True when the actor `role` is driven by the ADS under test (test mode, the chosen ego role)."""
    return settings.mode == "test" and role == settings.ego_role


def driver_dispositions(actor: SampledActor, settings: SimulationSettings) -> list[str]:
    """Oracle codes injected into the actor's driver: none for the ADS under test, else the actor's own."""
    return [] if is_ads(actor.role, settings) else list(actor.dispositions)


def actors_table(scenes: Sequence[SampledScene], settings: SimulationSettings) -> pa.Table:
    """ACTOR_SCHEMA rows, one per (variation, actor)."""
    rows: dict[str, list] = {name: [] for name in ACTOR_SCHEMA.names}
    for scene in scenes:
        for actor in scene.actors:
            rows["variation"].append(scene.index)
            rows["actor"].append(actor.role)
            rows["label"].append(actor.label)
            rows["type"].append(actor.type)
            rows["behavior"].append(actor.behavior)
            rows["is_ads"].append(is_ads(actor.role, settings))
            rows["length"].append(actor.length)
            rows["width"].append(actor.width)
            rows["dispositions"].append(driver_dispositions(actor, settings))
    return pa.table(rows, schema=ACTOR_SCHEMA)


def variations_table(scenes: Sequence[SampledScene], valid: Sequence[bool], reasons: Sequence[str | None],
                     settings: SimulationSettings) -> pa.Table:
    """VARIATION_SCHEMA rows, one per scene; `reasons[i]` is None for a valid variation."""
    return pa.table({
        "variation": [scene.index for scene in scenes],
        "seed": [scene.seed for scene in scenes],
        "scenario_hash": [scene.scenario_hash for scene in scenes],
        "valid": [bool(v) for v in valid],
        "invalid_reason": [None if v else r for v, r in zip(valid, reasons)],
        "dt": [settings.dt] * len(scenes),
        "steps": [settings.steps] * len(scenes),
        "params": [json.dumps(scene.params, sort_keys=True) for scene in scenes],
    }, schema=VARIATION_SCHEMA)


def empty_table(schema: pa.Schema) -> pa.Table:
    return schema.empty_table()


def _column(values: Sequence | None, n: int, dtype: pa.DataType) -> pa.Array:
    if values is None:
        if pa.types.is_floating(dtype):
            return pa.array(np.full(n, np.nan), type=dtype)
        return pa.nulls(n, type=dtype)
    if isinstance(values, np.ndarray):
        return pa.array(values, type=dtype)
    return pa.array(list(values), type=dtype)


def traces_table(columns: dict[str, Sequence | None]) -> pa.Table:
    """TRACE_SCHEMA table from column -> values; absent columns become NaN (floats) or null."""
    lengths = {len(v) for v in columns.values() if v is not None}
    if len(lengths) != 1:
        raise ValueError(f"trace columns have different lengths: {sorted(lengths)}")
    n = lengths.pop()
    unknown = set(columns) - set(TRACE_SCHEMA.names)
    if unknown:
        raise ValueError(f"unknown trace columns {sorted(unknown)}; allowed: {TRACE_SCHEMA.names}")
    arrays = [_column(columns.get(f.name), n, f.type) for f in TRACE_SCHEMA]
    return pa.Table.from_arrays(arrays, schema=TRACE_SCHEMA)


def collisions_table(rows: Sequence[dict]) -> pa.Table:
    """COLLISION_SCHEMA table from row dicts."""
    return pa.Table.from_pylist(list(rows), schema=COLLISION_SCHEMA)


def assemble_scene_results(scenes: Sequence[SampledScene], results: Sequence[SceneResult],
                           settings: SimulationSettings) -> dict[str, pa.Table]:
    """The four tables from per-scene results of a one-scene-at-a-time backend."""
    trace_parts = []
    collision_rows: list[dict] = []
    for scene, result in zip(scenes, results):
        columns = dict(result.traces)
        n = len(next(v for v in columns.values() if v is not None))
        columns["variation"] = [scene.index] * n
        trace_parts.append(traces_table(columns))
        for row in result.collisions:
            collision_rows.append({**row, "variation": scene.index})
    traces = pa.concat_tables(trace_parts) if trace_parts else empty_table(TRACE_SCHEMA)
    return {
        "traces": traces,
        "actors": actors_table(scenes, settings),
        "collisions": collisions_table(collision_rows),
        "variations": variations_table(scenes, [r.valid for r in results],
                                       [r.invalid_reason for r in results], settings),
    }
