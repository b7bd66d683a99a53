"""Benchmark: 2,000 variations of a two-vehicle intersection scenario, embedded vs Newtonian.

Run by hand: `.venv/bin/python benchmarks/bench_simulate.py [--variations 2000] [--newtonian 50]
[--mode test|reproduce] [--case examples/ciren/100237/golden.yaml]`.

Prints the time to sample the scenes (Scenic), to simulate them on the embedded
backend (20 s horizon, 10 Hz), their sum (target: under 20 s), the Newtonian
backend's time for the first `--newtonian` scenes extrapolated to all of them,
the ratio (target: 50x or more), and the peak resident memory (target: under 2 GB).
"""
from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT_CASE = REPO / "examples" / "ciren" / "100237" / "golden.yaml"  # V2 fails to yield at a 4-leg junction


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variations", type=int, default=2000)
    parser.add_argument("--newtonian", type=int, default=50, help="Newtonian runs to time (0: skip)")
    parser.add_argument("--mode", choices=("test", "reproduce"), default="test")
    parser.add_argument("--case", type=Path, default=DEFAULT_CASE)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    warnings.filterwarnings("ignore")

    from crashscene.dsl import load_file
    from crashscene.render import render
    from crashscene.sample import sample_scenes
    from crashscene.simulate.backend import (
        SimulationRequest,
        SimulationSettings,
        create_simulator,
    )

    scenario = load_file(args.case)
    settings = SimulationSettings(mode=args.mode)
    with tempfile.TemporaryDirectory(prefix="bench-simulate-") as tmp:
        t0 = time.perf_counter()
        rendered = render(scenario, Path(tmp))
        t_render = time.perf_counter() - t0

        t0 = time.perf_counter()
        scenes = sample_scenes(rendered.program, args.variations, args.seed)
        t_sample_one = time.perf_counter() - t0
        t0 = time.perf_counter()
        scenes_two = sample_scenes(rendered.program, args.variations, args.seed, workers=2)
        t_sample = time.perf_counter() - t0
        assert [s.model_dump_json() for s in scenes_two] == [s.model_dump_json() for s in scenes]

        request = SimulationRequest(scenario, scenes, Path(rendered.map), settings,
                                    program=Path(rendered.program).read_text(encoding="utf-8"))
        t0 = time.perf_counter()
        with create_simulator("embedded", settings) as sim:
            result = sim.simulate(request)
        t_embedded = time.perf_counter() - t0
        rows = result.tables["traces"].num_rows
        collided = len(set(result.tables["collisions"]["variation"].to_pylist()))
        valid = sum(result.tables["variations"]["valid"].to_pylist())

        t_newton = None
        if args.newtonian > 0:
            try:
                from crashscene.simulate.newtonian import time_newtonian_runs
            except ImportError as exc:
                print(f"newtonian backend unavailable ({exc}); skipping", file=sys.stderr)
            else:
                k = min(args.newtonian, len(scenes))
                t_newton = time_newtonian_runs(request, k) / k * len(scenes)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # Linux: kB

    n = args.variations
    print(f"case: {args.case.relative_to(REPO) if args.case.is_relative_to(REPO) else args.case}  "
          f"mode: {args.mode}  variations: {n}  horizon: {settings.horizon:g} s at {1 / settings.dt:g} Hz")
    print(f"render (map + program, once)       {t_render:8.2f} s")
    print(f"sample {n} scenes (Scenic), 1 proc {t_sample_one:8.2f} s")
    print(f"sample {n} scenes (Scenic), 2 proc {t_sample:8.2f} s   (identical scenes; used below)")
    print(f"simulate {n} (embedded)          {t_embedded:8.2f} s   ({rows:,} trace rows, {valid} valid, "
          f"{collided} with a collision)")
    print(f"sample + simulate                  {t_sample + t_embedded:8.2f} s   (target < 20 s)")
    if t_newton is not None:
        print(f"newtonian, {args.newtonian} runs -> {n} (extrap.) {t_newton:8.2f} s")
        print(f"ratio newtonian / embedded simulate  {t_newton / t_embedded:8.1f} x  (target >= 50 x)")
        print(f"ratio newtonian / (sample + simulate) {t_newton / (t_sample + t_embedded):7.1f} x")
    print(f"peak memory (process)              {peak_mb:8.0f} MB  (target < 2048 MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
