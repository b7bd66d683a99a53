"""Reproduce mode over the bundled cases: reproduction, first-contact, sequence and area-match rate per case.

Run by hand: `.venv/bin/python benchmarks/bench_reproduce.py [-n 100] [--seed 7] [--cases DIR] [--dsl golden.yaml]
[--json FILE] [--no-refine]`. Each case's DSL file (the golden file by default; `--dsl scenario.yaml` for extracted ones)
is simulated in reproduce mode on the embedded backend and judged by the monitor against its oracle and its
crash sequence (rules.md). Prints one row per case, then the means over the cases and over those with a
contact between actors (issue 10's figures: mean >= 0.95, none below 0.8).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from crashscene.dsl import load_file
from crashscene.pipeline.simulate import simulate_scenario

REPO = Path(__file__).resolve().parents[1]
RATES = ("reproduction_rate", "first_contact_rate", "sequence_rate", "area_match_rate")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=100, help="variations per case")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--cases", type=Path, default=REPO / "examples" / "ciren")
    parser.add_argument("--dsl", default="golden.yaml", help="DSL file name inside each case folder")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    parser.add_argument("--no-refine", action="store_true",
                        help="the analytic plans alone (simulate --no-refine): no check against the simulator")
    args = parser.parse_args()
    rows = []
    print(f"{'case':<16} {'valid':>5} {'reprod':>7} {'first':>7} {'seq':>7} {'areas':>7} {'s':>6}  expected")
    with tempfile.TemporaryDirectory(prefix="bench-reproduce-") as tmp:
        for case in sorted(p for p in args.cases.iterdir() if (p / args.dsl).is_file()):
            scenario = load_file(case / args.dsl)
            start = time.perf_counter()
            try:
                summary = simulate_scenario(scenario, Path(tmp) / case.name, n=args.n, seed=args.seed,
                                            mode="reproduce", refine=not args.no_refine)
            except Exception as exc:  # a benchmark reports every case, failures included
                print(f"{case.name:<16} FAILED {type(exc).__name__}: {exc}")
                rows.append({"case": case.name, "error": f"{type(exc).__name__}: {exc}"})
                continue
            row = {"case": case.name, "valid": summary["valid"], "seconds": round(time.perf_counter() - start, 1),
                   "contact": bool(scenario.collisions), **{k: summary.get(k) for k in RATES}}
            rows.append(row)
            expected = ", ".join(f"{c.striking}-{c.struck} {c.class_.value}" for c in scenario.collisions or [])
            print(f"{case.name:<16} {row['valid']:>5} " + " ".join(_fmt(row[k]) for k in RATES)
                  + f" {row['seconds']:>6}  {expected or '(no contact)'}", flush=True)
    for label, subset in (("all cases", rows), ("with a contact", [r for r in rows if r.get("contact")])):
        means = [_mean(subset, k) for k in RATES]
        lows = sum(1 for r in subset if (r.get("reproduction_rate") or 0) < 0.8)
        print(f"mean, {label} ({len(subset)}): " + " ".join(_fmt(m) for m in means) + f"; below 0.8: {lows}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    return 0


def _mean(rows: list[dict], key: str) -> float | None:
    if key == "area_match_rate":  # cases without a written contact have no areas to match
        values = [r[key] for r in rows if r.get(key) is not None]
    else:
        values = [r.get(key) or 0.0 for r in rows]  # a failed case or a missing figure counts as 0
    return statistics.fmean(values) if values else None


def _fmt(value: float | None) -> str:
    return f"{value:>7.2f}" if value is not None else f"{'-':>7}"


if __name__ == "__main__":
    sys.exit(main())
