"""Where a written junction contact is met when the routes' meeting point cannot give its class
(simulate.embedded.touch), and the pull-out that times it from a stop line (simulate.embedded.pullout), on a
hand-built turn into a lane: a right turn along a quarter circle that joins a straight southbound lane."""
from __future__ import annotations

import math

import numpy as np
import pytest

from crashscene.geometry import footprint_separation, heading_difference, relative_position
from crashscene.simulate.embedded import touch
from crashscene.simulate.embedded.pullout import PullOut
from crashscene.simulate.embedded.vehicles import limits_for
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS, Route

LANE_X = 11.35  # [m] the southbound lane's centre line
CAR = (4.5, 1.8)  # [m] length, width
RADIUS = 4.0  # [m] of the turn into the lane (a corner radius: the angle needs the nose in the lane early)


def route(key: str, xy: np.ndarray) -> Route:
    """A route through the points `xy` (K, 2), resampled every ROUTE_DS."""
    seg = np.hypot(*np.diff(xy, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    stations = np.arange(0.0, s[-1], ROUTE_DS)
    pts = np.stack([np.interp(stations, s, xy[:, 0]), np.interp(stations, s, xy[:, 1])], axis=1)
    yaw = np.unwrap(np.arctan2(*np.gradient(pts, axis=0).T[::-1]))
    n = len(pts)
    return Route((key,), pts, yaw, np.gradient(yaw) / ROUTE_DS, np.full(n, -1, dtype=np.int32),
                 np.full(n, -1, dtype=np.int32), np.full(n, np.nan), np.full(n, 20.0), [])


def world(radius: float = RADIUS) -> RouteArrays:
    """Route 0: south along x = LANE_X; route 1: east along y = -1.75, right along a quarter circle of `radius` into
    route 0's lane, then south in it; route 2: west along y = 1.75, crossing route 0 square."""
    through = np.array([[LANE_X, 150.0], [LANE_X, -150.0]])
    arc = [(LANE_X - radius + radius * math.cos(p), -1.75 - radius + radius * math.sin(p))
           for p in np.linspace(math.pi / 2, 0.0, 60)]
    turn = np.array([(-80.0, -1.75)] + arc + [(LANE_X, -150.0)])
    crossing = np.array([[100.0, 1.75], [-100.0, 1.75]])
    return RouteArrays.pack([route("through", through), route("turn", turn), route("crossing", crossing)])


def mover(arrays: RouteArrays, r: int, other: int, speed: float, rest: float | None = None) -> touch.Mover:
    return touch.Mover(r, float(arrays.conflict_s[r, other]), speed, rest, *CAR, limits_for("car"))


def test_a_turn_into_a_lane_cannot_give_an_angle_where_the_paths_join_a_crossing_can():
    arrays = world()
    cs = arrays.conflict_s
    assert math.degrees(abs(arrays.conflict_angle[1, 0])) < 30.0  # they join almost aligned
    assert touch.needs_moving(arrays, 0, cs[0, 1], 1, cs[1, 0], "angle")
    assert not touch.needs_moving(arrays, 0, cs[0, 1], 1, cs[1, 0], "sideswipe")
    assert not touch.needs_moving(arrays, 2, cs[2, 0], 0, cs[0, 2], "angle")


def test_the_turner_is_met_where_the_angle_happens_on_the_drives_predicted():
    """The through car (15 m/s) and the turner pulling away from rest 22 m before the routes join: the touch
    chosen is an angle (CLASS_MARGIN inside its range) on the two predicted drives, where they just touch, earlier
    on the turn than where the routes join."""
    arrays = world()
    striker = mover(arrays, 0, 1, 15.0)
    struck = mover(arrays, 1, 0, 12.0, rest=float(arrays.conflict_s[1, 0]) - 22.0)
    met = touch.class_meeting(arrays, striker, struck, ("angle", "front", "left"))
    assert met is not None
    assert met.struck_s < struck.meet - 1.0
    poses = []
    for m, t in ((striker, met.striker_t), (struck, met.struck_t)):
        times, x, y, yaw, _ = touch.driven_path(arrays, m)
        poses.append((np.interp(t, times, x), np.interp(t, times, y), np.interp(t, times, yaw)))
    (xa, ya, yawa), (xb, yb, yawb) = poses
    gap = footprint_separation(xa, ya, yawa, *CAR, xb, yb, yawb, *CAR)
    assert abs(float(gap)) < 0.1  # they just touch there
    rel = math.degrees(float(heading_difference(yawa, yawb)))
    assert 60.0 + touch.CLASS_MARGIN - 0.5 <= rel <= 120.0 - touch.CLASS_MARGIN + 0.5
    assert 0.0 < met.struck_v < 8.0 and met.striker_v == pytest.approx(15.0, abs=0.1)
    # along a wide turn the driver's pursuit cuts the corner and its nose reaches the lane only well turned (about
    # 50 deg): no angle at all
    wide = world(9.35)
    assert touch.class_meeting(wide, mover(wide, 0, 1, 15.0), mover(wide, 1, 0, 12.0, rest=float(
        wide.conflict_s[1, 0]) - 22.0), ("angle", "front", "left")) is None



def test_no_touch_is_chosen_when_no_shift_gives_the_class():
    arrays = world()
    # a head-on cannot happen between a car going south and one turning into its lane behind it
    assert touch.class_meeting(arrays, mover(arrays, 0, 1, 15.0), mover(arrays, 1, 0, 12.0),
                               ("head_on", "front", "front")) is None


def pull_out(fair: bool) -> PullOut:
    p = PullOut.none(1)
    p.npc[0], p.ads[0] = 0, 1
    p.line[0], p.cs_ads[0], p.tta[0] = 10.0, 100.0, 2.0
    p.fair[0] = fair
    if not fair:
        p.rest[0], p.touch_speed[0] = 7.5, 2.0  # its front 0.25 m before its line
    return p


@pytest.mark.parametrize("partner_s, npc_s, released", [
    (100.0 - 2.25 - 15.0 * 2.05, 7.5, False),  # 2.05 s away, the waiter where planned: not yet
    (100.0 - 2.25 - 15.0 * 1.95, 7.5, True),   # 1.95 s away: it pulls out
    (100.0 - 2.25 - 15.0 * 2.05, 7.3, True),   # 0.2 m further back it needs 0.1 s more: already
    (100.0 - 2.25 - 15.0 * 1.7, 7.5, True),    # inside the partner's stopping distance: no fairness applies
])
def test_a_reproduce_mode_pull_out_waits_for_its_partner_to_be_as_far_as_it_takes_from_rest(partner_s, npc_s,
                                                                                           released):
    p = pull_out(fair=False)
    s, v = np.array([[npc_s, partner_s]]), np.array([[0.0, 15.0]])
    hold = np.zeros((1, 2))
    invalid: list = [None]
    p.step(5.0, s, v, np.full((1, 2), 4.5), hold, invalid)
    assert bool(p.released[0]) == released and invalid == [None]
    assert hold[0, 0] == (5.0 if released else math.inf)


def test_a_test_mode_pull_out_still_gives_the_ads_its_stopping_time():
    p = pull_out(fair=True)
    # 1.7 s away at 15 m/s: the ADS's reaction and braking (2.2 s with the margin) is longer, so it pulls out now,
    # and the ADS was already inside its stopping distance: unavoidable
    s, v = np.array([[7.5, 100.0 - 2.25 - 15.0 * 1.7]]), np.array([[0.0, 15.0]])
    invalid: list = [None]
    p.step(5.0, s, v, np.full((1, 2), 4.5), np.zeros((1, 2)), invalid)
    assert p.released[0] and invalid[0] is not None and invalid[0].startswith("unavoidable")


def test_a_turner_charged_with_not_yielding_is_met_with_its_front_ahead_of_the_other_cars_centre():
    """rules.md's yield checks measure the other's time to reach the conflict area when the turner enters its path:
    a touch behind the through car's centre (it had passed) would leave the charge unobserved."""
    arrays = world()
    striker = mover(arrays, 0, 1, 15.0)
    plain = mover(arrays, 1, 0, 12.0, rest=float(arrays.conflict_s[1, 0]) - 22.0)
    charged = touch.Mover(*[getattr(plain, f) for f in ("route", "meet", "speed", "rest", "length", "width",
                                                         "limits")], yields_not=True)
    fronts = []
    for struck in (plain, charged):
        met = touch.class_meeting(arrays, striker, struck, ("angle", "front", "left"))
        assert met is not None
        poses = []
        for m, t in ((striker, met.striker_t), (struck, met.struck_t)):
            times, x, y, yaw, _ = touch.driven_path(arrays, m)
            poses.append((np.interp(t, times, x), np.interp(t, times, y), np.interp(t, times, yaw)))
        (xa, ya, yawa), (xb, yb, yawb) = poses
        front = (xb + CAR[0] / 2 * math.cos(yawb), yb + CAR[0] / 2 * math.sin(yawb))
        fronts.append(float(relative_position(xa, ya, yawa, *front)[0]))  # along the through car, from its centre
    # without the charge the most robust touch is 0.65 m ahead of the through car's centre, next to the shifts that
    # touch behind it; with it, the middle of the shifts that touch ahead of it (1.4 m)
    assert fronts[1] >= 0.0 and fronts[1] > fronts[0] + 0.3
