"""Benchmark the render stage: render time per scenario (target < 0.1 s, Scenic compile excluded), map build
time, Scenic compile time, and sampling throughput (target 100+ scenes/s per core).

Run by hand:  .venv/bin/python benchmarks/bench_render.py [--n 200] [--mode generated|carla] [CASE ...]
Render time is measured with a warm map cache (the map is built and parsed once per distinct input); the cold
map build (scenariogeneration, no Scenic parse) is reported separately.
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import warnings
from pathlib import Path

from crashscene.dsl import load_file
from crashscene.render import render
from crashscene.render.opendrive import build_map
from crashscene.render.plan import convert
from crashscene.render.sample import compile_program, sample_scenes

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples" / "ciren"
CARLA_MAPS = REPO / "tests" / "data" / "maps" / "carla"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", help="case folders under examples/ciren (default: all)")
    parser.add_argument("--n", type=int, default=200, help="scenes sampled per case")
    parser.add_argument("--mode", default="generated", choices=["generated", "carla"])
    parser.add_argument("--no-sample", action="store_true", help="render timings only (no Scenic compile)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    cases = args.cases or sorted(p.name for p in EXAMPLES.iterdir() if (p / "golden.yaml").exists())
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cache = tmp / "cache"
        print(f"{'case':16s} {'topology':15s} {'actors':>6s} {'map[s]':>7s} {'render[s]':>9s} "
              f"{'compile[s]':>10s} {'scenes/s':>9s} {'/cpu-s':>9s}")
        for case in cases:
            scenario = load_file(EXAMPLES / case / "golden.yaml")
            plan = convert(scenario)
            t0 = time.perf_counter()
            if args.mode == "generated":
                build_map(plan.map, tmp / f"{case}_cold.xodr")
            map_time = time.perf_counter() - t0
            kwargs = {"map_mode": args.mode, "carla_maps": CARLA_MAPS, "cache_dir": cache,
                          "town_override": {"Town05": "Town10HD"}}
            render(scenario, tmp / case / "warmup", **kwargs)  # builds, caches and parses the map once
            t0 = time.perf_counter()
            rendered = render(scenario, tmp / case / "out", **kwargs)
            render_time = time.perf_counter() - t0
            compile_time = rate = cpu_rate = float("nan")
            if not args.no_sample:
                t0 = time.perf_counter()
                compiled = compile_program(rendered.program)
                compile_time = time.perf_counter() - t0
                t0, c0 = time.perf_counter(), time.process_time()
                sample_scenes(rendered.program, args.n, seed=0, scenario=compiled)
                rate = args.n / (time.perf_counter() - t0)
                cpu_rate = args.n / (time.process_time() - c0)
            rows.append((render_time, compile_time, rate, cpu_rate))
            print(f"{case:16s} {plan.topology:15s} {len(plan.actors):6d} {map_time:7.3f} {render_time:9.3f} "
                  f"{compile_time:10.2f} {rate:9.0f} {cpu_rate:9.0f}", flush=True)
    renders = [r[0] for r in rows]
    print(f"\nrender (warm map cache, no compile): median {statistics.median(renders):.3f} s, "
          f"max {max(renders):.3f} s over {len(rows)} scenarios (target < 0.1 s)")
    if not args.no_sample:
        rates = [r[2] for r in rows]
        cpu_rates = [r[3] for r in rows]
        compiles = [r[1] for r in rows]
        print(f"Scenic compile: median {statistics.median(compiles):.2f} s; sampling (wall): median "
              f"{statistics.median(rates):.0f} scenes/s, min {min(rates):.0f}; per CPU-second (one core): median "
              f"{statistics.median(cpu_rates):.0f}, min {min(cpu_rates):.0f} scenes/s (target 100+ per core)")


if __name__ == "__main__":
    main()
