"""The skid plan (embedded.skid): candidate skids batched over speeds, the overlap interval of two footprints
along the road, and a planned loss of control whose first footprint contact has the written class."""
from __future__ import annotations

import math

import numpy as np
import pytest

from crashscene.geometry import classify_contact, footprints_overlap, heading_difference
from crashscene.simulate.embedded import skid

DT = 0.1  # [s] the simulator's step
CAR = skid.Body(4.6, 1.9)
TRUCK = skid.Body(8.0, 2.5)


def test_a_batch_of_speeds_gives_each_speed_the_bytes_it_gets_alone():
    speeds = np.array([12.0, 27.5, 33.25])
    batch = skid.trajectories(speeds, 0.7, DT)
    for i, v in enumerate(speeds):
        alone = skid.trajectories(np.array([v]), 0.7, DT)
        for got, want in zip(batch, alone):
            assert got[i].tobytes() == want[0].tobytes()
    paths = skid.SkidPaths(0.7, DT)
    paths.prepare(speeds)
    assert all(a.tobytes() == b[1].tobytes() for a, b in zip(paths.get(27.5), batch))


@pytest.mark.parametrize("yaw", [0.0, 0.3, 1.2, math.pi / 2, 2.6, math.pi])
@pytest.mark.parametrize("dy", [0.0, 1.5, -2.1, 3.1, 6.0])
def test_the_overlap_interval_is_where_the_footprints_overlap(yaw, dy):
    lo, hi = skid.overlap_interval(np.array([dy]), np.array([yaw]), CAR, TRUCK)
    xs = np.linspace(-12.0, 12.0, 2401)
    inside = footprints_overlap(xs, np.full_like(xs, dy), np.full_like(xs, yaw), CAR.length, CAR.width,
                                0.0 * xs, 0.0 * xs, 0.0 * xs, TRUCK.length, TRUCK.width)
    predicted = (xs >= lo[0]) & (xs <= hi[0])
    clear = (np.abs(xs - lo[0]) > 1e-6) & (np.abs(xs - hi[0]) > 1e-6)  # touching exactly: either, in floats
    assert np.array_equal(inside[clear], predicted[clear])


def first_contact(plan: skid.Skid, speed: float, gap: float, partner_speed: float, lateral: float,
                  opposite: bool) -> tuple[str, float]:
    """Steps the planned skid and the partner (straight on) at the simulator's step from t = 0 and returns the
    class and the time of their first footprint overlap (geometry, not the plan's own interval)."""
    paths = skid.trajectories(np.array([speed]), 0.8, DT)
    spin, drift = skid.candidates()
    sign = 1.0 if lateral >= 0 else -1.0
    c = int(np.nonzero(np.isclose(sign * spin, plan.spin_rate) & np.isclose(sign * drift, plan.drift))[0][0])
    x, y, yaw = (q[0, c] for q in paths)
    v_p = -partner_speed if opposite else partner_speed
    yaw_p = math.pi if opposite else 0.0
    n_before = int(round((plan.trigger + DT / 2) / DT))
    start = gap + plan.partner_shift
    for k in range(n_before + len(x)):
        t = (k + 1) * DT
        if k < n_before:
            me = (speed * t, 0.0, 0.0)
        else:
            j = k - n_before
            me = (speed * n_before * DT + x[j], sign * y[j], sign * yaw[j])
        other = (start + v_p * t, lateral, yaw_p)
        if footprints_overlap(me[0], me[1], me[2], CAR.length, CAR.width, other[0], other[1], other[2],
                              TRUCK.length, TRUCK.width):
            dx, dy = other[0] - me[0], other[1] - me[1]
            lon = dx * math.cos(me[2]) + dy * math.sin(me[2])
            lat = -dx * math.sin(me[2]) + dy * math.cos(me[2])
            klass = classify_contact(heading_difference(np.array(me[2]), np.array(yaw_p)), np.array(lon),
                                     np.array(lat), (CAR.length + TRUCK.length) / 2, (CAR.width + TRUCK.width) / 2)
            return str(klass[()]), t
    return "none", math.inf


@pytest.mark.parametrize("gap", [-6.0, -2.0, 0.0, 3.0])
@pytest.mark.parametrize("lateral", [3.5, -3.5])
def test_a_veer_into_a_truck_alongside_turns_far_enough_before_it_touches(gap, lateral):
    """A car alongside a truck in the next lane veers into it: side to side, it would touch long before it has
    turned; the plan lets it touch first where the truck's front meets its side at an angle."""
    speed, partner_speed = 28.0, 27.0
    rotation = skid.rotation_for("angle", False, 0.5)
    paths = skid.SkidPaths(0.8, DT).get(speed)
    plan = skid.plan(paths, speed, gap, partner_speed, False, lateral, CAR, TRUCK, rotation,
                     skid.Wanted("angle", "left" if lateral > 0 else "right", "front"), DT)
    assert plan is not None
    klass, _ = first_contact(plan, speed, gap, partner_speed, lateral, False)
    assert klass == "angle"


@pytest.mark.parametrize("klass", ["head_on", "angle"])
def test_a_loss_of_control_into_oncoming_traffic_meets_it_as_written(klass):
    speed, partner_speed, gap, lateral = 25.0, 20.0, 90.0, 3.5
    rotation = skid.rotation_for(klass, True, 0.3)
    plan = skid.plan(skid.SkidPaths(0.8, DT).get(speed), speed, gap, partner_speed, True, lateral, CAR, TRUCK,
                     rotation, skid.Wanted(klass), DT)
    assert plan is not None and plan.partner_shift == 0.0
    got, t = first_contact(plan, speed, gap, partner_speed, lateral, True)
    assert got == klass and t == pytest.approx(plan.trigger + DT / 2 + plan.t_meet, abs=DT + 1e-9)


def test_the_first_overlaps_are_those_found_step_by_step_for_every_offset():
    rng = np.random.default_rng(3)
    lo = rng.uniform(-6.0, -1.0, (5, 40))
    hi = lo + rng.uniform(-1.0, 8.0, (5, 40))  # some steps overlap for no offset (lo > hi)
    alongs = [np.cumsum(rng.uniform(-0.5, 1.5, (5, 40)), axis=1) - 10.0 for _ in range(3)]
    offsets_each = [rng.uniform(-20.0, 40.0, 50), rng.uniform(-20.0, 40.0, 7), rng.uniform(300.0, 400.0, 20)]
    want = []  # (pair, candidate, offset, step), pair by pair
    for g, (along, offsets) in enumerate(zip(alongs, offsets_each)):
        rel = along[:, None, :] - offsets[None, :, None]
        touch = (rel >= lo[:, None, :]) & (rel <= hi[:, None, :])
        cc, jj = np.nonzero(touch.any(axis=2))
        want.append((np.full(len(cc), g), cc, jj, touch[cc, jj].argmax(axis=1)))
    assert len(want[0][0]) and len(want[1][0]) and not len(want[2][0])  # the last pair never overlaps
    got = skid._first_steps(alongs, lo, hi, offsets_each)
    assert all(np.array_equal(g, np.concatenate(w)) for g, w in zip(got, zip(*want)))
    assert skid._first_steps(alongs[2:], lo, hi, offsets_each[2:]) is None


@pytest.mark.parametrize("opposite, gap, lateral, wanted, fine, place", [
    (False, -2.0, 3.5, skid.Wanted("angle", "left", "front"), 1, True),
    (False, 12.0, -1.8, skid.Wanted("sideswipe", "front", "rear", skidder_first=False), 5, False),
    (True, 90.0, 3.5, skid.Wanted("head_on"), 1, True),
])
def test_a_search_at_many_partner_speeds_finds_what_each_finds_alone(opposite, gap, lateral, wanted, fine, place):
    speed = 28.0
    paths = skid.SkidPaths(0.8, DT).get(speed)
    rotation = skid.rotation_for(wanted.contact_class, opposite, 0.4)
    sign = 1.0 if lateral >= 0 else -1.0
    partner_speeds, latests = [27.0, 20.0, 12.5, 27.0, 5.0], [12.0, 3.0, 6.0, 0.5, 9.0]
    together = skid.first_contacts(paths, sign, speed, gap, partner_speeds, opposite, lateral, CAR, TRUCK,
                                   rotation, wanted, DT, latests=latests, place=place, fine=fine)
    alone = [skid.first_contact(paths, sign, speed, gap, v, opposite, lateral, CAR, TRUCK, rotation, wanted, DT,
                                latest=t, place=place, fine=fine) for v, t in zip(partner_speeds, latests)]
    assert together == alone
    assert sum(found is not None for found in alone) >= 2  # the case finds contacts (the test can fail)


def first_touch_on_path(path, trigger: float, speed: float, start: float, partner_speed: float, lateral: float,
                        partner: skid.Body) -> tuple[str, float]:
    """Steps a car driving straight on at `speed` that starts `path` (x, y, yaw (1, K) every DT after its trigger,
    turning left) on the simulator step after `trigger` [s], and a partner `start` [m] ahead at `lateral` [m] driving
    straight on; the class and time of their first footprint overlap (geometry, not the plan's interval)."""
    x, y, yaw = (q[0] for q in path)
    n_before = int(round((trigger + DT / 2) / DT))
    for k in range(n_before + len(x)):
        t = (k + 1) * DT
        me = (speed * t, 0.0, 0.0) if k < n_before else (speed * n_before * DT + x[k - n_before], y[k - n_before],
                                                          yaw[k - n_before])
        other = (start + partner_speed * t, lateral, 0.0)
        if footprints_overlap(me[0], me[1], me[2], CAR.length, CAR.width, other[0], other[1], other[2],
                              partner.length, partner.width):
            dx, dy = other[0] - me[0], other[1] - me[1]
            lon = dx * math.cos(me[2]) + dy * math.sin(me[2])
            lat = -dx * math.sin(me[2]) + dy * math.cos(me[2])
            klass = classify_contact(heading_difference(np.array(me[2]), np.array(0.0)), np.array(lon),
                                     np.array(lat), (CAR.length + partner.length) / 2,
                                     (CAR.width + partner.width) / 2)
            return str(klass[()]), t
    return "none", math.inf


@pytest.mark.parametrize("partner", [CAR, skid.Body(3.7, 1.8)])
def test_the_other_starts_of_a_clip_each_clip_the_car_ahead_as_written(partner):
    """A pull-out clipping the slower car ahead: after the best start, `contact_choices` lists starts on other
    trigger steps, each of which first touches the car ahead with the written class too."""
    from crashscene.simulate.embedded import swerve

    speed, gap, offset = 21.0, 30.0, 3.5
    path = swerve.paths([(speed, offset, 2.0, 0.6 * CAR.length, math.radians(60), math.radians(35), DT)])[0]
    wanted = skid.Wanted("sideswipe", "right", "rear")
    partner_speeds = [17.0, 12.5]
    latests = [(gap - (CAR.length + partner.length) / 2) / (speed - v) - DT for v in partner_speeds]
    args = (path, 1.0, speed, gap, partner_speeds, False, 0.0, CAR, partner, skid.CLASS_HEADING["sideswipe"], wanted,
            DT)
    choices = skid.contact_choices(*args, latests=latests, place=False, fine=8, count=6)
    best = skid.first_contacts(*args, latests=latests, place=False, fine=8)
    assert [c[0] for c in choices] == best
    assert sum(len(c) for c in choices) > len(choices)  # other starts are found (the test can fail)
    for v, found in zip(partner_speeds, choices):
        assert len(found) <= 6 and len({round((trigger + DT / 2) / DT) for _, trigger, _, _ in found}) == len(found)
        for _, trigger, t_meet, shift in found:
            klass, t = first_touch_on_path(path, trigger, speed, gap + shift, v, 0.0, partner)
            assert klass == "sideswipe"
            assert t == pytest.approx(trigger + DT / 2 + t_meet, abs=DT + 1e-9)


@pytest.mark.parametrize("curvature", [1 / 400.0, -1 / 400.0])
def test_along_road_reads_a_skid_in_the_frame_of_the_bend(curvature):
    """A car out of control keeps its course while its partner follows the lane round a bend: a path going
    straight on ends up off the road's outside, one that follows the arc stays on it, turned with it."""
    radius = 1.0 / curvature
    theta = np.linspace(0.0, 0.3, 7)[None, :]  # [rad] round the arc
    on_arc = (abs(radius) * np.sin(theta), radius * (1.0 - np.cos(theta)), np.sign(curvature) * theta)
    s, d, yaw = skid.along_road(on_arc, curvature)
    assert s == pytest.approx(abs(radius) * theta, abs=1e-9)
    assert d == pytest.approx(0.0, abs=1e-9) and yaw == pytest.approx(0.0, abs=1e-12)
    x = np.linspace(0.0, 100.0, 5)[None, :]
    s, d, yaw = skid.along_road((x, np.zeros_like(x), np.zeros_like(x)), curvature)
    outside = np.abs(radius) - np.hypot(x, radius)  # [m] the bend's radius less the straight path's distance
    assert d == pytest.approx(np.sign(curvature) * outside, abs=1e-9)
    assert yaw == pytest.approx(-curvature * s, abs=1e-12)
    straight = (x, x * 0.1, x * 0.01)
    assert all(a is b for a, b in zip(skid.along_road(straight, 0.0), straight))
