"""Per-variation verdicts and reproduction of the scenario's oracle.

Verdict (rules.md): `invalid` when the test did not happen (the simulator said
so, the variation has no trace, or the actor under test never moved although
its behaviour is not static/stop); else `violation` when an actor under test
violated a rule; else `collision` when an actor under test collided; else
`pass`. The actors under test are those with `is_ads`; in reproduce mode no
actor is, and the ego stands in for it.

Reproduction: every oracle entry with a monitored code is violated by its
actor, and the expected collision (the report's crash, derived from the DSL:
the ego and the actor to blame, with the class its heading relation implies)
occurs with that class between those two actors. For a single-vehicle
scenario whose actor leaves the road, leaving the road is the expected event.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from crashscene.dsl.model import Scenario
from crashscene.monitor.arrays import TraceArrays
from crashscene.monitor.conflicts import arc_length
from crashscene.monitor.rules.base import RuleOutcome

VERDICTS = ("violation", "collision", "pass", "invalid")
STATIONARY_BEHAVIORS = ("static", "stop")
MIN_TRAVEL = 0.5  # [m] an actor under test that moved less never took part

VERDICT_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("verdict", pa.string()),                 # VERDICTS
    ("reproduced", pa.bool_()),
    ("reason", pa.string()),
    ("ads_violations", pa.list_(pa.string())),  # codes violated by the actors under test
    ("collision_classes", pa.list_(pa.string())),  # classes of collisions involving them
])


@dataclass(frozen=True)
class ExpectedCollision:
    """The crash the report describes, as the monitor can observe it."""

    actor_a: str
    actor_b: str
    klass: str | None   # None: any class (e.g. a rotating, out-of-control vehicle)
    also: tuple[str, ...] = ()  # further classes that count as the same crash

    def accepts(self, klass: str) -> bool:
        return self.klass is None or klass == self.klass or klass in self.also

    def label(self) -> str:
        return "/".join([self.klass, *self.also]) if self.klass else "any"

    def to_json(self) -> dict:
        return {"actors": [self.actor_a, self.actor_b], "class": self.klass,
                "accepted": [self.klass, *self.also] if self.klass else None}


def expected_collision(scenario: Scenario | None) -> ExpectedCollision | None:
    """The ego's crash partner and the class implied by its heading relation and behaviours."""
    if scenario is None or not scenario.npcs:
        return None
    blamed = [e.actor for e in scenario.oracle if e.actor != "ego" and e.actor in scenario.actors]
    partner = blamed[0] if blamed else next(iter(scenario.npcs))
    ego, other = scenario.actors["ego"], scenario.actors[partner]
    behaviors = {str(ego.behavior), str(other.behavior)}
    heading = str(other.position.heading) if other.position.heading is not None else "same_direction"
    also: tuple[str, ...] = ()
    if "lose_control" in behaviors:
        klass = None
    elif heading in ("from_left", "from_right"):
        klass = "angle"
    elif heading == "opposite_direction":
        if behaviors & {"turn_left", "turn_right", "u_turn"}:
            # a turn across the oncoming lane is struck early in the turn too, at 120-160 deg
            klass, also = "angle", ("sideswipe",)
        else:
            klass = "head_on"
    elif behaviors & {"change_lane_left", "change_lane_right", "overtake", "cross_centerline", "leave_road"}:
        klass = "sideswipe"
    else:
        klass = "rear_end"
    return ExpectedCollision("ego", partner, klass, also)


def ads_mask(arrays: TraceArrays) -> np.ndarray:
    """(V, A) actors under test: is_ads, or the ego in variations where no actor is."""
    ads = arrays.is_ads & arrays.present
    fallback = ~ads.any(axis=1)
    if "ego" in arrays.roles:
        ego = arrays.roles.index("ego")
        ads[fallback, ego] = arrays.present[fallback, ego]
    return ads


def invalid_reasons(arrays: TraceArrays, ads: np.ndarray, collided: np.ndarray | None = None) -> list[str | None]:
    """Why each variation is invalid, None when it is valid. An actor under test that collided took part
    in the test even if it never moved (`collided`, (V, A))."""
    travel = arc_length(arrays)[..., -1] if arrays.shape[2] else np.zeros(arrays.shape[:2])
    moving_role = ~np.isin(arrays.behavior.astype(str), STATIONARY_BEHAVIORS)
    never_moved = ads & moving_role & (travel < MIN_TRAVEL)
    if collided is not None:
        never_moved &= ~collided
    out: list[str | None] = []
    for v in range(arrays.shape[0]):
        if not arrays.valid[v]:
            out.append(arrays.invalid_reason[v] or "invalid (no reason given by the simulator)")
        elif not arrays.alive[v].any():
            out.append("no trace rows: the variation was not simulated")
        elif never_moved[v].any():
            roles = [arrays.roles[i] for i in np.nonzero(never_moved[v])[0]]
            out.append(f"the actor under test never moved ({', '.join(roles)})")
        else:
            out.append(None)
    return out


def verdict_table(arrays: TraceArrays, outcomes: dict[str, RuleOutcome], collisions: pa.Table,
                  scenario: Scenario | None, ads: np.ndarray, expected: ExpectedCollision | None,
                  reasons: list[str | None] | None = None) -> tuple[pa.Table, dict]:
    """The verdicts table and what the summary needs about the oracle.

    `reasons` (from `invalid_reasons` on the untruncated traces) say which variations are invalid.
    """
    n_var = arrays.shape[0]
    if reasons is None:
        reasons = invalid_reasons(arrays, ads)
    role_index = {r: i for i, r in enumerate(arrays.roles)}
    var_index = {int(v): i for i, v in enumerate(arrays.variations)}
    ads_codes: list[list[str]] = [[] for _ in range(n_var)]
    for code, out in outcomes.items():
        hit = (out.violated & ads).any(axis=1)
        for v in np.nonzero(hit)[0]:
            ads_codes[v].append(code)
    coll_classes: list[list[str]] = [[] for _ in range(n_var)]
    pair_classes: list[set[tuple[str, str, str]]] = [set() for _ in range(n_var)]
    if collisions.num_rows:
        cols = collisions.select(["variation", "actor_a", "actor_b", "class"]).to_pydict()
        for v, aa, bb, klass in zip(cols["variation"], cols["actor_a"], cols["actor_b"], cols["class"]):
            vi = var_index[int(v)]
            pair_classes[vi].add((aa, bb, klass))
            pair_classes[vi].add((bb, aa, klass))
            if ads[vi, role_index[aa]] or ads[vi, role_index[bb]]:
                coll_classes[vi].append(klass)

    # oracle entries the monitor can observe
    observable, unmonitored = [], []
    for entry in (scenario.oracle if scenario is not None else []):
        if entry.code in outcomes and entry.actor in role_index:
            observable.append(entry)
        else:
            unmonitored.append(entry)
    observed = {(e.code, e.actor): outcomes[e.code].violated[:, role_index[e.actor]] for e in observable}
    leave_road = _leave_road_expected(scenario, arrays) if expected is None else None

    verdicts, reproduced, reason_text = [], [], []
    for v in range(n_var):
        if reasons[v] is not None:
            verdicts.append("invalid")
            reproduced.append(False)
            reason_text.append(reasons[v])
            continue
        if ads_codes[v]:
            verdicts.append("violation")
        elif coll_classes[v]:
            verdicts.append("collision")
        else:
            verdicts.append("pass")
        seen, missing = [], []
        for e in observable:
            (seen if observed[(e.code, e.actor)][v] else missing).append(f"{e.code} by {e.actor}")
        if expected is not None:
            label = f"{expected.label()} collision {expected.actor_a}-{expected.actor_b}"
            match = any(a == expected.actor_a and b == expected.actor_b and expected.accepts(k)
                        for a, b, k in pair_classes[v])
            (seen if match else missing).append(label)
        if leave_road is not None:
            (seen if leave_road[v] else missing).append("leaves the road")
        if not seen and not missing:
            reproduced.append(False)
            reason_text.append("nothing observable to reproduce (no monitored oracle entry, no expected collision)")
        elif missing:
            reproduced.append(False)
            reason_text.append("not reproduced: missing " + "; ".join(missing))
        else:
            reproduced.append(True)
            reason_text.append("reproduced: " + "; ".join(seen))
    table = pa.table({
        "variation": pa.array(arrays.variations.astype(np.int32)),
        "verdict": pa.array(verdicts, type=pa.string()),
        "reproduced": pa.array(reproduced, type=pa.bool_()),
        "reason": pa.array(reason_text, type=pa.string()),
        "ads_violations": pa.array(ads_codes, type=pa.list_(pa.string())),
        "collision_classes": pa.array(coll_classes, type=pa.list_(pa.string())),
    }, schema=VERDICT_SCHEMA)
    info = {
        "oracle": [{"code": e.code, "actor": e.actor, "monitored": True,
                    "observed": int((observed[(e.code, e.actor)] & np.array([r is None for r in reasons])).sum())}
                   for e in observable]
                  + [{"code": e.code, "actor": e.actor, "monitored": False, "observed": None} for e in unmonitored],
        "expected_collision": expected.to_json() if expected is not None else None,
        "expected_leave_road": leave_road is not None,
    }
    return table, info


def _leave_road_expected(scenario: Scenario | None, arrays: TraceArrays) -> np.ndarray | None:
    """(V,) for a scenario whose actors include a road departure and no other vehicle: did it leave the road."""
    if scenario is None or scenario.npcs:
        return None
    if str(scenario.actors["ego"].behavior) != "leave_road" or "ego" not in arrays.roles:
        return None
    off = arrays.flag("off_road")[:, arrays.roles.index("ego")]
    if not arrays.known("off_road").any():
        return None
    return off.any(axis=1)
