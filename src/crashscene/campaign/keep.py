"""The traces the report will draw, chosen as chunks finish and kept in the campaign database.

Per run (scenario, seed, mode) the report draws a few variations, one per
`REASONS` entry: the first reproducing variation, the first ADS violation, the
ADS's closest calls (lowest rule robustness, lowest TTC), the first collision,
and the first variation (the fallback). A worker picks its chunk's best
variation for each reason (`pick`) and returns those variations' traces with
its rows; the store writes them in the chunk's transaction, so a stored chunk
always has its candidates (resume needs nothing more), then `prune` drops the
candidates another chunk beats. What remains after the last chunk is the same
whatever the chunk order: per reason, the lowest (score, variation).
"""
from __future__ import annotations

import math

import pyarrow as pa
import pyarrow.compute as pc

REASONS = ("first_reproducing", "first_ads_violation", "closest_robustness", "closest_ttc", "first_collision",
           "first_variation")
COLLISION_SCORE = -1e9  # the robustness of a variation where the ADS collided: lower than any rule margin

SHOWN_ROWS = pa.schema([
    ("variation", pa.int32()),
    ("reason", pa.string()),         # REASONS
    ("score", pa.float64()),         # lower is chosen (ties: lower variation)
])
SHOWN_TRACE_ROWS = pa.schema([
    ("variation", pa.int32()),
    ("actor", pa.string()),
    ("t", pa.float64()),             # [s]
    ("x", pa.float64()),             # [m]
    ("y", pa.float64()),             # [m]
    ("yaw", pa.float64()),           # [rad]
    ("speed", pa.float64()),         # [m/s]
])
SHOWN_ACTOR_ROWS = pa.schema([
    ("variation", pa.int32()),
    ("actor", pa.string()),
    ("label", pa.string()),
    ("type", pa.string()),
    ("is_ads", pa.bool_()),
    ("length", pa.float64()),        # [m]
    ("width", pa.float64()),         # [m]
])
SHOWN_SCHEMAS = {"shown": SHOWN_ROWS, "shown_traces": SHOWN_TRACE_ROWS, "shown_actors": SHOWN_ACTOR_ROWS}


def _best(scores: dict[int, float]) -> tuple[int, float] | None:
    finite = {v: s for v, s in scores.items() if s is not None and not math.isnan(s)}
    if not finite:
        return None
    v = min(finite, key=lambda k: (finite[k], k))
    return v, finite[v]


def ads_robustness(rule_results: pa.Table, collisions: pa.Table) -> dict[int, float]:
    """Per variation, the lowest rule robustness of an actor under test (COLLISION_SCORE when it collided)."""
    out: dict[int, float] = {}
    rows = rule_results.filter(pc.and_(pc.equal(rule_results.column("is_ads"), True),
                                       pc.not_equal(rule_results.column("verdict"), "not_applicable")))
    for r in rows.select(["variation", "robustness"]).to_pylist():
        if r["robustness"] is not None and math.isfinite(r["robustness"]):
            out[r["variation"]] = min(out.get(r["variation"], math.inf), r["robustness"])
    if "involves_ads" in collisions.column_names:
        for r in collisions.select(["variation", "involves_ads"]).to_pylist():
            if r["involves_ads"]:
                out[r["variation"]] = COLLISION_SCORE
    return out


def pick(variations: list[dict], rule_results: pa.Table, collisions: pa.Table,
         ttc: dict[int, float] | None = None) -> pa.Table:
    """The chunk's candidate per reason: SHOWN_ROWS (variation, reason, score).

    `variations` are the chunk's variation rows (variation, valid, reproduced, collided); `ttc` the ADS's
    minimum time to collision [s] per variation when criticality was computed."""
    valid = [r for r in variations if r["valid"]]
    ads_violated = set(pc.unique(rule_results.filter(pc.and_(
        pc.equal(rule_results.column("is_ads"), True),
        pc.equal(rule_results.column("verdict"), "violated"))).column("variation")).to_pylist())
    robustness = ads_robustness(rule_results, collisions)
    scores = {
        "first_reproducing": {r["variation"]: float(r["variation"]) for r in valid if r["reproduced"]},
        "first_ads_violation": {r["variation"]: float(r["variation"]) for r in valid if r["variation"] in ads_violated},
        "closest_robustness": {r["variation"]: robustness.get(r["variation"]) for r in valid},
        "closest_ttc": {r["variation"]: (ttc or {}).get(r["variation"]) for r in valid},
        "first_collision": {r["variation"]: float(r["variation"]) for r in valid if r["collided"]},
        "first_variation": {r["variation"]: float(r["variation"]) for r in (valid or variations)},
    }
    rows = []
    for reason in REASONS:
        best = _best(scores[reason])
        if best is not None:
            rows.append({"variation": best[0], "reason": reason, "score": best[1]})
    return pa.Table.from_pylist(rows, SHOWN_ROWS)


def traces_of(shown: pa.Table, traces: pa.Table, actors: pa.Table) -> tuple[pa.Table, pa.Table]:
    """The trace and actor rows of the chosen variations (SHOWN_TRACE_ROWS, SHOWN_ACTOR_ROWS)."""
    wanted = pa.array(sorted(set(shown.column("variation").to_pylist())), pa.int32())
    tr = traces.filter(pc.is_in(traces.column("variation"), wanted))
    tr = tr.select(SHOWN_TRACE_ROWS.names).cast(SHOWN_TRACE_ROWS)
    ac = actors.filter(pc.is_in(actors.column("variation"), wanted))
    for name, typ in zip(SHOWN_ACTOR_ROWS.names, SHOWN_ACTOR_ROWS.types):
        if name not in ac.column_names:
            ac = ac.append_column(name, pa.nulls(ac.num_rows, typ))
    return tr, ac.select(SHOWN_ACTOR_ROWS.names).cast(SHOWN_ACTOR_ROWS)


def prune(con, scenario_hash: str, seed: int, mode: str) -> None:
    """Keep, per reason, only the best candidate of the run, and only the traces of kept candidates."""
    key = [scenario_hash, seed, mode]
    where = "scenario_hash=? AND seed=? AND mode=?"
    con.execute(f"""DELETE FROM shown WHERE {where} AND NOT EXISTS (
        SELECT 1 FROM (SELECT reason, variation, row_number() OVER (PARTITION BY reason ORDER BY score, variation) AS k
                       FROM shown WHERE {where}) AS best
        WHERE best.k = 1 AND best.reason = shown.reason AND best.variation = shown.variation)""", key + key)
    for table in ("shown_traces", "shown_actors"):
        con.execute(f"DELETE FROM {table} WHERE {where} AND variation NOT IN "
                    f"(SELECT variation FROM shown WHERE {where})", key + key)
