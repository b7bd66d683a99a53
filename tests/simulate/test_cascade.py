"""The slide after an impact as the cascade plan predicts it (simulate.embedded.cascade.slide_path), and the same
bytes for the same seed on a cascade."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from crashscene.dsl import loads
from crashscene.pipeline.simulate import simulate_scenario
from crashscene.simulate.embedded import impact
from crashscene.simulate.embedded.cascade import slide_path
from crashscene.units import G


@pytest.mark.parametrize("friction", [0.4, 0.8])
def test_slide_path_rolls_and_slides_to_rest_at_the_simulators_rates(friction):
    dt, steps = 0.01, 1200
    v = np.array([10.0, 6.0])
    # the first car rolls straight on, the second slides sideways (its heading across its velocity)
    x, y, yaw = slide_path(np.zeros(2), np.zeros(2), np.array([0.0, np.pi / 2]), v * [1, 1], np.zeros(2),
                           np.zeros(2), friction, np.full(2, 4.5), np.full(2, 1.8), dt, steps)
    roll = impact.ROLL_FRACTION * friction * G
    assert x[0, -1] == pytest.approx(v[0] ** 2 / (2 * roll), rel=0.02)
    assert x[1, -1] == pytest.approx(v[1] ** 2 / (2 * friction * G), rel=0.02)
    assert np.abs(y).max() < 1e-9 and np.all(yaw[:, -1] == yaw[:, 0])


@pytest.mark.slow
def test_a_cascade_gives_the_same_bytes_for_the_same_seed(tmp_path):
    from tests.simulate.test_reproduce_configurations import CASCADE

    for name in ("a", "b"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scenario(loads(CASCADE), tmp_path / name, 4, 7, mode="reproduce")
    for name in ("traces", "collisions", "variations"):
        assert (tmp_path / "a" / f"{name}.parquet").read_bytes() == (tmp_path / "b" / f"{name}.parquet").read_bytes()


def test_touch_again_flags_a_striker_that_catches_up_with_the_car_it_pushed():
    from crashscene.simulate.embedded.cascade import DT, SEPARATE_STEPS, touch_again

    t = np.arange(40) * DT
    struck = (np.stack([2.0 * t, 2.0 * t]), np.zeros((2, 40)), np.zeros((2, 40)))
    # both strikers start touching its rear; the first keeps coming faster, the second falls back
    striker = (np.stack([-4.45 + 6.0 * t, -4.45 - 1.0 * t]), np.zeros((2, 40)), np.zeros((2, 40)))
    again = touch_again(struck, striker, 4.5, 1.8, 4.5, 1.8)
    assert not again[:, :SEPARATE_STEPS].any()
    assert again[0, -1] and np.all(np.diff(again[0].astype(int)) >= 0)  # once touched, it stays so
    assert not again[1].any()


def test_pushed_paths_gives_the_strikers_slide_from_where_it_struck():
    from crashscene.simulate.embedded.cascade import pushed_paths

    offsets = np.array([-0.4, 0.4])
    alone = pushed_paths(20.0, 0.0, offsets, 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8)
    struck, (x, y, yaw) = pushed_paths(20.0, 0.0, offsets, 1500.0, 1500.0, 4.5, 1.8, 4.5, 1.8, 0.8, striker=True)
    for a, b in zip(alone, struck):
        assert np.array_equal(a, b)
    # the striker came from behind, slowed by the impact: it stays behind the struck car's centre, off its line
    assert np.all(x < struck[0]) and np.all(np.sign(y[:, 0]) == np.sign(offsets))
    assert np.all(np.diff(x, axis=1) >= -1e-9)
