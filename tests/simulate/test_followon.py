"""The contact after a cascade's later one (simulate.embedded.followon): where the fourth actor may drive, and the
state of a deflected car along its predicted path."""
from __future__ import annotations

import functools
from types import SimpleNamespace

import numpy as np
import pytest

from crashscene.simulate.embedded.followon import mover_state
from crashscene.simulate.embedded.setup import lanes_beside
from crashscene.simulate.roads import RoadMap


def test_lanes_beside_counts_the_same_direction_lanes_on_each_side():
    def lane(uid, left, right):
        return SimpleNamespace(uid=uid, left=left, right=right)

    lanes = [lane("l1", "l2", None), lane("l2", "l3", "l1"), lane("l3", "l4", "l2"), lane("l4", None, "l3"),
             lane("o1", None, None)]  # an opposing lane: no same-direction neighbours (laneToLeft may be oncoming)
    roadmap = SimpleNamespace(lanes=lanes, by_uid={x.uid: x for x in lanes})
    roadmap.side_lanes = functools.partial(RoadMap.side_lanes, roadmap)  # the real walk over the fake map
    assert lanes_beside(roadmap).tolist() == [[3, 0], [2, 1], [1, 2], [0, 3], [0, 0]]


def test_mover_state_interpolates_the_pose_and_takes_the_velocity_the_path_carries():
    t = np.arange(10) * 0.05
    path = (10.0 * t, np.zeros(10), 0.5 * t, np.full(10, 10.0), np.zeros(10), np.full(10, 0.5))
    pose, motion = mover_state(path, 2.5)
    assert pose == pytest.approx((1.25, 0.0, 0.0625))
    assert motion == pytest.approx((10.0, 0.0, 0.5))
    assert mover_state(path, -1.0)[0] == pytest.approx((0.0, 0.0, 0.0))  # clipped to the path
