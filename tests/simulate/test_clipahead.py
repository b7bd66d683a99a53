"""The plan of a clip followed by the striker's contact with a car ahead of the clipped one in its lane
(simulate.embedded.clipahead): the clip stepped with both bodies, and where the third car must start."""
from __future__ import annotations

import numpy as np
import pytest

from crashscene.simulate.embedded import cascade, clipahead
from crashscene.simulate.embedded.cascade import DT
from crashscene.simulate.embedded.skid import Body

CAR = (4.5, 1.8, 1500.0, 0.6)
BODY = Body(4.5, 1.8)


def _straight_clip(speed: float = 20.0, partner_speed: float = 12.0, ahead: float = 10.0, dt: float = 0.1):
    t = dt * np.arange(1, 61)
    rows = (speed * t, np.zeros(60), np.zeros(60))  # straight on, the partner 0.9 m to its right
    touch = (ahead - 4.5) / (speed - partner_speed)  # [s] the bumpers meet
    t_meet = dt * np.ceil(touch / dt - 1e-9)
    return cascade.Clip(rows, 1.0, speed, 0.0, ahead, partner_speed, -0.9, t_meet, dt, CAR, CAR, 0.8), touch


def test_a_clip_pair_touches_where_the_bumpers_meet_and_pushes_the_clipped_car_on():
    clip, touch = _straight_clip()
    t_touch, mine, theirs = clipahead.clip_pairs([clip])[0]
    assert t_touch == pytest.approx(touch, abs=clip.dt / 100)
    # the clipped car, struck from behind, leaves faster than it drove; the striker slower than it came, and it never
    # passes the clipped car's centre
    assert (theirs[0][5] - theirs[0][0]) / (5 * DT) > clip.partner_speed + 1.0
    assert (mine[0][5] - mine[0][0]) / (5 * DT) < clip.speed - 1.0
    assert np.all(mine[0] < theirs[0])
    # struck on its right front corner the striker turns right (clockwise), the clipped car on its left rear too
    assert mine[2][10] < -0.05 and theirs[2][10] < -0.05


def test_clip_pairs_at_once_equal_each_alone():
    clips = [_straight_clip(20.0, 12.0)[0], _straight_clip(25.0, 15.0, 14.0)[0], _straight_clip(18.0, 14.0, 8.0)[0]]
    together = clipahead.clip_pairs(clips)
    for clip, pair in zip(clips, together):
        alone = clipahead.clip_pairs([clip])[0]
        assert pair[0] == alone[0]
        assert np.array_equal(pair[1], alone[1]) and np.array_equal(pair[2], alone[2])


def _pair(partner_across: float) -> tuple[float, np.ndarray, np.ndarray]:
    """A hand-made clip: the striker turned 90 deg clockwise slides on along the lane at 12 m/s from 2 m behind
    where the clipped car was; the clipped car moves across to `partner_across` [m] while it rolls on at 10 m/s."""
    steps = 60
    tau = DT * np.arange(1, steps + 1)
    mine = np.stack([-2.0 + 12.0 * tau, np.zeros(steps), np.full(steps, -np.pi / 2)])
    theirs = np.stack([4.0 + 10.0 * tau, partner_across * np.minimum(tau / 0.5, 1.0), np.zeros(steps)])
    return 0.0, mine, theirs


def test_the_third_car_is_placed_where_the_striker_meets_it_first_at_an_angle():
    # the third car drives on at 5 m/s in the lane, sampled 20 m ahead: the striker (7 m/s faster) reaches it first
    # only when the clipped car has left the lane
    ahead = clipahead.Ahead(20.0, 0.0, 5.0, BODY, 0.0)
    found = clipahead.place_ahead([_pair(-4.0)], BODY, BODY, ahead, [4.0], "angle", True)
    assert found is not None
    i, shift, k = found
    # where it was sampled the striker's leading side (-2 + 12 t + 0.9) reaches its rear (20 + 5 t - 2.25) at 2.69 s,
    # after the clipped car has left the lane: it is not moved, and they meet on the step ending at 2.7 s
    assert (i, shift) == (0, 0.0) and DT * (k + 1) == pytest.approx(2.7)
    # moved back onto the clipped car's rear it cannot start there
    far = clipahead.Ahead(9.0, 0.0, 5.0, BODY, 0.0)
    assert clipahead.place_ahead([_pair(-4.0)], BODY, BODY, far, [4.0], "angle", True)[1] > 0.0


def test_no_third_car_start_when_the_clipped_car_stays_in_the_lane_ahead_of_the_striker():
    ahead = clipahead.Ahead(20.0, 0.0, 5.0, BODY, 0.0)
    assert clipahead.place_ahead([_pair(0.0)], BODY, BODY, ahead, [4.0], "angle", True) is None
    # nor with another class than the one the striker's turned body gives
    assert clipahead.place_ahead([_pair(-4.0)], BODY, BODY, ahead, [4.0], "rear_end", True) is None


def test_a_clip_of_a_car_driving_on_never_sends_the_striker_into_the_next_car_first():
    """What the contact model gives (benchmarks/bench_clip_reach.py has the sweep): a front-to-rear clip takes the
    closing speed out of the contact point, so the striker never passes the car it clipped, which the clip pushes on
    ahead of it; with the third car ahead of the clipped one, at its speed or faster, the striker never meets it
    first."""
    clips = [_straight_clip(v, p, a)[0] for v, p, a in ((20.0, 12.0, 10.0), (30.0, 15.0, 20.0), (26.0, 20.0, 8.0))]
    for clip, pair in zip(clips, clipahead.clip_pairs(clips)):
        ahead = clipahead.Ahead(clip.partner_ahead + 8.0, -0.9, clip.partner_speed, BODY, 0.0)
        for klass in ("angle", "rear_end", "sideswipe"):
            assert clipahead.place_ahead([pair], BODY, BODY, ahead, [clip.partner_ahead], klass, True) is None
