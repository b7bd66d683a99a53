"""The contact after a cascade's later one (simulate.embedded.followon): where the fourth actor may drive, and the
state of a deflected car along its predicted path."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np
import pytest

from crashscene.simulate.embedded import cascade_plan
from crashscene.simulate.embedded.cascade import Push, pushes_moving
from crashscene.simulate.embedded.followon import (
    CORNERS,
    _apart,
    full,
    group_shifts,
    mover_states,
    option_key,
    shift_across,
    steady,
)
from crashscene.simulate.embedded.plan import VariationPlan
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


def test_mover_states_interpolate_the_pose_and_take_the_velocity_the_path_carries():
    t = np.arange(10) * 0.05
    paths = np.array([(10.0 * t, np.zeros(10), 0.5 * t, np.full(10, 10.0), np.zeros(10), np.full(10, 0.5)),
                      (np.zeros(10), 5.0 * t, np.full(10, 1.0), np.zeros(10), np.full(10, 5.0), np.zeros(10))])
    pose, motion = mover_states(paths, np.array([0, 1, 0, 1]), np.array([2.5, 2.5, -1.0, 20.0]))
    assert pose[:, 0] == pytest.approx((1.25, 0.0, 0.0625))
    assert motion[:, 0] == pytest.approx((10.0, 0.0, 0.5))
    assert pose[:, 1] == pytest.approx((0.0, 0.625, 1.0))
    assert pose[:, 2] == pytest.approx((0.0, 0.0, 0.0))  # clipped to the path
    assert pose[:, 3] == pytest.approx((0.0, 2.25, 1.0))  # ...at its end


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


def _drift_push(offset: float, approach: float, rate: float) -> Push:
    """A car drifting right at 28 m/s into a parked car's rear, `offset` of its width to its left (3-C1-2017-001's
    first contact, variation 20 at seed 7)."""
    return Push(28.16352, 0.0, np.array([offset]), 1500.0, 1500.0, 4.67, 1.81, 4.79, 2.16, 0.8,
                wheelbase_ratios=(0.6, 0.6), dt=0.1, approach=approach, approach_rate=rate, lead=0.0982)


def test_steady_tells_an_impact_that_throws_the_striker_either_way_on_a_hundredth_of_a_radian():
    # (approach: the heading at the touch; measured as -0.0246 and -0.0139 rad a step before it, when the
    # prediction started the striker at its approach heading: the drift turns it 0.0052 and 0.0041 rad further in
    # the 0.0982 s to the touch, cascade.pushes)
    items = [_drift_push(0.1005, -0.0298, -0.0527), _drift_push(0.3503, -0.0180, -0.0418)]
    found = pushes_moving(items)
    striker = tuple(np.concatenate([one[1][q] for one in found]) for q in range(2))
    # the nominal predictions: both strikers turned back left by the impact
    assert all(one[1][2][0][10] > 1.0 for one in found)
    # ...but the one into the corner turns the other way when it comes 0.01 rad more to the left
    assert pushes_moving([replace(items[1], approach=items[1].approach + 0.01)])[0][1][2][0][10] < 0.0
    assert steady(items, striker, True, [3, 3]) == [True, False]
    assert steady(items, striker, True, [3, None]) == [True, False]  # no meeting: not steady


def test_apart_starts_a_prediction_before_the_two_footprints_overlap():
    """The third car drives at 20 m/s along y = 0; the deflected car beside it at the same speed slides sideways (+y)
    at 3 m/s, its side 0.35 m into the third car's at the meeting step (k = 4 of its path, every 0.05 s; widths
    2 m): a simulator step (0.1 s) earlier it is still 0.05 m in; two steps earlier, 0.25 m apart: the prediction
    starts there, the third car 4 m back along its route."""
    tau = np.arange(40) * 0.05
    path = (100.0 + 20.0 * (tau - 0.2), -2.25 + 3.0 * tau, np.zeros(40), np.full(40, 20.0), np.full(40, 3.0),
            np.zeros(40))
    arrays = SimpleNamespace(point=lambda r, s: (s.astype(float), np.zeros(len(s)), np.zeros(len(s))))
    plan = SimpleNamespace(ctx=SimpleNamespace(arrays=arrays, skid_paths=SimpleNamespace(dt=0.1)),
                           route=np.array([0, 0]), d0=np.zeros(2), length=np.array([4.5, 4.5]),
                           width=np.array([2.0, 2.0]))
    far = tuple(q + np.array([0.0, 5.0, 0, 0, 0, 0])[i] for i, q in enumerate(path))  # 5 m further across: clear
    (lead, mover_pose, _, third_pose), clear = _apart(plan, 0, 1, [far, path], [(1, 4, 1.0, 100.0, 20.0),
                                                                                (0, 4, 1.0, 100.0, 20.0)])
    assert lead == pytest.approx(0.2)  # 1.0 s: a step boundary
    assert mover_pose == pytest.approx((96.0, -2.25, 0.0))
    assert third_pose == pytest.approx((96.0, 0.0, 0.0))
    assert clear[0] == pytest.approx(0.1)  # apart at the meeting step's own simulator step
    assert clear[1] == pytest.approx((98.0, 3.05, 0.0))


def test_option_key_ranks_a_steady_impact_then_the_sooner_meeting_below_the_written_classes():
    aimed = (3, True, 20.0)
    base = option_key(3, True, 3, True, 10, aimed, 5.0)
    assert option_key(3, True, 3, True, 4, aimed, 5.0) > base  # sooner
    assert option_key(3, True, 3, False, 4, aimed, 5.0) < base  # sooner, but not steady
    assert option_key(3, True, 2, True, 4, aimed, 5.0) < base  # sooner, but the next contact's class not robust
    assert option_key(3, True, 3, True, 10, (3, True, 25.0), 5.0) > base  # same time: the more central heading
    assert full(base) and not full(option_key(3, True, 3, False, 4, aimed, 5.0))
    # the fourth actor not aimed at the moving car (it cannot drive at its centre within its lane): not full
    assert not full(option_key(3, True, 3, True, 10, (3, False, 20.0), 5.0))


def test_option_key_ranks_the_written_classes_above_the_areas():
    # rules.md: the sequence (actors and classes) makes a reproduction, the areas are a separate figure: a
    # candidate whose deflected car meets the third with another face (later = 2: the class alone) but keeps the
    # next contact's class ranks above one with the written face whose next contact is another class (least = 1)
    aimed, lost = (3, True, 20.0), (1, True, -10.0)
    face_off = option_key(2, True, 3, True, 20, aimed, 5.0)
    face_on = option_key(3, True, 1, True, 4, lost, 5.0)
    assert face_off > face_on
    # ...but the later contact's class still comes first, and between equal classes the areas decide
    assert option_key(1, True, 3, True, 4, aimed, 5.0) < face_on
    assert option_key(3, True, 3, True, 20, aimed, 5.0) > face_off
    assert not full(face_off) and full(option_key(3, True, 3, True, 20, aimed, 5.0))


def test_the_corners_a_fourth_contact_tries_are_a_fine_grid_across_the_struck_cars_rear():
    steps = np.diff(CORNERS)
    assert CORNERS[0] == pytest.approx(0.05) and CORNERS[-1] == pytest.approx(0.6)
    assert steps == pytest.approx(np.full(len(steps), 0.025))


@dataclass
class _Plan:
    """The rows plan_cascade's alternatives change, and a start_back that always has room."""

    s0: np.ndarray
    d0: np.ndarray
    lateral_target: np.ndarray
    drifted: np.ndarray
    moved: np.ndarray
    speeds: np.ndarray
    ctx: object = None

    def start_back(self, a: int, dist: float) -> float:
        return float(self.s0[a] - dist)

    snapshot = VariationPlan.snapshot
    restore = VariationPlan.restore


def _alternatives(monkeypatch, keys: list[tuple]) -> tuple[_Plan, list[tuple[float, float]]]:
    """plan_cascade over a fake three-actor cascade (striker 0, struck 1, third 2; fourth 3) whose plans score
    `keys` in turn; returns the plan it leaves and each plan's (striker's start, the three's lateral shift)."""
    columns = [SimpleNamespace(behavior="go_forward")] * 4
    plan = _Plan(np.array([100.0, 130.0, 90.0, 50.0]), np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4, dtype=bool),
                 np.array([20.0, 0.0, 25.0, 25.0]), SimpleNamespace(columns=columns))
    tried, scores = [], iter(keys)

    def one_plan(plan, found):
        tried.append((float(plan.s0[0]), float(plan.d0[2])))
        plan.lateral_target[3] = len(tried)  # what this plan placed
        return next(scores)

    monkeypatch.setattr(cascade_plan, "_cascade_actors", lambda plan: (0, 1, 0, 2, "rear_end", ()))
    monkeypatch.setattr(cascade_plan.followon, "next_contact", lambda *a: SimpleNamespace(actor=3))
    monkeypatch.setattr(cascade_plan.followon, "group_shifts", lambda *a: [-3.5])
    monkeypatch.setattr(cascade_plan, "_plan_cascade", one_plan)
    cascade_plan.plan_cascade(plan)
    return plan, tried


def _key(least: int, steady: bool) -> tuple:
    return option_key(3, True, least, steady, 5, (3, True, 10.0), 5.0)


def test_a_fourth_contact_tries_the_three_a_lane_over_then_the_striker_further_back_until_one_has_it(monkeypatch):
    plan, tried = _alternatives(monkeypatch, [_key(2, True), _key(3, False), _key(2, True), _key(3, True),
                                              _key(0, False)])
    back = [0.025 * 20.0, 0.05 * 20.0]  # [m] NUDGES at the striker's 20 m/s
    # as placed, the three a lane over, then the striker nudged back from there (the better lane), until full
    assert tried == [(100.0, 0.0), (100.0, -3.5), (100.0 - back[0], -3.5), (100.0 - back[1], -3.5)]
    assert plan.lateral_target[3] == 4 and plan.s0[0] == 100.0 - back[1] and plan.moved[0]


def test_a_fourth_contact_keeps_the_best_plan_when_none_has_it(monkeypatch):
    plan, tried = _alternatives(monkeypatch, [_key(2, True), _key(3, False), _key(2, False), _key(0, False),
                                              _key(1, True)])
    assert len(tried) == 5
    assert plan.lateral_target[3] == 2 and plan.d0[2] == -3.5 and plan.s0[0] == 100.0 and not plan.moved[0]


def test_a_fourth_contact_planned_as_placed_is_kept(monkeypatch):
    plan, tried = _alternatives(monkeypatch, [_key(3, True)])
    assert tried == [(100.0, 0.0)] and plan.lateral_target[3] == 1


def test_touch_class_is_the_monitors_class_of_the_recorded_contact():
    """Two cars (4.8 x 2 m) 160 deg apart: touching front to front they are a head-on; 2.1 m apart across (front
    corners along each other's sides) they are side to side, a sideswipe, as monitor.collisions classifies them,
    the pair taken in actor order; a car struck 20 deg turned from behind is a rear-end, not the sideswipe the
    headings alone would allow."""
    from crashscene.simulate.embedded.followon import _later_match, touch_class

    plan = SimpleNamespace(length=np.full(4, 4.8), width=np.full(4, 2.0))
    turned = math.radians(160.0)
    assert touch_class(plan, 1, 0, (0.0, 0.0, 0.0, 4.655, -0.821, turned)) == "head_on"  # front corners meet
    assert touch_class(plan, 1, 0, (0.0, 0.0, 0.0, 4.0, 2.1, turned)) == "sideswipe"
    assert touch_class(plan, 0, 3, (4.0, 2.1, turned, 0.0, 0.0, 0.0)) == "sideswipe"
    behind = (0.0, 0.0, math.radians(20.0), 4.7, 0.0, 0.0)  # the third (actor 0) 4.7 m ahead of the mover
    assert touch_class(plan, 1, 0, behind) == "rear_end"
    meeting = (3, 10.0, "sideswipe", "left", 1.0, 5.0)  # a meeting read as the written sideswipe, on the area
    later = ("sideswipe", "left", "right")
    assert _later_match(plan, meeting, later, None, 1, 0) == 3
    assert _later_match(plan, meeting, later, (None, 0.0, None, behind), 1, 0) == 1
    side = (0.0, 0.0, 0.0, 0.5, 2.0, math.radians(15.0))
    assert touch_class(plan, 1, 0, side) == "sideswipe"
    assert _later_match(plan, meeting, later, (None, 0.0, None, side), 1, 0) == 3


@pytest.mark.parametrize("turned, across, klass", [(180, 0.0, "head_on"), (180, 1.5, "head_on"), (180, 2.5, None),
                                                    (160, -1.0, "head_on"), (160, 0.0, "head_on"),
                                                    (160, 1.0, "sideswipe"), (160, 3.0, None)])
def test_the_fourth_contact_is_classed_where_the_fourth_car_first_touches_the_moving_one(turned, across, klass):
    """A car (4.8 x 2 m) stopped facing back down the fourth car's route 50 m ahead of it, `turned` [deg] from the
    fourth car's heading; the fourth car at 20 m/s timed to meet it, `across` [m] to its right: anti-parallel,
    they meet end to end wherever they touch (a head-on), 2.5 m across they pass; turned 20 deg off (its front to
    the left), met 1 m to its right the fourth car's front corner meets its side first (a sideswipe for the
    monitor), 1 m to its left its front."""
    from crashscene.simulate.embedded.followon import Next, _met

    arrays = SimpleNamespace(point=lambda r, s: (s.astype(float), np.zeros(len(s)), np.zeros(len(s))))
    plan = SimpleNamespace(ctx=SimpleNamespace(arrays=arrays), route=np.array([0, 0]), s0=np.zeros(2),
                           d0=np.zeros(2), speeds=np.array([0.0, 20.0]), length=np.full(2, 4.8), width=np.full(2, 2.0))
    rel = math.radians(turned)
    path = (np.full(40, 50.0), np.full(40, across), np.full(40, rel))
    extent = 2.4 * abs(math.sin(rel)) + 1.0 * abs(math.cos(rel))  # [m] its half extent across the route
    meeting = (20, 50.0, "head_on", "front", extent, 10.0)  # at step 20 its centre 50 m along the route
    nxt = Next(1, 0, ("head_on", "front", "front"))
    assert _met(plan, nxt, [path], [(0.0, meeting, True)])[0][1][2] == klass
