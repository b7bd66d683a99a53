"""Per-variation verdicts and reproduction of the scenario's oracle.

Verdict (rules.md): `invalid` when the test did not happen (the simulator said
so, the variation has no trace, or the actor under test never moved although
its behaviour is not static/stop); else `violation` when an actor under test
violated a rule; else `collision` when an actor under test collided; else
`pass`. The actors under test are those with `is_ads`; in reproduce mode no
actor is, and the ego stands in for it.

Reproduction (rules.md): every oracle entry with a monitored code is violated
by its actor, and the crash sequence happens. When the DSL has `collisions`,
the sequence is that list: its first contact is the variation's first contact
between actors (the same two actors, the same class) and every later contact
follows, in order (the same two actors and class); each matched contact's
areas are compared apart (`area_match`). Without `collisions` (older files),
the expected collision is derived from the DSL (the ego and the actor to
blame, with the class its heading relation implies) and must occur. For a
single-vehicle scenario whose actor leaves the road, leaving the road is the
expected event.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from crashscene.dsl.model import Contact, Scenario
from crashscene.dsl.tokens import LANE_CHANGES, OPPOSING_PASSES, STANDING
from crashscene.monitor.arrays import TraceArrays
from crashscene.monitor.conflicts import arc_length
from crashscene.monitor.rules.base import RuleOutcome

VERDICTS = ("violation", "collision", "pass", "invalid")
STATIONARY_BEHAVIORS = STANDING
MIN_TRAVEL = 0.5  # [m] an actor under test that moved less never took part

VERDICT_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("verdict", pa.string()),                 # VERDICTS
    ("reproduced", pa.bool_()),
    ("reason", pa.string()),
    ("ads_violations", pa.list_(pa.string())),  # codes violated by the actors under test
    ("collision_classes", pa.list_(pa.string())),  # classes of collisions involving them
    ("first_contact", pa.bool_()),            # the first contact is the reported (or expected) one
    ("sequence", pa.bool_()),                 # the whole reported sequence happened, in order
    ("area_match", pa.bool_()),               # ... with the reported areas (null: the DSL has no collisions)
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
    elif behaviors & {*LANE_CHANGES, *OPPOSING_PASSES, "leave_road"}:
        klass = "sideswipe"
    else:
        klass = "rear_end"
    return ExpectedCollision("ego", partner, klass, also)


@dataclass(frozen=True)
class SequenceMatch:
    """How a variation's contacts compare with the crash sequence."""

    first_contact: bool
    sequence: bool
    area_match: bool | None


def match_sequence(observed: list[tuple[str, str, str, str, str]], reported: list[Contact]) -> SequenceMatch:
    """Compare a variation's contacts, in time order as (actor_a, actor_b, class, area_a, area_b), with the
    reported sequence. The first contact must be the first one observed; later ones follow in order."""
    if not reported:
        return SequenceMatch(not observed, not observed, None)

    def fits(seen: tuple[str, str, str, str, str], contact: Contact) -> bool:
        return {seen[0], seen[1]} == {contact.striking, contact.struck} and seen[2] == contact.class_.value

    def areas(seen: tuple[str, str, str, str, str], contact: Contact) -> bool:
        by_actor = {seen[0]: seen[3], seen[1]: seen[4]}
        return (by_actor[contact.striking] == contact.striking_area.value
                and by_actor[contact.struck] == contact.struck_area.value)

    if not observed or not fits(observed[0], reported[0]):
        return SequenceMatch(False, False, False)
    matched = [(observed[0], reported[0])]
    position = 1
    for contact in reported[1:]:
        while position < len(observed) and not fits(observed[position], contact):
            position += 1
        if position == len(observed):
            break
        matched.append((observed[position], contact))
        position += 1
    sequence = len(matched) == len(reported)
    return SequenceMatch(True, sequence, sequence and all(areas(seen, c) for seen, c in matched))


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
    contacts: list[list[tuple[str, str, str, str, str]]] = [[] for _ in range(n_var)]  # in time order
    if collisions.num_rows:
        cols = collisions.select(["variation", "actor_a", "actor_b", "class", "area_a", "area_b"]).to_pydict()
        for v, aa, bb, klass, area_a, area_b in zip(*cols.values()):
            vi = var_index[int(v)]
            contacts[vi].append((aa, bb, klass, area_a, area_b))
            if ads[vi, role_index[aa]] or ads[vi, role_index[bb]]:
                coll_classes[vi].append(klass)
    reported = scenario.collisions if scenario is not None and expected is None else None

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
    first_contact: list[bool] = []
    sequence: list[bool] = []
    area_match: list[bool | None] = []
    for v in range(n_var):
        if reasons[v] is not None:
            verdicts.append("invalid")
            reproduced.append(False)
            reason_text.append(reasons[v])
            first_contact.append(False)
            sequence.append(False)
            area_match.append(None if reported is None else False)
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
        if reported is not None:
            match = match_sequence(contacts[v], reported)
            first_contact.append(match.first_contact)
            sequence.append(match.sequence)
            area_match.append(match.area_match)
            label = ("no contact between actors" if not reported else
                     "crash sequence " + ", ".join(f"{c.striking}-{c.struck} {c.class_.value}" for c in reported))
            # a written sequence is an observation with one vehicle too (rules.md: each monitored oracle entry,
            # none may be written, and the sequence, [] here, happened): a lone vehicle touched no other actor
            (seen if match.sequence else missing).append(label if scenario.npcs else "one vehicle, " + label)
        elif expected is not None:
            label = f"{expected.label()} collision {expected.actor_a}-{expected.actor_b}"

            def fits(contact: tuple[str, str, str, str, str]) -> bool:
                return {contact[0], contact[1]} == {expected.actor_a, expected.actor_b} and expected.accepts(contact[2])

            match_any = any(fits(c) for c in contacts[v])
            first_contact.append(bool(contacts[v]) and fits(contacts[v][0]))
            sequence.append(match_any)
            area_match.append(None)
            (seen if match_any else missing).append(label)
        else:
            first_contact.append(not contacts[v])
            sequence.append(not contacts[v])
            area_match.append(None)
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
        "first_contact": pa.array(first_contact, type=pa.bool_()),
        "sequence": pa.array(sequence, type=pa.bool_()),
        "area_match": pa.array(area_match, type=pa.bool_()),
    }, schema=VERDICT_SCHEMA)
    info = {
        "oracle": [{"code": e.code, "actor": e.actor, "monitored": True,
                    "observed": int((observed[(e.code, e.actor)] & np.array([r is None for r in reasons])).sum())}
                   for e in observable]
                  + [{"code": e.code, "actor": e.actor, "monitored": False, "observed": None} for e in unmonitored],
        "expected_collision": expected.to_json() if expected is not None else None,
        "expected_sequence": ([c.model_dump(mode="json", by_alias=True) for c in reported]
                              if reported is not None else None),
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
