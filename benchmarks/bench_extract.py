"""Benchmark of the rules extraction backend on the bundled CIREN cases: time per case and accuracy.

Run by hand: `.venv/bin/python benchmarks/bench_extract.py [--subset all|odd|even] [--out DIR] [--diffs]`.
Cases are indexed in sorted order from 0; `odd` (indices 1, 3, ...) is the development half and `even`
the held-out half. OCR runs once per sketch (cached by image hash), and its time is reported apart.
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from crashscene.dsl import dumps, load_file
from crashscene.evaluation.score import evaluate, format_result
from crashscene.extract.case_input import load_report
from crashscene.extract.rules import extract_rules
from crashscene.extract.sketch import sketch_facts

CIREN = Path(__file__).resolve().parent.parent / "examples" / "ciren"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--subset", choices=("all", "odd", "even"), default="all")
    parser.add_argument("--out", type=Path, help="write <case>.yaml predictions here")
    parser.add_argument("--diffs", action="store_true", help="print per-case diffs and the confusion table")
    parser.add_argument("--no-sketch", action="store_true",
                        help="no sketch facts (the narrative, and the case XML where there is one)")
    args = parser.parse_args()
    cases = sorted(p.name for p in CIREN.iterdir() if p.is_dir())
    if args.subset == "odd":
        cases = cases[1::2]
    elif args.subset == "even":
        cases = cases[0::2]
    ocr_times, rule_times, pairs = [], [], {}
    for case in cases:
        report = load_report(CIREN / case)
        start = time.perf_counter()
        facts = sketch_facts(report.sketch) if report.sketch and not args.no_sketch else []
        ocr_times.append(time.perf_counter() - start)
        start = time.perf_counter()
        scenario = extract_rules(report, facts)
        rule_times.append(time.perf_counter() - start)
        pairs[case] = (load_file(CIREN / case / "golden.yaml"), scenario)
        if args.out:
            args.out.mkdir(parents=True, exist_ok=True)
            (args.out / f"{case}.yaml").write_text(dumps(scenario), encoding="utf-8")
    result = evaluate(pairs)
    print(format_result(result, diffs=args.diffs, confusion=args.diffs))
    scope = f"{args.subset}, no sketch" if args.no_sketch else args.subset
    print(f"\n{len(cases)} cases ({scope}); rules: mean {1000 * statistics.mean(rule_times):.1f} ms, "
          f"max {1000 * max(rule_times):.1f} ms per case; sketch facts (OCR, cached after first run): "
          f"mean {statistics.mean(ocr_times):.2f} s, max {max(ocr_times):.2f} s")


if __name__ == "__main__":
    main()
