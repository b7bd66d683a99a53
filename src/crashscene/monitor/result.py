"""MonitorResult: the three result tables and the JSON summary built from them."""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from crashscene.monitor.collisions import COLLISION_CLASSES
from crashscene.monitor.verdicts import VERDICTS

RULE_RESULT_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("actor", pa.string()),
    ("code", pa.string()),
    ("violation", pa.string()),         # the rule's violation token
    ("verdict", pa.string()),           # violated | satisfied | not_applicable
    ("first_violation_t", pa.float64()),  # [s]
    ("measured", pa.float64()),         # in `unit`
    ("threshold", pa.float64()),        # in `unit`
    ("unit", pa.string()),
    ("robustness", pa.float64()),       # signed margin in `unit`, negative when violated
    ("is_ads", pa.bool_()),             # the actor is under test in this variation
    ("note", pa.string()),              # exemption used, advisory, condition factor
])


@dataclass
class MonitorResult:
    """What the monitor found for one batch of variations."""

    rule_results: pa.Table
    collisions: pa.Table
    verdicts: pa.Table
    rules: list[dict[str, Any]] = field(default_factory=list)   # code, violation, unit, params of each rule run
    oracle: dict[str, Any] = field(default_factory=dict)       # observable/unmonitored entries, expected collision
    rulebook: str | None = None

    def _per_rule(self, valid: set[int], order: list[str]) -> tuple[dict, dict]:
        """Verdict counts per code (actor rows of valid variations) and, per code and actor, the smallest
        finite robustness: how close the batch came to (or how far it went past) each threshold."""
        rr = self.rule_results
        if not rr.num_rows:
            return {}, {}
        rr = rr.filter(pc.is_in(rr["variation"], value_set=pa.array(sorted(valid), type=pa.int32())))
        counts: dict[str, Counter] = {}
        for row in rr.group_by(["code", "verdict"]).aggregate([("verdict", "count")]).to_pylist():
            counts.setdefault(row["code"], Counter())[row["verdict"]] = row["verdict_count"]
        finite = rr.filter(pc.is_finite(rr["robustness"]))
        closest: dict[str, dict[str, float]] = {}
        for row in finite.group_by(["code", "actor"]).aggregate([("robustness", "min")]).to_pylist():
            closest.setdefault(row["code"], {})[row["actor"]] = row["robustness_min"]
        verdict_names = ("violated", "satisfied", "not_applicable")
        return ({code: {name: int(counts[code].get(name, 0)) for name in verdict_names}
                 for code in order if code in counts},
                {code: {actor: _json_number(value) for actor, value in sorted(closest[code].items())}
                 for code in order if code in closest})

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary; counts are over valid variations unless said otherwise."""
        verdicts = self.verdicts.to_pydict()
        valid = {v for v, verdict in zip(verdicts["variation"], verdicts["verdict"]) if verdict != "invalid"}
        n_valid = len(valid)
        violations: dict[str, dict[str, int]] = {}
        rr = self.rule_results.filter(pc.equal(self.rule_results["verdict"], "violated"))
        if rr.num_rows:
            cols = rr.select(["variation", "actor", "code"]).to_pydict()
            seen = set()
            for v, actor, code in zip(cols["variation"], cols["actor"], cols["code"]):
                if v in valid and (v, actor, code) not in seen:
                    seen.add((v, actor, code))
                    violations.setdefault(code, {}).setdefault(actor, 0)
                    violations[code][actor] += 1
        order = [r["code"] for r in self.rules]
        violations = {code: dict(sorted(violations[code].items())) for code in order if code in violations}
        counts = Counter(verdicts["verdict"])
        reproduced = int(sum(1 for r in verdicts["reproduced"] if r))
        rates = {}
        for column in ("first_contact", "sequence", "area_match"):
            values = [value for value, verdict in zip(verdicts[column], verdicts["verdict"]) if verdict != "invalid"]
            known = [value for value in values if value is not None]
            rates[f"{column}_rate"] = round(sum(known) / n_valid, 4) if n_valid and known else None
        coll = self.collisions.to_pydict()
        by_class: Counter = Counter()
        by_pair: dict[str, Counter] = {}
        for v, a, b, klass in zip(coll["variation"], coll["actor_a"], coll["actor_b"], coll["class"]):
            if v in valid:
                by_class[klass] += 1
                by_pair.setdefault(f"{a}-{b}", Counter())[klass] += 1
        invalid_reasons = Counter(r for r, verdict in zip(verdicts["reason"], verdicts["verdict"])
                                  if verdict == "invalid")
        rule_verdicts, closest = self._per_rule(valid, order)
        return {
            "variations": len(verdicts["variation"]),
            "valid": n_valid,
            "violations": violations,
            "verdicts": {name: int(counts.get(name, 0)) for name in VERDICTS},
            "reproduced": reproduced,
            "reproduction_rate": round(reproduced / n_valid, 4) if n_valid else None,
            **rates,
            "collisions": {name: int(by_class.get(name, 0)) for name in COLLISION_CLASSES},
            "collision_pairs": {pair: dict(c) for pair, c in sorted(by_pair.items())},
            "invalid_reasons": dict(invalid_reasons),
            "rule_verdicts": rule_verdicts,
            "min_robustness": closest,
            "oracle": self.oracle.get("oracle", []),
            "expected_collision": self.oracle.get("expected_collision"),
            "expected_sequence": self.oracle.get("expected_sequence"),
            "rules": [r["code"] for r in self.rules],
            "rulebook": self.rulebook,
        }


def combine(parts: list[MonitorResult]) -> MonitorResult:
    """One result from the results of consecutive blocks of variations (each evaluated alone: the monitor
    judges every variation by itself): tables concatenated in block order, oracle observations summed."""
    first = parts[0]
    oracle = dict(first.oracle)
    entries = [dict(e) for e in first.oracle.get("oracle", [])]
    for part in parts[1:]:
        for entry, more in zip(entries, part.oracle.get("oracle", [])):
            if entry["observed"] is not None:
                entry["observed"] += more["observed"]
    if "oracle" in oracle:
        oracle["oracle"] = entries
    return MonitorResult(rule_results=pa.concat_tables([p.rule_results for p in parts]),
                         collisions=pa.concat_tables([p.collisions for p in parts]),
                         verdicts=pa.concat_tables([p.verdicts for p in parts]),
                         rules=first.rules, oracle=oracle, rulebook=first.rulebook)


def _json_number(value: float) -> float | None:
    return round(float(value), 4) if np.isfinite(value) else None


def rule_results_table(variations: np.ndarray, roles: list[str], present: np.ndarray, ads: np.ndarray,
                       outcomes: list[tuple[Any, Any]]) -> pa.Table:
    """Long table, one row per (variation, actor, rule) for actors present in the variation."""
    vv, aa = np.nonzero(present)
    parts = []
    role_arr = np.asarray(roles, dtype=object)
    for rule, out in outcomes:
        verdict = np.where(out.applicable, np.where(out.violated, "violated", "satisfied"), "not_applicable")
        n = len(vv)
        parts.append(pa.table({
            "variation": pa.array(variations[vv].astype(np.int32)),
            "actor": pa.array(role_arr[aa].tolist(), type=pa.string()),
            "code": pa.array([rule.code] * n, type=pa.string()),
            "violation": pa.array([rule.violation] * n, type=pa.string()),
            "verdict": pa.array(verdict[vv, aa].tolist(), type=pa.string()),
            "first_violation_t": pa.array(out.first_t[vv, aa].astype(float)),
            "measured": pa.array(out.measured[vv, aa].astype(float)),
            "threshold": pa.array(out.threshold[vv, aa].astype(float)),
            "unit": pa.array([rule.unit] * n, type=pa.string()),
            "robustness": pa.array(out.robustness[vv, aa].astype(float)),
            "is_ads": pa.array(ads[vv, aa]),
            "note": pa.array(out.note[vv, aa].tolist(), type=pa.string()),
        }, schema=RULE_RESULT_SCHEMA))
    if not parts:
        return RULE_RESULT_SCHEMA.empty_table()
    table = pa.concat_tables(parts)
    # variation-major order, then actor (ego first), then rule (rules.md order)
    rule_no = np.repeat(np.arange(len(parts)), len(vv))
    key = (np.tile(vv, len(parts)) * len(roles) + np.tile(aa, len(parts))) * len(parts) + rule_no
    return table.take(pa.array(np.argsort(key, kind="stable")))
