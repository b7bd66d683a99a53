"""Hand-built trace tables for monitor tests: a few lines of numpy per scenario.

`tables({"ego": track(...), "npc1": track(...)})` gives the four tables of
`crashscene.traces`. A track is a dict of trace columns (arrays over steps, or
scalars broadcast) plus actor fields (length, width, behavior, is_ads).
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

from crashscene.traces import (
    ACTOR_SCHEMA,
    COLLISION_SCHEMA,
    TRACE_SCHEMA,
    VARIATION_SCHEMA,
)

DT = 0.1  # [s]
ACTOR_FIELDS = ("length", "width", "behavior", "is_ads", "type", "dispositions", "label")


def track(steps: int = 100, x0: float = 0.0, y0: float = 0.0, yaw: float = 0.0, speed: float | np.ndarray = 10.0,
          dt: float = DT, **columns) -> dict:
    """A straight drive at `speed` [m/s] (scalar or per step) from (x0, y0) along `yaw` [rad]."""
    v = np.broadcast_to(np.asarray(speed, dtype=float), (steps,)).copy()
    s = np.concatenate([[0.0], np.cumsum(v[:-1] * dt)])
    out = {"x": x0 + s * np.cos(yaw), "y": y0 + s * np.sin(yaw), "yaw": np.full(steps, float(yaw)),
           "speed": v, "accel": np.gradient(v, dt) if steps > 1 else np.zeros(steps), "route_s": s}
    out.update(columns)
    return out


def turn(steps: int, x0: float, y0: float, yaw0: float, speed: float, radius: float, left: bool = True,
         start: int = 0, angle: float = np.pi / 2, dt: float = DT, **columns) -> dict:
    """Straight until step `start`, then an arc of `radius` [m] through `angle` [rad], then straight."""
    x, y, yaw = np.empty(steps), np.empty(steps), np.empty(steps)
    px, py, h, turned = x0, y0, yaw0, 0.0
    sign = 1.0 if left else -1.0
    for k in range(steps):
        x[k], y[k], yaw[k] = px, py, h
        if k >= start and turned < angle:
            dh = min(speed * dt / radius, angle - turned)
            turned += dh
            h += sign * dh
        px += speed * dt * np.cos(h)
        py += speed * dt * np.sin(h)
    out = {"x": x, "y": y, "yaw": yaw, "speed": np.full(steps, float(speed)), "accel": np.zeros(steps)}
    out.update(columns)
    return out


def tables(actors: dict[str, dict], variations: int = 1, dt: float = DT, valid=True, invalid_reason=None,
           collisions: list[dict] | None = None, ads: tuple[str, ...] = ("ego",)) -> dict[str, pa.Table]:
    """The four trace tables for `variations` identical copies of the given tracks."""
    steps = max(len(np.atleast_1d(v)) for spec in actors.values() for k, v in spec.items()
                if k not in ACTOR_FIELDS and np.ndim(v) > 0)
    trace_cols = {name: [] for name in TRACE_SCHEMA.names}
    actor_rows = []
    for var in range(variations):
        for role, spec in actors.items():
            trace_cols["variation"].append(np.full(steps, var))
            trace_cols["actor"].append(np.full(steps, role, dtype=object))
            trace_cols["step"].append(np.arange(steps))
            trace_cols["t"].append(np.arange(steps) * dt)
            for field in TRACE_SCHEMA:
                if field.name in ("variation", "actor", "step", "t"):
                    continue
                value = spec.get(field.name)
                if value is None:
                    fill = np.nan if pa.types.is_floating(field.type) else None
                    trace_cols[field.name].append(np.full(steps, fill, dtype=object if fill is None else float))
                else:
                    arr = np.asarray(value)
                    if arr.dtype.kind in "OU":
                        arr = arr.astype(object)
                    trace_cols[field.name].append(np.broadcast_to(arr, (steps,)).copy())
            actor_rows.append({"variation": var, "actor": role, "label": spec.get("label"), "type": spec.get("type", "car"),
                               "behavior": spec.get("behavior", "go_forward"),
                               "is_ads": bool(spec.get("is_ads", role in ads)),
                               "length": float(spec.get("length", 4.5)), "width": float(spec.get("width", 1.9)),
                               "dispositions": list(spec.get("dispositions", []))})
    arrays = []
    for field in TRACE_SCHEMA:
        values = np.concatenate(trace_cols[field.name])
        if values.dtype == object:
            values = [None if (v is None or (isinstance(v, float) and np.isnan(v))) else v for v in values]
        arrays.append(pa.array(values, type=field.type, from_pandas=True))
    traces = pa.Table.from_arrays(arrays, schema=TRACE_SCHEMA)
    valid_list = [valid] * variations if isinstance(valid, bool) else list(valid)
    reasons = [None if ok else (invalid_reason or "spawn failed") for ok in valid_list]
    variations_table = pa.table({"variation": list(range(variations)), "seed": [0] * variations,
                                 "scenario_hash": ["test"] * variations, "valid": valid_list,
                                 "invalid_reason": reasons, "dt": [dt] * variations, "steps": [steps] * variations,
                                 "params": ["{}"] * variations}, schema=VARIATION_SCHEMA)
    return {"traces": traces, "actors": pa.Table.from_pylist(actor_rows, schema=ACTOR_SCHEMA),
            "collisions": pa.Table.from_pylist(collisions or [], schema=COLLISION_SCHEMA),
            "variations": variations_table}
