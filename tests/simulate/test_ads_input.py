"""A hostile or careless ADS: it cannot change the simulator's state, and a bad action is named as its fault."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.backend import AdsError

from .conftest import crossing_scenes
from .test_embedded import YIELD_CASE, actor_trace, run

USER = "tests.simulate.user_ads"


def test_an_ads_writing_into_its_observation_does_not_change_the_state(four_way_map):
    scenes = crossing_scenes(four_way_map, 3)
    with pytest.raises(AdsError, match="ADS Vandal driving 'ego' at step 0.*read-only"):
        run(YIELD_CASE, scenes, four_way_map, mode="test", ads=f"{USER}:Vandal")
    honest = run(YIELD_CASE, scenes, four_way_map, mode="test", ads=f"{USER}:ConstantSpeed")
    sneaky = run(YIELD_CASE, scenes, four_way_map, mode="test", ads=f"{USER}:Sneaky")
    for v in range(3):
        for role in ("ego", "npc1"):
            assert np.array_equal(actor_trace(honest, v, role)["speed"], actor_trace(sneaky, v, role)["speed"])
            assert np.array_equal(actor_trace(honest, v, role)["x"], actor_trace(sneaky, v, role)["x"])
    assert actor_trace(sneaky, 0, "npc1")["speed"].max() > 1.0


@pytest.mark.parametrize("kind, field, words", [
    ("nan", "accel", ["nan", "variation 2"]),
    ("shape", "accel", ["shape (4,)", "(3,)"]),
    ("string", "accel", ["'fast'", "finite number"]),
    ("none", "accel", ["NoneType", "finite number"]),
    ("dict", "step()", ["returned dict", "Action"]),
    ("raise", "step()", ["raised ZeroDivisionError"]),
    ("offset", "lateral_offset", ["1e+06", "variation 0", "+-20 m"]),
])
def test_a_bad_action_names_the_ads_field_actor_step_and_variation(four_way_map, kind, field, words):
    scenes = crossing_scenes(four_way_map, 3)
    with pytest.raises(AdsError) as err:
        run(YIELD_CASE, scenes, four_way_map, mode="test", ads=f"{USER}:BadAction", ads_params={"kind": kind, "at": 5})
    message = str(err.value)
    assert "ADS BadAction driving 'ego' at step 5" in message
    assert field in message
    for word in words:
        assert word in message
    assert "golden.yaml" not in message
