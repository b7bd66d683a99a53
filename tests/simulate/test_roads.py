"""Routes and lookups from Scenic's parsed road network (crashscene.simulate.roads)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scenariogeneration import xodr

from crashscene.simulate.backend import SimulationError
from crashscene.simulate.embedded.stations import bent_frames
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS, Lane, RoadMap, heading_near

from .conftest import LANE, TOWN02


def test_four_way_lanes_and_manoeuvres(four_way_map):
    roadmap = RoadMap.load(four_way_map)
    lane = roadmap.by_uid["road1_lane0"]
    assert lane.junction is None and lane.left is None  # the lane to its left runs the other way
    assert lane.opposite == "road1_lane1"
    assert lane.centerline_offset == pytest.approx(LANE / 2, abs=0.05)
    assert sorted(m[0] for m in lane.maneuvers) == ["left", "right", "straight"]


@pytest.mark.parametrize("intent, end_heading", [("straight", 0.0), ("left", math.pi / 2), ("right", -math.pi / 2)])
def test_route_takes_the_intended_manoeuvre(four_way_map, intent, end_heading):
    roadmap = RoadMap.load(four_way_map)
    route = roadmap.route("road1_lane0", intent)
    assert len(route.entries) == 1 and route.entries[0].maneuver == intent
    assert route.entries[0].s == pytest.approx(150.0, abs=1.0)
    assert math.cos(route.yaw[-1] - end_heading) > 0.99
    assert np.all(np.hypot(*np.diff(route.xy, axis=0).T) < ROUTE_DS + 1e-6)
    inside = route.junction >= 0
    assert inside.any() and not inside[0] and not inside[-1]
    # lanes along the route: the approach lane, a connecting lane, the exit lane
    names = [roadmap.lanes[i].uid for i in dict.fromkeys(route.lane.tolist())]
    assert names[0] == "road1_lane0" and roadmap.lanes[route.lane[-1]].junction is None and len(names) == 3


def test_project_and_lookup(four_way_map):
    roadmap = RoadMap.load(four_way_map)
    route = roadmap.route("road1_lane0", "straight")
    s, d = route.local_coordinates(np.array([50.0, 80.0]), np.array([0.0, -3.5]))
    assert s == pytest.approx([50.0, 80.0], abs=0.01) and d == pytest.approx([LANE / 2, LANE / 2 - 3.5], abs=0.01)
    lane, junction = roadmap.lookup(np.array([50.0, 50.0, 162.0, 50.0]), np.array([-1.75, 1.75, 0.0, 30.0]))
    assert [roadmap.lanes[k].uid if k >= 0 else None for k in lane[[0, 1, 3]]] == ["road1_lane0", "road1_lane1", None]
    assert junction[2] >= 0 and junction[0] == -1
    assert roadmap.lane_at(50.0, 1.75, math.pi).uid == "road1_lane1"


def test_town02_parses_with_signals_and_routes():
    roadmap = RoadMap.load(TOWN02)
    assert len(roadmap.lanes) > 50 and any(j.signalised for j in roadmap.junctions)
    route = roadmap.route(roadmap.lanes[0].uid, "right", min_length=300)
    assert route.length >= 300 and route.entries


def test_centre_line_marker_is_read_from_the_file(straight_map):
    assert RoadMap.load(straight_map).by_uid["road1_lane0"].marker == "double_solid_line"


def test_missing_map_is_a_clear_error(tmp_path):
    with pytest.raises(SimulationError, match="map file not found"):
        RoadMap.load(tmp_path / "nope.xodr")


def test_route_arrays_local_coordinates_inverts_point(four_way_map):
    roadmap = RoadMap.load(four_way_map)
    arrays = RouteArrays.pack([roadmap.route("road1_lane0", "left"), roadmap.route("road1_lane0", "straight")])
    r = np.array([0, 0, 1, 1])
    s = np.array([20.0, 57.3, 33.3, 140.0])
    d = np.array([0.8, -1.2, 0.0, 1.5])
    x, y, yaw = arrays.point(r, s)
    px, py = x - np.sin(yaw) * d, y + np.cos(yaw) * d
    got_s, got_d, got_yaw = arrays.local_coordinates(r, px, py, s + 1.5)
    assert got_s == pytest.approx(s, abs=0.05) and got_d == pytest.approx(d, abs=0.05)
    assert np.cos(got_yaw - yaw) == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("shape", ["wave", "spiral", "duplicates", "scatter"])
def test_locate_on_line_gives_geos_own_floats(shape):
    """`locate_on_line` prunes the segments it walks; its stations are still GEOS's, bit for bit: on curves,
    on a spiral that comes back near itself, with repeated vertices, and for points on vertices and mid-segment."""
    import shapely

    from crashscene.simulate.roads import locate_on_line

    rng = np.random.default_rng(["wave", "spiral", "duplicates", "scatter"].index(shape))
    for _ in range(20):
        k = int(rng.integers(2, 300))
        t = np.cumsum(rng.uniform(0.0, 0.6, k))
        xy = {"wave": lambda: np.stack([t, np.sin(t / 7) * 5], 1),
              "spiral": lambda: np.stack([np.cos(t / 5) * (10 + t / 20), np.sin(t / 5) * (10 + t / 20)], 1),
              "duplicates": lambda: np.stack([np.round(t, 1), np.zeros(k)], 1)[np.sort(rng.integers(0, k, k))],
              "scatter": lambda: rng.normal(0.0, 5.0, (k, 2))}[shape]() + rng.normal(0.0, 300.0)
        points = xy[rng.integers(0, k, 700)] + rng.normal(0.0, rng.choice([0.01, 0.5, 3.0, 30.0]), (700, 2))
        points[:30] = xy[rng.integers(0, k, 30)]
        points[30:60] = ((xy[:-1] + xy[1:]) / 2)[rng.integers(0, max(k - 1, 1), 30)]
        want = shapely.line_locate_point(shapely.LineString(xy), shapely.points(points[:, 0], points[:, 1]))
        np.testing.assert_array_equal(locate_on_line(xy, points[:, 0], points[:, 1]), want)


def _travel_time_by_full_profile(arrays, r, s0, s1, speed, lat_accel, v0=None, accel=2.5, decel=2.0):
    """`RouteArrays.travel_time` as first written: the curvature read with a slice, every profile (K x K)."""
    if s1 <= s0:
        return 0.0
    k0, k1 = int(s0 / ROUTE_DS), min(int(np.ceil(s1 / ROUTE_DS)), arrays.curvature.shape[1] - 1)
    if k1 <= k0:
        return (s1 - s0) / max(speed, 0.5)
    speed = max(speed, 0.5)
    if (v0 is None or v0 >= speed - 1e-9) and \
            speed ** 2 * float(np.abs(arrays.curvature[r, k0:k1 + 1]).max()) <= lat_accel:
        return (s1 - s0) / speed
    kappa = np.abs(arrays.curvature[r, k0:k1 + 1]).copy()
    if len(kappa) > 4:
        kappa = np.concatenate([kappa, np.full((-len(kappa)) % 4, kappa[-1])]).reshape(-1, 4).max(axis=1)
        ds = ROUTE_DS * 4
    else:
        ds = ROUTE_DS
    v_lim2 = np.minimum(speed ** 2, lat_accel / np.maximum(kappa, 1e-4))
    dist = np.arange(len(kappa)) * ds
    gap = dist[None, :] - dist[:, None]
    ahead = np.where(gap >= 0, v_lim2[None, :] + 2 * decel * gap, np.inf).min(axis=1)
    behind = np.where(gap <= 0, ahead[None, :] - 2 * accel * gap, np.inf).min(axis=1)
    v2 = np.minimum(ahead, behind)
    if v0 is not None:
        v2 = np.minimum(v2, max(v0, 0.0) ** 2 + 2 * accel * dist)
    v = np.maximum(np.sqrt(v2), 1.0)
    if len(v) < 2:
        return (s1 - s0) / float(v[0])
    return float(np.sum(ds / (0.5 * (v[1:] + v[:-1])))) * (s1 - s0) / (dist[-1] if dist[-1] > 0 else 1.0)


def test_travel_time_takes_its_shortcuts_without_changing_a_bit(four_way_map):
    """The sparse-table curvature maximum and the skipped profile where no curve limits the speed give the same
    floats as reading every sample and building every profile: on a turn and a straight, from rest and at speed."""
    roadmap = RoadMap.load(four_way_map)
    arrays = RouteArrays.pack([roadmap.route("road1_lane0", "left"), roadmap.route("road1_lane0", "straight")])
    rng = np.random.default_rng(4)
    length = arrays.curvature.shape[1] * ROUTE_DS
    shortcuts = 0
    for _ in range(3000):
        r = int(rng.integers(0, 2))
        s0 = float(rng.uniform(0.0, length))
        s1 = s0 + float(rng.choice([0.3, rng.uniform(0.0, 3.0), rng.uniform(0.0, 200.0)]))
        speed, lat = float(rng.uniform(0.0, 25.0)), float(rng.choice([1.5, 2.5, 4.0]))
        v0 = rng.choice([None, 0.0, float(rng.uniform(0.0, speed + 2.0))])
        got = arrays.travel_time(r, s0, s1, speed, lat, v0=v0)
        assert got == _travel_time_by_full_profile(arrays, r, s0, s1, speed, lat, v0=v0), (r, s0, s1, speed, lat, v0)
        shortcuts += v0 is not None and v0 < speed
    assert shortcuts > 500


def test_curve_lookahead_gives_the_samples_last_gathers_floats(four_way_map):
    """curve_lookahead (samples on the first axis, the curve speed read from a table, a constant where no route of
    the batch curves) equals the plain formula: each (route, station, speed)'s 12 samples ahead gathered, |curvature|
    limited to 1e-4, reduced on the last axis; on every shape the simulator and the plans call it with."""
    roadmap = RoadMap.load(four_way_map)
    turning = RouteArrays.pack([roadmap.route("road1_lane0", "left"), roadmap.route("road1_lane0", "straight")])
    straight = RouteArrays.pack([roadmap.route("road1_lane0", "straight")])
    assert not np.any(straight.curvature)
    rng = np.random.default_rng(5)
    curved = 0
    for arrays in (turning, straight):
        n_k, n_r = arrays.curvature.shape[1], arrays.curvature.shape[0]
        for shape in [(2, 700), (3,), ()]:
            r = rng.integers(0, n_r, shape)
            s = rng.uniform(-5.0, n_k * ROUTE_DS + 50.0, shape)
            v = rng.choice([0.0, 3.0, 14.2, 31.0], shape)
            near = np.maximum(20.0, 3.0 * v)
            dist = (near + v * v / 4.0)[..., None] * np.linspace(0.0, 1.0, 12)
            k = np.clip((s[..., None] + dist) / ROUTE_DS, 0.0, n_k - 1).astype(np.int64)
            kappa = np.abs(arrays.curvature[r[..., None], k])
            curvature, speed = arrays.curve_lookahead(r, s, v)
            want = (np.where(dist <= near[..., None], kappa, 0.0).max(axis=-1),
                    np.sqrt(np.min(2.5 / np.maximum(kappa, 1e-4) + 4.0 * dist, axis=-1)))
            assert np.array_equal(curvature, want[0]) and np.array_equal(speed, want[1])
            assert np.shape(curvature) == np.shape(want[0]) and np.shape(speed) == np.shape(want[1])
            curved += int(np.count_nonzero(curvature > 0))
    assert curved > 100  # the turn's curve was looked at


@pytest.mark.parametrize("apart, meets", [(0.3, True), (0.45, True), (0.55, False), (3.5, False)])
def test_routes_that_never_cross_meet_where_they_come_within_the_merge_tolerance(apart, meets):
    """Two routes that never cross meet (a merge) where one first comes within MERGE_TOLERANCE of the other; the
    tolerance is tested with an indexed distance (shapely.dwithin on prepared lines), not the full distance."""
    from types import SimpleNamespace

    from crashscene.simulate.embedded.world import MERGE_TOLERANCE, _conflicts

    s = np.arange(0.0, 400.0, ROUTE_DS)
    gap = np.where(s < 200.0, 5.0, apart)  # the second lane closes in to `apart` from 200 m on
    routes = [SimpleNamespace(xy=np.c_[s, np.zeros_like(s)], yaw=np.zeros_like(s), key=("lane_a",)),
              SimpleNamespace(xy=np.c_[s, gap + 0.02 * np.sin(s)], yaw=np.zeros_like(s), key=("lane_b",))]
    conflict_s, angle = _conflicts(routes)
    assert (apart < MERGE_TOLERANCE) == meets
    if meets:
        assert 199.0 <= conflict_s[0, 1] <= 201.0 and 199.0 <= conflict_s[1, 0] <= 206.0  # b jogs in by 4.5 m
    else:
        assert np.isnan(conflict_s).all() and np.isnan(angle).all()


def test_point_reads_the_step_table_with_the_interpolations_floats(four_way_map):
    """point interpolates x + dx u from a table of steps to the next sample: the floats of x0 + (x1 - x0) u with the
    samples read directly (and yaw_at is point's yaw), on and past both ends of the routes."""
    roadmap = RoadMap.load(four_way_map)
    arrays = RouteArrays.pack([roadmap.route("road1_lane0", "left"), roadmap.route("road1_lane0", "straight")])
    rng = np.random.default_rng(6)
    n_k = arrays.xy.shape[1]
    r = rng.integers(0, 2, (3, 500))
    s = rng.uniform(-10.0, n_k * ROUTE_DS + 10.0, r.shape)
    f = np.clip(s * (1.0 / ROUTE_DS), 0.0, n_k - 1.000001)
    k = f.astype(np.int64)
    u = f - k
    want = [q0 + (q1 - q0) * u for q0, q1 in ((arrays.xy[r, k, i], arrays.xy[r, k + 1, i]) for i in (0, 1))]
    x, y, yaw = arrays.point(r, s)
    assert np.array_equal(x, want[0]) and np.array_equal(y, want[1]) and np.array_equal(yaw, arrays.yaw[r, k])
    assert np.array_equal(arrays.yaw_at(r, s), yaw)


@pytest.mark.parametrize("per_side", [1, 2, 3, 7])
def test_every_lane_knows_its_distance_to_the_centre_line(tmp_path, per_side):
    # Scenic 3.1 builds a backward lane group's left edge from its lanes in the wrong order: with three lanes or more
    # it runs through the group (7 a side: the inner westbound lane read 15.75 m from the centre line, so a driver
    # crossing it aimed four lanes too far)
    road = xodr.create_road(xodr.Line(300.0), id=1, left_lanes=per_side, right_lanes=per_side, lane_width=LANE)
    odr = xodr.OpenDrive("wide")
    odr.add_road(road)
    odr.adjust_roads_and_lanes()
    odr.write_xml(str(tmp_path / "wide.xodr"))
    roadmap = RoadMap.load(tmp_path / "wide.xodr")
    assert len(roadmap.lanes) == 2 * per_side
    for lane in roadmap.lanes:
        centre_y = float(np.mean(lane.points[:, 1]))  # the centre line is y = 0
        assert lane.centerline_offset == pytest.approx(abs(centre_y), abs=0.01), lane.uid
        assert abs(float(np.mean(roadmap.by_uid[lane.opposite].points[:, 1]))) == pytest.approx(LANE / 2, abs=0.01)


def test_heading_near_a_joints_backward_kink_is_the_lanes_direction():
    """Scenic's centre lines step a few cm backwards where two geometries join (a straight meeting an arc): the
    one segment nearest a point just past the joint points backwards, and an actor placed there read as facing
    against its lane (issue 10: every variation of a curve 'starts off the road network')."""
    points = np.array([[0.0, -1.75], [100.0, -1.75], [99.94, -1.749], [127.17, -2.68], [154.27, -5.46]])
    lane = Lane(0, "road1_lane1", "road1", points, 3.5, math.nan, None, [], None, None, None, None, math.nan,
                "not_mentioned")
    for x in (80.0, 100.5, 104.6, 130.0):
        y = float(np.interp(x, [0.0, 100.0, 127.17, 154.27], [-1.75, -1.75, -2.68, -5.46]))
        assert math.cos(heading_near(lane, x, y)) > 0.99


def _chorded_bend(radius: float = 400.0, chord: float = 28.0) -> Lane:
    """A lane 100 m straight along +x, then chords of an arc of `radius` bending left (the generated curve map)."""
    step = 2.0 * math.asin(chord / (2.0 * radius))  # [rad] the arc's angle per chord
    angles = step * np.arange(31)
    arc = np.stack([100.0 + radius * np.sin(angles), radius * (1.0 - np.cos(angles))], axis=1)
    return Lane(0, "road1_lane1", "road1", np.concatenate([[[0.0, 0.0]], arc]), 3.5, math.nan, None, [], None,
                None, None, None, math.nan, "not_mentioned")


def test_bent_frames_put_a_straight_plans_point_on_the_bend():
    """A path planned along a straight road from a station (a pull-out that clips the car ahead) is read on a
    bend in a frame turned so that its point `along` ahead (the touch) lies on the route there, heading with it;
    on a straight stretch the frame is the route's pose (the same floats)."""
    arrays = RouteArrays.pack([RoadMap(Path("none.xodr"), [_chorded_bend()], []).route("road1_lane1", min_length=10.0)])
    s, along = np.array([20.0, 150.0]), np.array([40.0, 60.0])
    x, y, yaw = bent_frames(arrays, 0, s, along)
    px, py, pyaw = arrays.point(np.zeros(2, dtype=int), s)
    assert (x[0], y[0], yaw[0]) == (px[0], py[0], pyaw[0])  # 20 -> 60 m: straight
    cx, cy, cyaw = arrays.point(np.zeros(1, dtype=int), s[1:] + along[1:])
    assert x[1] + math.cos(yaw[1]) * along[1] == pytest.approx(cx[0], abs=1e-9)
    assert y[1] + math.sin(yaw[1]) * along[1] == pytest.approx(cy[0], abs=1e-9) and yaw[1] == cyaw[0]
    assert cy[0] - (py[1] + math.sin(pyaw[1]) * along[1]) > 3.0  # read straight from s, the touch lies 4 m off


def test_route_curvature_of_a_chorded_arc_is_the_arcs():
    """Scenic's centre line of a bend is a chain of chords (here 28 m chords of a 400 m radius after a 100 m
    straight, the shape of the generated curve map): the route's curvature is the bend's, not 0 along each chord
    and ~30 times the bend's at its vertices (where drivers looking ahead for curves slowed to ~6 m/s)."""
    radius, chord = 400.0, 28.0
    route = RoadMap(Path("none.xodr"), [_chorded_bend(radius, chord)], []).route("road1_lane1", min_length=10.0)
    s = np.arange(len(route.curvature)) * ROUTE_DS
    on_arc = (s > 100.0 + chord) & (s < route.length - chord)
    assert np.abs(route.curvature).max() < 1.05 / radius
    assert route.curvature[on_arc] == pytest.approx(1.0 / radius, rel=0.02)
    assert np.abs(route.curvature[s < 70.0]).max() < 0.5 / radius
