"""Later contacts of a written crash sequence (simulate.embedded.later): which contacts a driven actor is timed
to, the slide they are predicted with, and the same bytes for the same seed on a cascade."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from crashscene.dsl import loads
from crashscene.pipeline.simulate import simulate_scenario
from crashscene.simulate.embedded import impact
from crashscene.simulate.embedded.cascade import slide_path
from crashscene.simulate.embedded.later import BRAKE, LaterContact, later_contacts, station_profile
from crashscene.units import G

ROLES = ["ego", "npc1", "npc2", "npc3"]


def test_a_chain_times_each_later_contact_to_the_vehicle_sliding_by_then():
    # a truck rear-ends npc2, then ego; ego, pushed, rear-ends npc3 (3-C1-2018-003's sequence)
    seq = (("npc1", "npc2", "rear_end", "front", "rear"), ("npc1", "ego", "rear_end", "front", "rear"),
           ("ego", "npc3", "rear_end", "front", "rear"))
    got = later_contacts(seq, ROLES, [True] * 4)
    assert got == [LaterContact(free=1, driven=0, klass="rear_end", area_free="front", area_driven="rear"),
                   LaterContact(free=0, driven=3, klass="rear_end", area_free="front", area_driven="rear")]


def test_no_timing_for_the_first_contact_a_same_pair_recontact_or_an_actor_that_cannot_drive():
    first = ("ego", "npc1", "angle", "front", "right")
    assert later_contacts((first,), ROLES, [True] * 4) == []
    assert later_contacts((first, ("ego", "npc1", "sideswipe", "left", "right")), ROLES, [True] * 4) == []
    pushed = ("npc2", "npc1", "angle", "front", "left")
    assert later_contacts((first, pushed), ROLES, [True, True, False, True]) == []
    assert later_contacts((first, pushed), ROLES, [True] * 4) == [LaterContact(1, 2, "angle", "left", "front")]


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


def test_station_profile_slows_at_the_drivers_rate_and_holds_the_target():
    s = station_profile(np.array([0.0]), np.array([10.0]), np.array([[10.0, 4.0]]), 2.0, 0.1, 40)
    assert s[0, 0, -1] == pytest.approx(40.0)
    ramp = (10.0 - 4.0) / BRAKE  # [s]
    expected = (10.0 + 4.0) / 2 * ramp + 4.0 * (4.0 - ramp)
    assert s[0, 1, -1] == pytest.approx(expected, abs=0.05)


@pytest.mark.slow
def test_a_cascade_gives_the_same_bytes_for_the_same_seed(tmp_path):
    from tests.simulate.test_reproduce_configurations import CASCADE

    for name in ("a", "b"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scenario(loads(CASCADE), tmp_path / name, 4, 7, mode="reproduce")
    for name in ("traces", "collisions", "variations"):
        assert (tmp_path / "a" / f"{name}.parquet").read_bytes() == (tmp_path / "b" / f"{name}.parquet").read_bytes()
