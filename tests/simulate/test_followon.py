"""The contact after a cascade's later one (simulate.embedded.followon): where the fourth actor may drive, and the
state of a deflected car along its predicted path."""
from __future__ import annotations

import functools
from types import SimpleNamespace

import numpy as np
import pytest

from crashscene.simulate.embedded.followon import group_shifts, mover_state, shift_across
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


def _four_lanes(actor_lanes: list[int], behaviors: list[str]):
    """A fake plan on a straight road of four same-direction lanes 3.5 m apart (lane i's centre at y = 3.5 i, one
    route per lane), its actors at x = 0 in `actor_lanes`."""
    xy = np.stack([np.stack([np.arange(0.0, 200.0, 1.0), np.full(200, 3.5 * i)], axis=1) for i in range(4)])
    arrays = SimpleNamespace(xy=xy, yaw=np.zeros((4, 200)), lane=np.repeat(np.arange(4)[:, None], 200, axis=1))
    table = np.array([[3 - i, i] for i in range(4)])  # same-direction lanes on the left, on the right of lane i
    n = len(actor_lanes)
    return SimpleNamespace(
        ctx=SimpleNamespace(arrays=arrays, lanes_beside=table,
                            columns=[SimpleNamespace(behavior=b) for b in behaviors]),
        scene=SimpleNamespace(actors=[SimpleNamespace(x=0.0, y=3.5 * i) for i in actor_lanes]),
        route=np.array(actor_lanes), s0=np.zeros(n), d0=np.zeros(n), lateral_target=np.zeros(n),
        drifted=np.zeros(n), lane_width=3.5)


@pytest.mark.parametrize("lanes, shifts", [
    ([1, 1, 2, 3], [-3.5]),  # the third car one lane right of the fourth: the three may move one lane right
    ([0, 0, 1, 2], []),  # the striker and the struck car already in the rightmost lane: no room
    ([0, 0, 1, 3], []),
    ([1, 1, 2, 0], [3.5]),  # the fourth car on the third's right: the three move left (one lane: the third has one)
])
def test_group_shifts_move_the_cascade_away_from_the_fourth_car_as_far_as_every_one_has_a_lane(lanes, shifts):
    plan = _four_lanes(lanes, ["leave_road", "static", "go_forward", "go_forward"])
    assert group_shifts(plan, 3, (0, 1, 2)) == pytest.approx(shifts)


def test_shift_across_moves_starts_and_lane_targets_but_not_the_road_edge_a_driver_leaves_for():
    plan = _four_lanes([1, 1, 2, 3], ["leave_road", "static", "go_forward", "go_forward"])
    plan.lateral_target[:] = [-5.0, 0.0, 0.0, 0.0]
    shift_across(plan, (0, 1, 2), -3.5)
    assert plan.d0.tolist() == [-3.5, -3.5, -3.5, 0.0]
    assert plan.drifted.tolist() == [-3.5, -3.5, -3.5, 0.0]
    assert plan.lateral_target.tolist() == [-5.0, -3.5, -3.5, 0.0]  # the road's edge stays where it is
