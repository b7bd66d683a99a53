"""Where a third actor meets a car an impact sets moving (simulate.embedded.meetings): the nearest route points of
many paths at once, and every path's meeting measured with the others as it is alone."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from crashscene.simulate.embedded.meetings import (
    NEAR_ROUTE,
    along_route,
    meetings_along,
    nearest_within,
    pushed_meetings,
    route_nearest,
)
from crashscene.simulate.embedded.stations import relative_to_route


def _argmin(points: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    dist = np.hypot(points[None, :, 0] - x[:, None], points[None, :, 1] - y[:, None])
    nearest = np.argmin(dist, axis=1)
    return nearest, dist[np.arange(len(x)), nearest]


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.parametrize("reach", [3.0, 8.0, 1e3])
def test_nearest_within_is_argmin_of_every_distance_where_it_is_within_reach(seed, reach):
    rng = np.random.default_rng(seed)
    if seed % 2:  # a curving route, its points in order
        s = np.arange(int(rng.integers(1, 400))) * 0.5
        points = np.round(np.stack([40 * np.sin(s / 40), 40 * np.cos(s / 40) - 40 + 0.001 * s], axis=1), 3)
    else:  # points anywhere, in no order
        points = np.round(rng.normal(0, 20, (int(rng.integers(1, 300)), 2)), int(rng.integers(0, 3)))
    if seed % 3 == 0:
        points = np.concatenate([points, points])  # exact ties: the first one
    n = int(rng.integers(1, 90))
    x, y = np.round(rng.normal(0, 20, n), 1), np.round(rng.normal(0, 20, n), 1)
    if seed % 7 == 0:
        x[0] = np.nan  # no distance: never within reach
    want, want_dist = _argmin(points, x, y)
    got, got_dist = nearest_within(points, x, y, reach)
    within = want_dist <= reach
    assert np.array_equal(got[within], want[within])
    assert np.array_equal(got_dist[within], want_dist[within])
    assert np.all(~(got_dist[~within] <= reach))


def test_route_nearest_measures_each_path_near_the_route_and_none_of_a_path_with_a_nan_point():
    route = np.stack([np.arange(0.0, 300.0, 0.5), np.zeros(600)], axis=1)
    x = np.array([10.0, 10.2, 50.0, 120.0, 120.4, 200.0, 200.0])
    y = np.array([1.0, 30.0, -7.9, 2.0, np.nan, 3.0, 9.0])
    index, dist = route_nearest(route, x, y, [3, 2, 2])
    assert index[[0, 2, 5]].tolist() == [20, 100, 400]
    assert dist[[0, 2, 5]] == pytest.approx([1.0, 7.9, 3.0])
    assert np.all(dist[[1, 6]] > NEAR_ROUTE)  # too far from the route to meet a car on it
    assert np.all(np.isinf(dist[[3, 4]]))  # a NaN point: its path is not measured


def _plan_on_straight_road():
    """A fake plan: actor 1 (the third, 4.5 m x 1.8 m) starts at station 20 m of a straight route along x; actor 0
    is the moving car."""
    xy = np.stack([np.arange(0.0, 400.0, 0.5), np.zeros(800)], axis=1)[None]
    def point(r, s):
        s = np.asarray(s, dtype=float)
        return s, np.zeros(s.shape), np.zeros(s.shape)
    arrays = SimpleNamespace(xy=xy, yaw=np.zeros((1, 800)), point=point)
    return SimpleNamespace(ctx=SimpleNamespace(arrays=arrays), route=np.array([0, 0]), s0=np.array([0.0, 20.0]),
                           d0=np.array([0.0, 0.0]), length=np.array([4.5, 4.5]), width=np.array([1.8, 1.8]),
                           lane_width=3.5, draws=SimpleNamespace(cascade=np.array([0.0, 0.4])))


@pytest.mark.parametrize("later", [("sideswipe", "right", "left"), ("angle", "left", "front"),
                                   ("head_on", "front", "front")])
def test_pushed_meetings_measures_every_path_with_the_others_as_alone(later):
    rng = np.random.default_rng(3)
    plan = _plan_on_straight_road()
    t = np.arange(80) * 0.05
    paths, poses = [], []
    for _ in range(12):  # cars sliding across the third car's route from either side, turning
        paths.append((rng.uniform(5, 25) * t, rng.uniform(-4, 4) * t, rng.uniform(-2, 2) * t))
        poses.append((rng.uniform(40, 120), rng.uniform(-6, 6), rng.uniform(-np.pi, np.pi)))
    paths.append((t + 1e3, t, t))  # nowhere near the route
    poses.append((0.0, 0.0, 0.0))
    together = pushed_meetings(plan, 0, 1, paths, poses, later)
    alone = [pushed_meetings(plan, 0, 1, [p], [q], later)[0] for p, q in zip(paths, poses)]
    assert together == alone
    assert together[-1] is None and sum(m is not None for m in together) >= 6


def test_paths_measured_along_a_route_once_meet_the_third_actor_wherever_it_starts_across_it():
    """`along_route` holds nothing of where across its route the third actor starts: `meetings_along` of it after the
    third actor moves a lane across is `pushed_meetings` there."""
    plan = _plan_on_straight_road()
    t = np.arange(80) * 0.05
    paths = [(20.0 * t, -3.0 * t, -0.5 * t), (15.0 * t, 3.0 * t, 0.4 * t), (18.0 * t, 2.0 * t, 0.0 * t)]
    poses = [(60.0, 4.0, 0.0), (60.0, -4.0, 0.0), (40.0, 1.0, 0.3)]
    later = ("sideswipe", "right", "left")
    measured = along_route(plan, 0, 1, paths, poses)
    seen = set()
    for shift in (0.0, 3.5, -3.5):
        plan.d0[1] = shift
        found = meetings_along(plan, 1, measured, later)
        assert found == pushed_meetings(plan, 0, 1, paths, poses, later)
        seen.add(tuple(m is not None for m in found))
    assert len(seen) > 1  # where it starts across its route changes which paths meet it


def test_a_paths_lateral_offset_along_a_route_is_the_one_relative_to_route_measures():
    """On a route curving left (radius 60 m), each path point within NEAR_ROUTE of it is as far left of it as
    stations.relative_to_route has it, to the bit."""
    s = np.arange(0.0, 200.0, 0.5)
    xy = np.stack([60 * np.sin(s / 60), 60 - 60 * np.cos(s / 60)], axis=1)[None]

    def point(r, at):
        at = np.asarray(at, dtype=float)
        return 60 * np.sin(at / 60), 60 - 60 * np.cos(at / 60), at / 60

    plan = _plan_on_straight_road()
    plan.ctx.arrays = SimpleNamespace(xy=xy, yaw=(s / 60)[None], point=point)
    t = np.arange(80) * 0.05
    paths = [(15.0 * t, 4.0 * t - 5.0, 0.1 * t), (30.0 + 10.0 * t, 9.0 - 2.0 * t, 0.0 * t)]
    measured = along_route(plan, 0, 1, paths, [(0.0, 0.0, 0.0)] * 2)
    checked = 0
    for j, (x, y, _) in enumerate(paths):
        for k in range(len(x)):
            lateral = measured.lateral(j, k)
            if np.isfinite(lateral):
                assert lateral == relative_to_route(plan.ctx.arrays, 0, 20.0, float(x[k]), float(y[k]))[1]
                checked += 1
    assert checked > 50
