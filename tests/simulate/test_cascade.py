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
