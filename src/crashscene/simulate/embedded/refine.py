"""Reproduce mode: the plans checked against the simulator itself, as crash reconstruction's optimisers do
(PC-Crash's optimiser and sequence optimiser search the pre-crash conditions with the simulation until the
simulated sequence matches the evidence).

The timing plans (plan.VariationPlan) predict contacts with pairwise models; where the prediction is wrong the
variation does not give the written crash sequence. The simulator runs a chunk's batch as it is (`dry_run`, the
real simulator, into a recorder of its own); `replanned` judges each variation's contacts with the monitor's own
code (classified as the monitor classifies them, matched by `verdicts.match_sequence`), and for each valid
variation that misses its sequence (an invalid one, a spawn overlap, stays as it was sampled) simulates K
candidates at once: copies of its plan perturbed in the plan's own degrees of freedom, within the ranges the
plans already allow (a cruise-speed timing scale within timing.SPEED_SCALE, a start moved along its lane, alone
or with the queue ahead of it, a manoeuvre's trigger time). The first candidate, in the order drawn, that gives
the sequence replaces the plan, and the chunk is simulated again with it; otherwise the variation keeps its
analytic plan, and when none is replanned the first run is the chunk's result. A variation that gives its
sequence is left as it was (its batch rows untouched). Candidates come from a generator seeded by the
variation's own (seed, index), so the same seed gives the same bytes, in any chunking.
"""
from __future__ import annotations

import copy

import numpy as np

from crashscene.dsl.tokens import STANDING
from crashscene.monitor.arrays import build_arrays
from crashscene.monitor.collisions import classify_collisions, first_contact_steps
from crashscene.monitor.verdicts import ads_mask, invalid_reasons, match_sequence
from crashscene.render.plan import LEAD_TIME
from crashscene.simulate.embedded import setup as batch_setup
from crashscene.simulate.embedded import timing
from crashscene.simulate.embedded.plan import VariationPlan
from crashscene.simulate.embedded.record import Recorder
from crashscene.simulate.embedded.stations import END_MARGIN, START_GAP, START_MARGIN, same_lane

K = 48  # [-] candidates per variation that misses its sequence: each costs one simulated variation. Measured with
# 200 on the bundled cases (seed 7): 25 of the 47 missing variations of six cases have a candidate that gives the
# sequence, the first one at candidate 0-43 in 23 of them (67 and 136 in the other two)
SHAKE = 0.5  # [-] chance that a candidate perturbs a given degree of freedom (the others keep the plan's value):
# a candidate moves some of the plan's choices, not all at once
SCALE_STEP = 0.25  # [-] a timing scale moves by at most this fraction of itself (then clipped to SPEED_SCALE)
SHIFT_TIME = timing.ARRIVAL_OFFSET_MAX  # [s] a start moves along its lane by at most this long at its planned
# speed: the arrival window the junction plans draw their offsets from
TRIGGER_SHIFT = LEAD_TIME[1]  # [s] a manoeuvre's trigger moves by at most the longest lead time a lateral plan
# draws (render.plan.LEAD_TIME): from the manoeuvre under way at the meeting to twice the longest lead before it
SALT = 0x2EF1  # the refine generator's stream tag, apart from setup.variation_rng's


def refine_rng(seed: int, index: int) -> np.random.Generator:
    """The candidates' generator of variation `index` of a batch seeded `seed` (independent of the chunking)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed) & 0xFFFFFFFF, int(index), SALT]))


def replanned(batch: batch_setup.BatchSetup, run: Recorder) -> batch_setup.BatchSetup | None:
    """`batch` simulated (`run`: its recording) judged: None when every valid variation gave its written sequence
    (or no candidate of one that missed it does), else a fresh batch with the first reproducing candidate's plan in
    place of each missing variation's plan (the other variations' plans as they were), to be simulated instead."""
    from crashscene.simulate.embedded.simulator import chunk_size  # the simulator imports this module

    scenario, scenes, roadmap, settings = batch.scenario, batch.scenes, batch.roadmap, batch.settings
    valid, gives = judged(run, batch)
    missed = [v for v in range(len(scenes)) if valid[v] and not gives[v]]  # an invalid one stays as sampled
    if not missed:
        return None
    trial_scenes, trial_plans, owner = [], [], []
    for v in missed:
        rng = refine_rng(scenes[v].seed, scenes[v].index)
        for plan in candidates(batch.plans[v], rng, K):
            trial_scenes.append(scenes[v].model_copy(update={"index": len(trial_scenes)}))
            trial_plans.append(plan)
            owner.append(v)
    found: dict[int, VariationPlan] = {}
    size = chunk_size(trial_scenes)
    for first in range(0, len(trial_scenes), size):
        part = slice(first, first + size)
        trial = batch_setup.build(scenario, trial_scenes[part], roadmap, settings, plans=trial_plans[part])
        valid, gives = judged(dry_run(trial), trial)
        for j, ok in enumerate(np.logical_and(valid, gives), start=first):
            if ok and owner[j] not in found:
                found[owner[j]] = trial_plans[j]
    if not found:
        return None
    plans = [found.get(v, plan) for v, plan in enumerate(batch.plans)]
    return batch_setup.build(scenario, scenes, roadmap, settings, plans=plans)


def dry_run(batch: batch_setup.BatchSetup) -> Recorder:
    """`batch` simulated (it is changed) into a recorder of its own."""
    from crashscene.simulate.embedded.simulator import run_batch  # the simulator imports this module

    recorder = Recorder(batch.roadmap, batch.settings)
    run_batch(batch, recorder)
    return recorder


def judged(run: Recorder, batch: batch_setup.BatchSetup) -> tuple[list[bool], list[bool]]:
    """(V,) whether each variation of `batch`, simulated into `run`, is valid, and whether it gives the written
    crash sequence, judged as the monitor judges them."""
    tables = run.tables(batch.scenes)
    arrays = build_arrays(tables)
    collisions = classify_collisions(arrays, tables.get("collisions"), arrays.is_ads & arrays.present)
    reasons = invalid_reasons(arrays, ads_mask(arrays), first_contact_steps(arrays, collisions) >= 0)
    row = {int(v): i for i, v in enumerate(arrays.variations)}
    contacts: list[list[tuple[str, str, str, str, str]]] = [[] for _ in range(len(row))]
    if collisions.num_rows:
        cols = collisions.select(["variation", "actor_a", "actor_b", "class", "area_a", "area_b"]).to_pydict()
        for v, *contact in zip(*cols.values()):
            contacts[row[int(v)]].append(tuple(contact))
    reported = batch.scenario.collisions or []
    rows = [row[scene.index] for scene in batch.scenes]
    return ([reasons[i] is None for i in rows], [match_sequence(contacts[i], reported).sequence for i in rows])


def candidates(plan: VariationPlan, rng: np.random.Generator, k: int) -> list[VariationPlan]:
    """k copies of `plan`, each perturbed by `perturb` with the next draws of `rng`."""
    out = []
    for _ in range(k):
        trial = copy.copy(plan)
        for name, rows in plan.snapshot().items():
            setattr(trial, name, rows)
        perturb(trial, rng)
        out.append(trial)
    return out


def perturb(plan: VariationPlan, rng: np.random.Generator) -> None:
    """Moves some of the plan's own choices of each moving actor, with a fixed number of draws per actor (so one
    actor's draws never shift another's): its timing scale (within timing.SPEED_SCALE), its start along its lane
    (alone, or with the cars ahead of it in its lane, which keeps the gaps of a queue), its manoeuvre trigger."""
    ctx = plan.ctx
    for a, col in enumerate(ctx.columns):
        shake = rng.random(3) < SHAKE
        scale_step, shift_step, group, trigger_step = rng.uniform(-1.0, 1.0, 4)
        if col.is_ads or col.behavior in STANDING or plan.hold[a] > 0 or plan.planned[a] <= 0.5:
            continue
        if shake[0]:
            plan.scale[a] = float(np.clip(plan.scale[a] * (1.0 + SCALE_STEP * scale_step), *timing.SPEED_SCALE))
        if shake[1]:
            shift = shift_step * SHIFT_TIME * plan.planned[a] * plan.scale[a]
            queue = [a] + ([b for b in range(len(ctx.columns)) if same_lane(plan.route, plan.d0, a, b)
                            and plan.s0[b] > plan.s0[a]] if group > 0 else [])
            if shift_queue(plan, queue, shift):
                plan.moved[queue] = True
        if shake[2] and np.isfinite(plan.trigger[a]):
            plan.trigger[a] = max(0.0, float(plan.trigger[a]) + trigger_step * TRIGGER_SHIFT)


def shift_queue(plan: VariationPlan, queue: list[int], shift: float) -> bool:
    """Moves the starts of `queue` (an actor and possibly the cars ahead of it in its lane) `shift` [m] along
    their routes together, when the routes have room and no other car of their lanes comes within a car length
    and START_GAP of a moved start or between old and new; False (nothing moved) otherwise."""
    s0, length, route, arrays = plan.s0, plan.length, plan.route, plan.ctx.arrays
    new = {a: float(s0[a] + shift) for a in queue}
    for a, s in new.items():
        if s < START_MARGIN or s > arrays.length[route[a]] - END_MARGIN:
            return False
        lo, hi = min(s0[a], s), max(s0[a], s)
        for b in range(len(route)):
            if b in new or not same_lane(route, plan.d0, a, b):
                continue
            if abs(s0[b] - s) < (length[a] + length[b]) / 2 + START_GAP or lo < s0[b] < hi:
                return False
    for a, s in new.items():
        s0[a] = s
    return True
