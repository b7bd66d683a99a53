"""Benchmark: monitor 2,000 variations x 200 steps x 3 actors (synthetic 4-leg junction traces).

Run by hand: `.venv/bin/python benchmarks/bench_monitor.py [--variations N]`. Prints
the time to build the arrays, evaluate every rule, detect and classify
collisions, and the whole `evaluate`, plus the peak memory.
"""
from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np
import pyarrow as pa

from crashscene.monitor import evaluate
from crashscene.monitor.arrays import build_arrays
from crashscene.monitor.collisions import classify_collisions
from crashscene.monitor.context import EvalContext
from crashscene.monitor.rulebook import Rulebook
from crashscene.traces import (
    ACTOR_SCHEMA,
    COLLISION_SCHEMA,
    TRACE_SCHEMA,
    VARIATION_SCHEMA,
)

DT = 0.1  # [s]
BOX = 7.0  # [m] junction half size


def synthetic(n_var: int, steps: int, seed: int = 0) -> dict[str, pa.Table]:
    """A signalised 4-leg junction: ego eastbound, npc1 northbound (its signal turns red at a random
    time), npc2 westbound; random speeds [m/s] and start distances [m], so some variations collide."""
    rng = np.random.default_rng(seed)
    t = np.arange(steps) * DT
    roles = ["ego", "npc1", "npc2"]
    cols: dict[str, list] = {name: [] for name in TRACE_SCHEMA.names}
    for a, role in enumerate(roles):
        speed = rng.uniform(8, 14, n_var)[:, None] * np.ones(steps)
        s = speed * t - rng.uniform(20, 60, n_var)[:, None]      # station, 0 at the junction centre
        if role == "ego":
            x, y, yaw = s, np.full_like(s, -1.75), 0.0
        elif role == "npc1":
            x, y, yaw = np.full_like(s, 1.75), s, np.pi / 2
        else:
            x, y, yaw = -s, np.full_like(s, 1.75), np.pi
        in_j = (np.abs(x) < BOX) & (np.abs(y) < BOX)
        red = (t[None, :] > rng.uniform(0, 6, n_var)[:, None]) if role == "npc1" else np.zeros((n_var, steps), bool)
        n = n_var * steps
        cols["variation"].append(np.repeat(np.arange(n_var), steps))
        cols["actor"].append(np.full(n, role, dtype=object))
        cols["step"].append(np.tile(np.arange(steps), n_var))
        cols["t"].append(np.tile(t, n_var))
        for name, value in (("x", x), ("y", y), ("yaw", np.full_like(x, yaw)), ("speed", speed),
                            ("accel", np.zeros_like(x)), ("lat_accel", np.zeros_like(x)), ("route_s", s - s[:, :1]),
                            ("centerline_intrusion", np.full_like(x, -1.0)), ("stop_line_dist", -BOX - 2.25 - s),
                            ("speed_limit", np.full_like(x, 13.4))):
            cols[name].append(value.ravel())
        for name, value in (("opposing_lane", np.zeros(n, bool)), ("off_road", np.zeros(n, bool)),
                            ("in_junction", in_j.ravel()), ("lane_change", np.zeros(n, bool)),
                            ("lost_control", np.zeros(n, bool))):
            cols[name].append(value)
        for name, value in (("lane_id", f"road{a}_lane-1"), ("centerline_marker", "double_solid_line"),
                            ("junction_id", "j1"), ("maneuver", "straight"),
                            ("control", "signal"), ("target_lane_id", None)):
            cols[name].append(np.full(n, value, dtype=object))
        cols["signal"].append(np.where(red.ravel(), "red", "green").astype(object))
    traces = pa.table({name: pa.array(np.concatenate(cols[name]).tolist() if cols[name][0].dtype == object
                                      else np.concatenate(cols[name]), type=TRACE_SCHEMA.field(name).type)
                       for name in TRACE_SCHEMA.names}, schema=TRACE_SCHEMA)
    actors = pa.Table.from_pylist([{"variation": v, "actor": r, "label": None, "type": "car", "behavior": "go_forward",
                                    "is_ads": r == "ego", "length": 4.5, "width": 1.9, "dispositions": []}
                                   for v in range(n_var) for r in roles], schema=ACTOR_SCHEMA)
    variations = pa.table({"variation": np.arange(n_var, dtype=np.int32), "seed": np.zeros(n_var, np.int64),
                           "scenario_hash": ["bench"] * n_var, "valid": np.ones(n_var, bool),
                           "invalid_reason": pa.nulls(n_var, pa.string()), "dt": np.full(n_var, DT),
                           "steps": np.full(n_var, steps, np.int32), "params": ["{}"] * n_var},
                          schema=VARIATION_SCHEMA)
    return {"traces": traces, "actors": actors, "collisions": COLLISION_SCHEMA.empty_table(),
            "variations": variations}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--variations", type=int, default=2000)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    tables = synthetic(args.variations, args.steps)
    print(f"{args.variations} variations x {args.steps} steps x 3 actors = {tables['traces'].num_rows:,} trace rows")

    t0 = time.perf_counter()
    arrays = build_arrays(tables)
    t1 = time.perf_counter()
    print(f"build arrays           {t1 - t0:7.3f} s")
    ctx = EvalContext(arrays=arrays, scenario=None)
    for rule in Rulebook().rules():
        t = time.perf_counter()
        rule.evaluate(ctx)
        print(f"  {rule.code:<20} {time.perf_counter() - t:7.3f} s")
    t2 = time.perf_counter()
    print(f"all rules              {t2 - t1:7.3f} s (path conflicts and leaders computed once, inside)")
    classify_collisions(arrays, tables["collisions"], arrays.is_ads)
    t3 = time.perf_counter()
    print(f"collisions             {t3 - t2:7.3f} s")
    t, cpu = time.perf_counter(), time.process_time()
    result = evaluate(tables, None)
    total, cpu = time.perf_counter() - t, time.process_time() - cpu
    print(f"evaluate (end to end)  {total:7.3f} s wall, {cpu:.3f} s CPU  -> {args.variations / total:,.0f} variations/s"
          f" (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores: other work inflates wall time)")
    print(f"summary verdicts: {result.summary()['verdicts']}, collisions: {result.summary()['collisions']}")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:,.0f} MB")


if __name__ == "__main__":
    main()
