"""Benchmark: random sampling against the adaptive samplers, per bundled case with a contact.

Run by hand: `.venv/bin/python benchmarks/bench_search.py [--budget 400] [--samplers random,halton,ce,bo,cmaes]
[--cases 100237,120013] [--limit K] [--out out/bench_search] [--objective ttc] [--ego auto]`.

For every case of examples/ciren whose golden DSL has a contact between actors
(its `collisions` list, or, in a DSL without it, an actor the ego can collide
with), test mode with the reference ADS in the seat `--ego` names (default
`auto`: V1's, or the seat V1's own swerve came at, crashscene.search.seat),
the same budget and seed per sampler:
prints the minimum objective and the failures found by each sampler, then the
share of cases where an adaptive sampler found a lower minimum than random and
the failures summed per sampler. Results are also appended as JSON lines to
OUT/results.jsonl, so an interrupted run keeps what it measured (rerun skips done rows).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

CASES = Path(__file__).resolve().parents[1] / "examples" / "ciren"
TIE = 1e-3  # [objective units] minima this close are a plateau both samplers reached (e.g. the same capped impact)


def cases_with_contact() -> list[Path]:
    from crashscene.dsl import load_file
    from crashscene.monitor.verdicts import expected_collision

    out = []
    for folder in sorted(CASES.iterdir()):
        golden = folder / "golden.yaml"
        if not golden.is_file():
            continue
        scenario = load_file(golden)
        contacts = getattr(scenario, "collisions", None)
        if (contacts if contacts is not None else expected_collision(scenario)):
            out.append(golden)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=400)
    parser.add_argument("--samplers", default="random,halton,ce,bo,cmaes")
    parser.add_argument("--objective", default="ttc")
    parser.add_argument("--ego", default="auto", help="the ADS's role: auto (crashscene.search.seat) or a role")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cases", default="", help="comma-separated case ids (default: every case with a contact)")
    parser.add_argument("--limit", type=int, default=0, help="at most this many cases (0: all)")
    parser.add_argument("--out", type=Path, default=Path("out/bench_search"))
    args = parser.parse_args()

    from crashscene.campaign.engines import quiet_scenic_warnings
    from crashscene.dsl import load_file
    from crashscene.search import search_scenario

    quiet_scenic_warnings()
    samplers = args.samplers.split(",")
    goldens = cases_with_contact()
    if args.cases:
        wanted = args.cases.split(",")
        goldens = [g for g in goldens if g.parent.name in wanted]
    if args.limit:
        goldens = goldens[:args.limit]
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "results.jsonl"
    done = {}
    if log.exists():
        for line in log.read_text().splitlines():
            row = json.loads(line)
            row.setdefault("ego", "ego")  # rows written before --ego
            done[(row["case"], row["sampler"], row["budget"], row["objective"], row["seed"], row["ego"])] = row
    start = time.perf_counter()
    for golden in goldens:
        case = golden.parent.name
        scenario = load_file(golden)
        for sampler in samplers:
            key = (case, sampler, args.budget, args.objective, args.seed, args.ego)
            if key in done:
                continue
            try:
                s = search_scenario(scenario, args.out / case / f"{sampler}-{args.ego}", budget=args.budget,
                                    sampler=sampler, objective=args.objective, seed=args.seed, ego_role=args.ego)
                row = {"case": case, "sampler": sampler, "budget": args.budget, "objective": args.objective,
                       "seed": args.seed, "ego": args.ego, "seat": s["ego_role"], "min_objective": s["min_objective"],
                       "failures": s["failures"], "invalid": s["invalid"], "seconds": s["seconds"]}
            except Exception as exc:  # a case that cannot be searched is reported, not fatal
                row = {"case": case, "sampler": sampler, "budget": args.budget, "objective": args.objective,
                       "seed": args.seed, "ego": args.ego, "error": f"{type(exc).__name__}: {exc}"[:300]}
            done[key] = row
            with open(log, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(row) + "\n")
            print(json.dumps(row), flush=True)
    print_table([done[k] for k in done if k[2:] == (args.budget, args.objective, args.seed, args.ego)], samplers)
    print(f"wall time this invocation: {time.perf_counter() - start:.0f} s")


def print_table(rows: list[dict], samplers: list[str]) -> None:
    by_case: dict[str, dict[str, dict]] = {}
    for row in rows:
        by_case.setdefault(row["case"], {})[row["sampler"]] = row
    complete = {c: r for c, r in by_case.items() if all(s in r and "error" not in r[s] for s in samplers)}
    header = "| case | ADS | " + " | ".join(f"{s} min | {s} fail" for s in samplers) + " |"
    print(header)
    print("|" + "---|" * (2 + 2 * len(samplers)))
    fmt = lambda v: "-" if v is None else f"{v:.4f}"
    for case, r in sorted(complete.items()):
        seat = r[samplers[0]].get("seat", "ego")
        print(f"| {case} | {seat} | " + " | ".join(f"{fmt(r[s]['min_objective'])} | {r[s]['failures']}"
                                                  for s in samplers) + " |")
    for case, r in sorted(by_case.items()):
        for s in samplers:
            if s in r and "error" in r[s]:
                print(f"  {case} {s}: {r[s]['error']}")
    if "random" not in samplers or not complete:
        return
    inf = float("inf")
    value = lambda row: inf if row["min_objective"] is None else row["min_objective"]
    print(f"cases compared: {len(complete)}")
    for s in samplers:
        failures = sum(r[s]["failures"] for r in complete.values())
        if s == "random":
            print(f"  random: failures summed {failures}")
            continue
        lower = sum(value(r[s]) < value(r["random"]) for r in complete.values())
        ties = sum(value(r[s]) == value(r["random"]) for r in complete.values())
        near = sum(abs(value(r[s]) - value(r["random"])) <= TIE for r in complete.values())
        print(f"  {s}: lower minimum than random on {lower}/{len(complete)} cases "
              f"({100 * lower / len(complete):.0f}%, {ties} exact ties, {near} within {TIE:g}); "
              f"failures summed {failures}")
    adaptive = [s for s in samplers if s not in ("random", "halton")]
    if adaptive:
        best = sum(min(value(r[s]) for s in adaptive) < value(r["random"]) for r in complete.values())
        print(f"  best adaptive ({'/'.join(adaptive)}): lower than random on {best}/{len(complete)} cases")


if __name__ == "__main__":
    main()
