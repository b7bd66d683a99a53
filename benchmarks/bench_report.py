"""`crashscene report DIR` wall and CPU time on a finished campaign, and whether it re-simulated anything.

Run by hand (not a test):
  .venv/bin/python benchmarks/bench_report.py OUT_DIR [--repeat 2] [--no-gifs]
where OUT_DIR is the --out of a finished `crashscene campaign` (e.g. all of examples/ciren,
`-n 50 --dsl golden.yaml`: 37 cases x 2 modes x 50 variations). Prints the seconds per run, the
machine's load average (the figure is only as quiet as the machine), the report's size, and the
variations re-simulated (folders under OUT/cases/*/report/, which a campaign that keeps its
report traces never needs).
"""
from __future__ import annotations

import argparse
import os
import resource
import time
from pathlib import Path

from crashscene.report import write_report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--no-gifs", action="store_true")
    args = parser.parse_args()
    for k in range(args.repeat):
        before = os.getloadavg()[0]
        start, cpu = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
        written = write_report(args.out_dir, gifs=not args.no_gifs)
        wall = time.perf_counter() - start
        own = resource.getrusage(resource.RUSAGE_SELF)
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)
        resim = len(list(args.out_dir.glob("cases/*/report/*")))
        print(f"run {k + 1}: {wall:6.1f} s wall, driver CPU {own.ru_utime - cpu.ru_utime + own.ru_stime - cpu.ru_stime:5.1f} s, "
              f"drawing processes CPU (cumulative) {kids.ru_utime + kids.ru_stime:5.1f} s; load average "
              f"{before:.1f} -> {os.getloadavg()[0]:.1f}; report.html {written.html.stat().st_size / 1e6:.1f} MB; "
              f"variations re-simulated: {resim}", flush=True)


if __name__ == "__main__":
    main()
