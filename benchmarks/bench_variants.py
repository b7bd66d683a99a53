"""Reproduce mode on the bundled cases with one field changed that does not change the crash: a proxy for reports
nobody here has seen.

Run by hand: `.venv/bin/python benchmarks/bench_variants.py [-n 40] [--seed 7] [--cases DIR] [--only CASE ...]
[--kinds KIND ...] [--json FILE]`. Issue 10's figures are also measured on unseen CIREN reports, whose roads,
light, speeds and vehicles differ from the bundled ones. Each golden file is varied one field at a time, in ways a
report of the same crash could differ (`KINDS`): the road surface, the light, the speed limit by 10 mph or
unstated, one more through lane, a straight road bent either way (or a curve straightened), one actor a truck
instead of a car. Each variant is simulated in reproduce mode on the embedded backend and judged against its
(unchanged) crash sequence. Prints one row per case and variant, then per kind the mean reproduction and
first-contact rates and the variants below 0.8. A variant the DSL refuses is reported, not counted.
"""
from __future__ import annotations

import argparse
import copy
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import yaml

from crashscene.dsl import DslError, from_raw
from crashscene.pipeline.simulate import simulate_scenario

REPO = Path(__file__).resolve().parents[1]
RATES = ("reproduction_rate", "first_contact_rate")
LIMIT_STEP_MPH = 10  # [mph] one posted-limit step up or down (US limits are posted in 5 mph steps)
LIMIT_FLOOR_MPH = 25  # [mph] no variant below a residential limit
MAX_LANES = 4  # [-] one more lane only up to this many


def _surface(raw: dict) -> Iterator[tuple[str, dict]]:
    env = raw["environment"]
    yield "surface", {**env, "road_surface": "dry" if env.get("road_surface") == "wet" else "wet"}


def _light(raw: dict) -> Iterator[tuple[str, dict]]:
    env = raw["environment"]
    yield "light", {**env, "time_of_day": "nighttime" if env.get("time_of_day") == "daytime" else "daytime"}


def _limit(raw: dict) -> Iterator[tuple[str, dict]]:
    road = raw["road_network"]
    limit = road.get("speed_limit_mph")
    if limit is None:
        return
    # a report that does not state the limit (no sign either: validation pairs the two)
    yield "limit-unstated", {**{k: v for k, v in road.items() if k != "speed_limit_mph"},
                             "traffic_signs": [s for s in road["traffic_signs"] if s != "speed_limit_sign"]}
    yield f"limit+{LIMIT_STEP_MPH}", {**road, "speed_limit_mph": limit + LIMIT_STEP_MPH}
    if limit - LIMIT_STEP_MPH >= LIMIT_FLOOR_MPH:
        yield f"limit-{LIMIT_STEP_MPH}", {**road, "speed_limit_mph": limit - LIMIT_STEP_MPH}


def _lanes(raw: dict) -> Iterator[tuple[str, dict]]:
    road = raw["road_network"]
    if road["number_of_lanes"] < MAX_LANES:
        yield "lanes+1", {**road, "number_of_lanes": road["number_of_lanes"] + 1}


def _bend(raw: dict) -> Iterator[tuple[str, dict]]:
    road = {k: v for k, v in raw["road_network"].items() if k != "curve_direction"}
    if road["road_type"] == "straight":
        for side in ("left", "right"):
            yield f"curve-{side}", {**road, "road_type": "curve", "curve_direction": side}
    elif road["road_type"] == "curve":
        yield "straight", {**road, "road_type": "straight"}


def _truck(raw: dict) -> Iterator[tuple[str, dict]]:
    for name, actor in raw["actors"].items():
        if actor["type"] == "car":
            yield f"{name}=truck", {**raw["actors"], name: {**actor, "type": "truck"}}


# kind -> (the section it replaces, the variants of that section)
KINDS: dict[str, tuple[str, Callable[[dict], Iterator[tuple[str, Any]]]]] = {
    "surface": ("environment", _surface), "light": ("environment", _light), "limit": ("road_network", _limit),
    "lanes": ("road_network", _lanes), "bend": ("road_network", _bend), "truck": ("actors", _truck)}


def variants(raw: dict, kinds: list[str]) -> Iterator[tuple[str, str, dict]]:
    """(kind, label, the golden's raw mapping with one field changed) for each variant of these kinds."""
    for kind in kinds:
        section, vary = KINDS[kind]
        for label, value in vary(raw):
            yield kind, label, {**copy.deepcopy(raw), section: copy.deepcopy(value)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=40, help="variations per variant")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--cases", type=Path, default=REPO / "examples" / "ciren")
    parser.add_argument("--only", nargs="*", default=[], help="these case folders only")
    parser.add_argument("--kinds", nargs="*", choices=sorted(KINDS), default=list(KINDS))
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    args = parser.parse_args()
    rows = []
    print(f"{'case':<16} {'variant':<12} {'valid':>5} {'reprod':>7} {'first':>7} {'s':>6}")
    with tempfile.TemporaryDirectory(prefix="bench-variants-") as tmp:
        for case in sorted(p for p in args.cases.iterdir() if (p / "golden.yaml").is_file()):
            if args.only and case.name not in args.only:
                continue
            raw = yaml.safe_load((case / "golden.yaml").read_text(encoding="utf-8"))
            for kind, label, varied in variants(raw, args.kinds):
                rows.append(_run(case.name, kind, label, varied, Path(tmp) / f"{case.name}-{label}", args))
    for kind in args.kinds:
        subset = [r for r in rows if r["kind"] == kind and "error" not in r]
        if subset:
            means = [statistics.fmean(r[k] or 0.0 for r in subset) for k in RATES]
            lows = [f"{r['case']} {r['variant']}" for r in subset if (r["reproduction_rate"] or 0.0) < 0.8]
            print(f"{kind:<8} ({len(subset):>3}): reproduction {means[0]:.3f}, first contact {means[1]:.3f}; "
                  f"below 0.8: {len(lows)} {', '.join(lows)}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    return 0


def _run(case: str, kind: str, label: str, raw: dict, out: Path, args: argparse.Namespace) -> dict:
    row: dict[str, Any] = {"case": case, "kind": kind, "variant": label}
    try:
        scenario = from_raw(raw, source=f"{case}/golden.yaml ({label})")
    except DslError as exc:  # a variant the DSL refuses is not a failure of reproduce mode
        print(f"{case:<16} {label:<12} refused: {exc}")
        return {**row, "error": str(exc)}
    start = time.perf_counter()
    summary = simulate_scenario(scenario, out, n=args.n, seed=args.seed, mode="reproduce")
    row.update(valid=summary["valid"], seconds=round(time.perf_counter() - start, 1),
               **{k: summary.get(k) for k in RATES})
    print(f"{case:<16} {label:<12} {row['valid']:>5} " + " ".join(_fmt(row[k]) for k in RATES)
          + f" {row['seconds']:>6}", flush=True)
    return row


def _fmt(value: float | None) -> str:
    return f"{value:>7.2f}" if value is not None else f"{'-':>7}"


if __name__ == "__main__":
    sys.exit(main())
