"""The failure region as rules: a shallow decision tree over the parameters, read leaf by leaf.

scikit-learn's CART tree (depth MAX_DEPTH, leaves of at least MIN_LEAF_SHARE of the
variations) is fitted to "failed or not"; every leaf where failures are the
majority becomes a rule such as
`npc1_SPEED > 11.2 and npc1_ARRIVAL_OFFSET <= 0.4 -> 83% collision (n=40)`,
most failures first.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_DEPTH = 3
MIN_LEAF_SHARE = 0.03
MIN_LEAF = 5


@dataclass(frozen=True)
class RegionRule:
    conditions: tuple[str, ...]
    failure_rate: float     # share of the leaf's variations that failed
    kind: str               # collision | violation | failure (both)
    support: int            # variations in the leaf
    failures: int

    def text(self) -> str:
        cond = " and ".join(self.conditions) if self.conditions else "always"
        return f"{cond} -> {round(100 * self.failure_rate)}% {self.kind} (n={self.support})"

    def to_json(self) -> dict:
        return {"rule": self.text(), "conditions": list(self.conditions), "failure_rate": round(self.failure_rate, 4),
                "kind": self.kind, "support": self.support, "failures": self.failures}


def failure_rules(names: list[str], values: np.ndarray, verdicts: list[str], seed: int = 0) -> list[RegionRule]:
    """Rules describing where the failing verdicts (violation, collision) concentrate; [] when none failed."""
    from sklearn.tree import DecisionTreeClassifier

    failed = np.array([v in ("violation", "collision") for v in verdicts])
    if not failed.any() or len(failed) < 2 * MIN_LEAF:
        return []
    leaf_min = max(MIN_LEAF, int(MIN_LEAF_SHARE * len(failed)))
    tree = DecisionTreeClassifier(max_depth=MAX_DEPTH, min_samples_leaf=leaf_min, random_state=seed)
    tree.fit(values, failed)
    t = tree.tree_
    leaves = tree.apply(values)
    kinds = np.array(verdicts, dtype=object)
    rules: list[RegionRule] = []

    def walk(node: int, conditions: tuple[str, ...]) -> None:
        if t.children_left[node] == t.children_right[node]:   # a leaf
            members = leaves == node
            n_fail = int(failed[members].sum())
            support = int(members.sum())
            if support and n_fail * 2 > support:
                found = set(kinds[members & failed])
                kind = found.pop() if len(found) == 1 else "failure"
                rules.append(RegionRule(conditions, n_fail / support, kind, support, n_fail))
            return
        name, threshold = names[t.feature[node]], t.threshold[node]
        walk(t.children_left[node], _merge(conditions, name, "<=", threshold))
        walk(t.children_right[node], _merge(conditions, name, ">", threshold))

    walk(0, ())
    return sorted(rules, key=lambda r: (-r.failures, -r.failure_rate, r.text()))


def _merge(conditions: tuple[str, ...], name: str, op: str, threshold: float) -> tuple[str, ...]:
    """Add `name op threshold`, replacing a looser bound on the same parameter and side."""
    kept = tuple(c for c in conditions if not c.startswith(f"{name} {op} "))
    bound = f"{name} {op} {threshold:.3g}"
    for c in conditions:
        if c.startswith(f"{name} {op} "):
            old = float(c.rsplit(" ", 1)[1])
            tighter = threshold < old if op == "<=" else threshold > old
            bound = bound if tighter else c
    return kept + (bound,)
