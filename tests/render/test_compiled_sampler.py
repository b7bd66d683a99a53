"""The compiled (numpy) sampler against Scenic's: same distribution, same requirements, index-deterministic draws.

The cross-check samples each program with both samplers and compares, per
sampled parameter and per actor coordinate (x, y, yaw, speed, length), the two
samples with a two-sample Kolmogorov-Smirnov test, and the rejection-sampling
acceptance rates. Seeds are fixed, so the test is deterministic.
"""
from __future__ import annotations

import math
import random

import numpy as np
import pytest
from scipy.stats import ks_2samp

from crashscene.dsl import load_file
from crashscene.render import render
from crashscene.render.compiled_sampler import CompiledSampler
from crashscene.render.sample import SampleError, compile_program, sample_scenes, scene_seed, to_sampled_scene

from tests.conftest import EXAMPLES
from tests.render.test_render import CACHE

pytestmark = [pytest.mark.filterwarnings("ignore::UserWarning")]

# a 4-way approach, a curve with an oncoming car, three actors (follow + oncoming), four actors beside and behind,
# a T junction with a stop, a follower and an approach
CROSS_CHECK = ["100237", "108812", "105203", "3-C1-2017-001", "3-C2-2018-008"]
N_SCENIC = 300
N_COMPILED = 1500
P_MIN = 1e-3  # [-] smallest KS p-value accepted per compared quantity
COORDS = ("x", "y", "yaw", "speed", "length")


def _rendered(case, tmp_path):
    return render(load_file(EXAMPLES / case / "golden.yaml"), tmp_path, cache_dir=CACHE)


def _scenic_scenes(program, n, seed):
    """Scenic's scenes, as `sample_scenes(..., sampler="scenic")` draws them, and the attempts each took."""
    scenario = compile_program(program)
    py_state, np_state = random.getstate(), np.random.get_state()
    scenes, attempts = [], []
    try:
        for index in range(n):
            py_seed, np_seed = scene_seed(seed, index)
            random.seed(py_seed)
            np.random.seed(np_seed)
            scene, iterations = scenario.generate(maxIterations=2000, verbosity=0)
            scenes.append(to_sampled_scene(scene, index, seed, "", ""))
            attempts.append(iterations)
    finally:
        random.setstate(py_state)
        np.random.set_state(np_state)
    return scenes, np.asarray(attempts)


def _columns(scenes):
    cols: dict[str, list[float]] = {}
    for scene in scenes:
        for key, value in scene.params.items():
            if isinstance(value, float):
                cols.setdefault(f"param {key}", []).append(value)
        for actor in scene.actors:
            for c in COORDS:
                cols.setdefault(f"{actor.role}.{c}", []).append(getattr(actor, c))
    # Scenic stores headings as rotations, so equal angles come back a few ulps apart: rounded, atoms stay atoms
    return {k: np.round(np.asarray(v), 6) for k, v in cols.items()}


@pytest.mark.slow
@pytest.mark.parametrize("case", CROSS_CHECK)
def test_compiled_sampler_matches_scenic(case, tmp_path):
    r = _rendered(case, tmp_path)
    reference, scenic_attempts = _scenic_scenes(r.program, N_SCENIC, seed=11)
    compiled = CompiledSampler(r.program)
    ours = compiled.scenes(0, N_COMPILED, 12, "", "")

    # the same parameters (constants equal), actors in the same order with the same tokens
    ref0, our0 = reference[0], ours[0]
    assert list(our0.params) == list(ref0.params)
    for key, value in ref0.params.items():
        if not isinstance(value, float) or all(s.params[key] == value for s in reference):
            assert our0.params[key] == value, key
    assert [a.role for a in our0.actors] == [a.role for a in ref0.actors]
    for ra, oa in zip(ref0.actors, our0.actors):
        fixed = ("label", "type", "behavior", "route_intent", "reference", "relation", "heading_relation",
                 "dispositions")
        assert {f: getattr(oa, f) for f in fixed} == {f: getattr(ra, f) for f in fixed}
        assert {k: v for k, v in oa.properties.items() if k not in ("target_speed", "route_lanes")} == \
            {k: v for k, v in ra.properties.items() if k not in ("target_speed", "route_lanes")}
    # every start lane and route Scenic produced, the compiled sampler produces too (and vice versa, nearly)
    ref_lanes = {(a.role, a.properties["route_lanes"]) for s in reference for a in s.actors}
    our_lanes = {(a.role, a.properties["route_lanes"]) for s in ours for a in s.actors}
    assert ref_lanes <= our_lanes

    ref_cols, our_cols = _columns(reference), _columns(ours)
    assert set(ref_cols) == set(our_cols)
    failures = []
    for key, ref_values in sorted(ref_cols.items()):
        if np.ptp(ref_values) == 0 and np.ptp(our_cols[key]) == 0:
            assert ref_values[0] == pytest.approx(our_cols[key][0], abs=1e-9), key
            continue
        p = ks_2samp(ref_values, our_cols[key]).pvalue
        if p < P_MIN:
            failures.append(f"{key}: KS p = {p:.2g}")
    assert not failures, failures

    # acceptance rates of the rejection sampling agree (within 4 standard errors, plus a small absolute slack)
    ref_rate = N_SCENIC / scenic_attempts.sum()
    our_rate = N_COMPILED / compiled.last_attempts.sum()
    se = math.sqrt(ref_rate * (1 - ref_rate) / scenic_attempts.sum() + our_rate * (1 - our_rate)
                   / compiled.last_attempts.sum())
    assert abs(ref_rate - our_rate) <= 4 * se + 0.02, (ref_rate, our_rate)


@pytest.mark.parametrize("case", ["100237", "3-C5-2018-004"])
def test_compiled_scenes_depend_only_on_seed_and_index(case, tmp_path):
    r = _rendered(case, tmp_path)
    whole = sample_scenes(r.program, 300, seed=5)
    parts = sample_scenes(r.program, 120, seed=5) + sample_scenes(r.program, 180, seed=5, first=120)
    assert [s.model_dump_json() for s in parts] == [s.model_dump_json() for s in whole]
    again = sample_scenes(r.program, 300, seed=5)
    assert [s.model_dump_json() for s in again] == [s.model_dump_json() for s in whole]
    other = sample_scenes(r.program, 300, seed=6)
    assert [s.params["EGO_SPEED"] for s in other] != [s.params["EGO_SPEED"] for s in whole]
    assert [s.index for s in whole] == list(range(300))


def test_a_stale_or_missing_plan_is_refused(tmp_path):
    r = _rendered("120013", tmp_path)
    text = r.program.read_text(encoding="utf-8")
    r.program.write_text(text.replace("param cs_horizon = 20.0", "param cs_horizon = 30.0"), encoding="utf-8")
    with pytest.raises(SampleError, match="sampler.json.*re-render"):
        sample_scenes(r.program, 5, seed=0)
    (tmp_path / "sampler.json").unlink()
    with pytest.raises(SampleError, match="no compiled sampling plan.*--sampler scenic"):
        sample_scenes(r.program, 5, seed=0)
    with pytest.raises(SampleError, match="sampler 'numba' is not allowed"):
        sample_scenes(r.program, 5, seed=0, sampler="numba")


def test_rejected_attempts_are_redrawn_until_the_requirements_hold(tmp_path):
    """A follower placed 0-5 m (centre to centre) ahead of the ego overlaps it unless the draw separates them."""
    r = _rendered("109176", tmp_path)  # npc1 follows the ego, in front, on a straight road
    sampler = CompiledSampler(r.program)
    follower = next(a for a in sampler.actors if a["role"] == "npc1")
    assert follower["placement"] == "follow" and follower["along"] == "front"
    follower["gap"] = -15.0  # [m] npc1_INIT_DIST is drawn in [15, 20]
    scenes = sampler.scenes(0, 400, 3, "", "")
    acceptance = len(scenes) / sampler.last_attempts.sum()
    assert 0.0 < acceptance < 0.9
    for scene in scenes:
        ego, npc = scene.actors
        assert math.dist((ego.x, ego.y), (npc.x, npc.y)) >= 0.5 * (ego.length + npc.length) - 1e-6
    again = sampler.scenes(200, 200, 3, "", "")  # rejections do not break index determinism
    assert [s.model_dump_json() for s in again] == [s.model_dump_json() for s in scenes[200:]]


def test_a_scene_no_attempt_can_satisfy_is_a_clear_error(tmp_path):
    import shapely

    r = _rendered("120013", tmp_path)
    sampler = CompiledSampler(r.program)
    sampler.region = shapely.Polygon([(0, 0), (1, 0), (1, 1)])  # no car fits on this "road"
    with pytest.raises(SampleError, match=r"scene 7 \(seed 1\) could not be sampled.*30"):
        sampler.scenes(7, 2, 1, "", "", max_attempts=30)
