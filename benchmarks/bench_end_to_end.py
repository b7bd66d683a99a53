"""End to end on the bundled cases: report -> rules extraction -> reproduce mode, judged against the golden file.

Run by hand: `.venv/bin/python benchmarks/bench_end_to_end.py [-n 20] [--seed 7] [--cases ID,ID] [--golden-too]
[--json FILE]`. For every bundled case whose golden file has a contact between actors, the case's report
(narrative and sketch, never the golden file) is extracted with the rules backend, as `crashscene run CASE_DIR
--mode reproduce` does, and simulated in reproduce mode on the embedded backend. The traces are then judged
against the GOLDEN oracle and crash sequence (the extracted road, map and actors are kept, since those are
what was simulated): a variation re-enacts the real crash when every monitored golden oracle entry is observed
for its actor and the golden `collisions` happen, first contact first (rules.md).

Columns: `e2e` (that rate), `self` (the same traces judged against the extracted oracle and collisions:
what `crashscene run` reports), `golden` (with `--golden-too`: the golden file itself simulated, the planner's
own rate; a case where `golden` is high and `e2e` low points at extraction, both low at planning), and `diff`,
the fields where the extracted scenario differs from the golden one in a way the simulation sees (behaviours,
positions, road type, devices, oracle, collisions).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from crashscene.dsl import Scenario, load_file
from crashscene.extract.pipeline import extract_case
from crashscene.monitor.check_traces import evaluate as monitor
from crashscene.monitor.run_folder import read_run
from crashscene.pipeline.simulate import simulate_scenario

REPO = Path(__file__).resolve().parents[1]


def judged_against(extracted: Scenario, golden: Scenario) -> Scenario:
    """The extracted scenario (what was simulated) carrying the golden oracle and crash sequence (what happened)."""
    return extracted.model_copy(update={"oracle": golden.oracle, "collisions": golden.collisions})


def simulation_diff(extracted: Scenario, golden: Scenario) -> list[str]:
    """The fields the simulation sees where the extraction differs from the golden file."""
    out = []
    er, gr = extracted.road_network, golden.road_network
    for name in ("road_type", "number_of_ways", "number_of_lanes", "road_marker"):
        if getattr(er, name) != getattr(gr, name):
            out.append(f"{name} {_tok(getattr(er, name))}!={_tok(getattr(gr, name))}")
    if set(er.traffic_signs) != set(gr.traffic_signs):
        out.append("signs " + "/".join(sorted(_tok(s) for s in er.traffic_signs)) + "!="
                   + "/".join(sorted(_tok(s) for s in gr.traffic_signs)))
    for role, actor in golden.actors.items():
        mine = extracted.actors.get(role)
        if mine is None:
            out.append(f"{role} missing")
            continue
        if mine.behavior != actor.behavior:
            out.append(f"{role}.behavior {_tok(mine.behavior)}!={_tok(actor.behavior)}")
        for name in ("reference", "relation", "heading"):
            a, b = getattr(mine.position, name), getattr(actor.position, name)
            if a != b:
                out.append(f"{role}.{name} {_tok(a)}!={_tok(b)}")
    gold_oracle = {(e.code, e.actor) for e in golden.oracle}
    mine_oracle = {(e.code, e.actor) for e in extracted.oracle}
    out += [f"oracle -{c}@{a}" for c, a in sorted(gold_oracle - mine_oracle)]
    out += [f"oracle +{c}@{a}" for c, a in sorted(mine_oracle - gold_oracle)]
    seq = [(c.striking, c.struck, _tok(c.class_)) for c in extracted.collisions or []]
    gold_seq = [(c.striking, c.struck, _tok(c.class_)) for c in golden.collisions or []]
    if seq != gold_seq:
        out.append(f"collisions {seq}!={gold_seq}")
    return out


def _tok(value: object) -> str:
    return str(getattr(value, "value", value))


def _rate(tables: dict, scenario: Scenario) -> float | None:
    return monitor(tables, scenario).summary()["reproduction_rate"]


def run_case(case: Path, n: int, seed: int, tmp: Path, golden_too: bool) -> dict:
    golden = load_file(case / "golden.yaml")
    extracted = extract_case(case, backend="rules").scenario
    start = time.perf_counter()
    simulate_scenario(extracted, tmp / case.name, n=n, seed=seed, mode="reproduce")
    tables, _ = read_run(tmp / case.name)
    row = {"case": case.name, "e2e": _rate(tables, judged_against(extracted, golden)),
           "self": _rate(tables, extracted), "diff": simulation_diff(extracted, golden)}
    if golden_too:
        summary = simulate_scenario(golden, tmp / f"{case.name}-golden", n=n, seed=seed, mode="reproduce")
        row["golden"] = summary["reproduction_rate"]
    row["seconds"] = round(time.perf_counter() - start, 1)
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=20, help="variations per case")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--cases", help="comma-separated case ids (default: every bundled case with a contact)")
    parser.add_argument("--golden-too", action="store_true", help="also simulate the golden file (planner's rate)")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    args = parser.parse_args()
    root = REPO / "examples" / "ciren"
    cases = [p for p in sorted(root.iterdir())
             if (p / "golden.yaml").is_file() and load_file(p / "golden.yaml").collisions]
    if args.cases:
        wanted = set(args.cases.split(","))
        cases = [p for p in cases if p.name in wanted]
    rows = []
    print(f"{'case':<16} {'e2e':>5} {'self':>5} {'golden':>6} {'s':>5}  "
          "extracted != golden (fields the simulation sees)")
    with tempfile.TemporaryDirectory(prefix="bench-e2e-") as tmp:
        for case in cases:
            try:
                row = run_case(case, args.n, args.seed, Path(tmp), args.golden_too)
            except Exception as exc:  # a benchmark reports every case, failures included
                row = {"case": case.name, "error": f"{type(exc).__name__}: {exc}"[:300]}
                print(f"{case.name:<16} FAILED {row['error']}", flush=True)
                rows.append(row)
                continue
            rows.append(row)
            print(f"{case.name:<16} {_fmt(row['e2e'])} {_fmt(row['self'])} {_fmt(row.get('golden')):>6} "
                  f"{row['seconds']:>5}  {'; '.join(row['diff']) or '-'}", flush=True)
    for key in ("e2e", "self", "golden"):
        values = [r.get(key) or 0.0 for r in rows if key in r or "error" in r]
        if values:
            print(f"mean {key} over {len(values)} cases with a contact: {statistics.fmean(values):.3f}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    return 0


def _fmt(value: float | None) -> str:
    return f"{value:>5.2f}" if value is not None else f"{'-':>5}"


if __name__ == "__main__":
    sys.exit(main())
