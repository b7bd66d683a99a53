"""Campaign time: every bundled case x 2 modes x N variations (default: all 37 x 2 x 2,000; target <= 15 min).

Run by hand (not a test):  .venv/bin/python benchmarks/bench_campaign.py [-n 2000] [--cases all|ID...]
[--engines local:2 ray:2] [--chunk-size 250]
Each configuration runs the same cases, seed and chunking into a fresh folder
(both modes: reproduce and test), timed end to end: case preparation, engine
start-up, simulation, monitoring and DuckDB writes, with the machine's load
average before and after (the machine is shared) and the CPU time spent (driver
and local workers; on an idle machine the wall time's floor is about CPU / cores). `--worker fake` measures the
scheduler and store alone with a stand-in worker.
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))  # for --worker fake (tests.campaign.fakes)

from crashscene.campaign import CampaignConfig, Store, run_campaign  # noqa: E402


def _cpu() -> float:
    """[s] user + system CPU of this process and of the worker processes it has waited for (local engine)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=2000, help="variations per case and mode")
    parser.add_argument("--cases", nargs="+", default=["all"], help="CIREN case ids in examples/ciren, or all")
    parser.add_argument("--chunk-size", type=int, default=250, help="variations per chunk (the CLI default)")
    parser.add_argument("--worker", choices=("real", "fake"), default="real")
    parser.add_argument("--engines", nargs="+", default=[f"local:{os.cpu_count() or 1}"])
    args = parser.parse_args()

    worker = None
    if args.worker == "fake":
        from tests.campaign import fakes

        worker = fakes.fake_chunk
        try:
            import ray.cloudpickle

            ray.cloudpickle.register_pickle_by_value(fakes)
        except ImportError:
            pass
    examples = REPO / "examples" / "ciren"
    cases = sorted(p for p in examples.iterdir() if (p / "golden.yaml").is_file()) if args.cases == ["all"] \
        else [examples / c for c in args.cases]
    print(f"campaign throughput: {len(cases)} case(s) x 2 modes x {args.n} variations, chunk {args.chunk_size}, "
          f"worker {args.worker}, DSL golden.yaml")
    print(f"{'engine':<10} {'workers':>7} {'variations':>10} {'seconds':>8} {'minutes':>8} {'var/s':>8} {'CPU s':>8} {'CPU ms/var':>9}  load (1 min)")
    root = Path(tempfile.mkdtemp(prefix="bench-campaign-"))
    try:
        for spec in args.engines:
            engine, _, workers = spec.partition(":")
            out = root / spec.replace(":", "-")
            config = CampaignConfig(n=args.n, chunk_size=args.chunk_size, engine=engine, workers=int(workers or 1),
                                    dsl_name="golden.yaml")
            load = os.getloadavg()[0]
            start = time.perf_counter()
            cpu0 = _cpu()
            summary = run_campaign(cases, out, config, worker=worker, quiet=True)
            seconds = time.perf_counter() - start
            cpu = _cpu() - cpu0
            with Store(out, read_only=True) as store:
                rows = store.query("SELECT count(*) AS c FROM variations")[0]["c"]
            status = "" if summary.complete else f"  INCOMPLETE ({summary.chunks_failed} chunks failed)"
            print(f"{engine:<10} {summary.workers:>7} {rows:>10} {seconds:>8.1f} {seconds / 60:>8.1f} "
                  f"{rows / seconds:>8.1f} {cpu:>8.1f} {1e3 * cpu / max(rows, 1):>9.2f}  "
                  f"{load:.1f} -> {os.getloadavg()[0]:.1f}{status}", flush=True)
            for failure in summary.failures[:3]:
                print(f"    {failure['chunk']}: {failure['error'].splitlines()[0][:300]}", flush=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
