"""The plan's prediction of a contact (simulate.embedded.rollout) against the embedded simulator: started from a
trace one step before its first contact, it gives the poses the simulator recorded through it."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pyarrow.parquet as pq
import pytest

from crashscene.dsl import loads
from crashscene.pipeline.simulate import simulate_scenario
from crashscene.simulate.embedded.rollout import Bodies, rollout, stepped
from crashscene.simulate.embedded.vehicles import limits_for


def _bodies(rows: list[dict], sizes: dict) -> Bodies:
    """Driven bodies (their drivers in control) at the traced poses, moving along their headings."""
    def col(f):
        return np.array([f(r) for r in rows], dtype=float)

    limits = [limits_for(sizes[r["actor"]][2]) for r in rows]
    length, width = col(lambda r: sizes[r["actor"]][0]), col(lambda r: sizes[r["actor"]][1])
    return Bodies(col(lambda r: r["x"]), col(lambda r: r["y"]), col(lambda r: r["yaw"]),
                  col(lambda r: r["speed"] * math.cos(r["yaw"])), col(lambda r: r["speed"] * math.sin(r["yaw"])),
                  np.zeros(len(rows)), length, width, np.array([m.mass for m in limits]),
                  np.array([m.wheelbase_ratio for m in limits]) * length, np.zeros(len(rows), dtype=bool))


@pytest.mark.slow
def test_a_rollout_from_the_step_before_a_contact_follows_the_simulators_trace_through_it(tmp_path):
    from tests.simulate.test_reproduce_configurations import CASCADE, LATER_CONTACTS

    # a drift into the corner of a parked car, and a rear-end into the corner of a stopped one: the two bodies go
    # on touching after the first exchange
    drift, _ = LATER_CONTACTS["a_drift_into_a_parked_car_deflects_the_striker_into_the_side_of_the_car_alongside"]
    checked, after = 0, 0
    for name, text in (("drift", drift), ("rear_end", CASCADE)):
        one, later = _compare(text, tmp_path / name)
        checked, after = checked + one, after + later
    assert checked >= 8 and after >= 3


def _compare(text: str, out) -> tuple[int, int]:
    """(variations compared, of which compared after the first exchange too): the rollout from the step before
    each variation's first contact against the simulator's trace through it (asserted)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate_scenario(loads(text), out, 6, 7, mode="reproduce")
    traces = pq.read_table(out / "traces.parquet").to_pylist()
    contacts = pq.read_table(out / "collisions.parquet").to_pylist()
    actors = pq.read_table(out / "actors.parquet").to_pylist()
    dt = pq.read_table(out / "variations.parquet").column("dt")[0].as_py()
    checked, after = 0, 0
    for v in sorted({c["variation"] for c in contacts}):
        mine = sorted((c for c in contacts if c["variation"] == v), key=lambda c: c["t"])
        first = mine[0]
        pair = (first["actor_a"], first["actor_b"])
        sizes = {a["actor"]: (a["length"], a["width"], a["type"]) for a in actors if a["variation"] == v}
        rows = {(r["actor"], r["step"]): r for r in traces if r["variation"] == v and r["actor"] in pair}
        k0 = int(math.floor(first["t"] / dt + 1e-9))  # the last step before the onset
        # compared until another vehicle touches either of the two (the rollout steps the pair alone)
        other = min((c["t"] for c in mine[1:] if {c["actor_a"], c["actor_b"]} != set(pair)), default=math.inf)
        steps = [j for j in range(3) if (k0 + 1 + j) * dt < other and (pair[0], k0 + 1 + j) in rows]
        if k0 < 1 or not steps:
            continue
        a = _bodies([rows[(pair[0], k0)]], sizes)
        b = _bodies([rows[(pair[1], k0)]], sizes)
        pa, pb, t_first, _ = rollout(a, b, 0.8, dt, 3)  # a dry road (the scenarios')
        assert t_first[0] == pytest.approx(first["t"] - k0 * dt, abs=1e-3)
        for actor, pose in ((pair[0], pa), (pair[1], pb)):
            for j in steps:
                row = rows[(actor, k0 + 1 + j)]
                assert pose[0][0, j] == pytest.approx(row["x"], abs=0.05), (v, actor, j)
                assert pose[1][0, j] == pytest.approx(row["y"], abs=0.05), (v, actor, j)
                yaw = math.degrees(math.remainder(pose[2][0, j] - row["yaw"], 2 * math.pi))
                assert abs(yaw) < 0.5, (v, actor, j, yaw)
        checked += 1
        after += max(steps) >= 1  # a step after the exchange, the bodies moving as it left them
    return checked, after


def test_stepped_resamples_from_the_first_contact_and_says_when_there_is_none():
    car = dict(length=np.full(2, 4.5), width=np.full(2, 1.8), mass=np.full(2, 1500.0), wheelbase=np.full(2, 2.7))
    # a car 20 m/s behind a parked one, touching within the first 0.1 s step; and one 3 m aside that never touches
    a = Bodies(np.array([-5.5, -5.5]), np.array([0.5, 3.0]), np.zeros(2), np.full(2, 20.0), np.zeros(2), np.zeros(2),
               free=np.zeros(2, dtype=bool), **car)
    b = Bodies(np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2),
               free=np.zeros(2, dtype=bool), **car)
    pa, pb, first = stepped(a, b, 0.8, 0.1, 20, 0.05)
    assert first[0] == pytest.approx(1.0 / 20.0, abs=1e-3) and np.isnan(first[1])
    assert pa.shape == (3, 2, 20) and pb.shape == (3, 2, 20)
    # the parked car is pushed on from where it stood; the car that never touched drives on at 20 m/s
    assert pb[0, 0, 0] >= 0.0 and pb[0, 0, -1] > 1.0
    assert np.allclose(np.diff(pa[0, 1]), 20.0 * 0.05) and np.all(pb[:, 1] == 0.0)
    # a and b unchanged by the call
    assert a.x[0] == -5.5 and b.x[0] == 0.0


def _pair(gap: float, sliding_speed: float = 0.0):
    """A car (a) 20 m/s along x, its front `gap` [m] behind the rear of a car (b) standing still, or sliding
    sideways at `sliding_speed` [m/s] (then free)."""
    one = np.ones(1)
    a = Bodies(-(4.5 + gap) * one, 0.3 * one, 0 * one, 20.0 * one, 0 * one, 0 * one, 4.5 * one, 1.8 * one,
               1500.0 * one, 2.7 * one, np.zeros(1, dtype=bool))
    b = Bodies(0 * one, 0 * one, 0 * one, 0 * one, sliding_speed * one, 0 * one, 4.5 * one, 1.8 * one, 1500.0 * one,
               2.7 * one, np.full(1, sliding_speed != 0.0))
    return a, b


def test_the_bodies_are_pushed_apart_after_each_exchange_as_the_simulator_does():
    from crashscene.geometry import footprint_separation
    from crashscene.simulate.embedded.impact import OVERLAP_KEPT

    a, b = _pair(0.5)
    pa, pb, first, _ = rollout(a, b, 0.8, 0.1, 4, motion=True)
    assert pa.shape == (6, 1, 4) and 0.0 < first[0] < 0.1
    gap = footprint_separation(pa[0], pa[1], pa[2], 4.5, 1.8, pb[0], pb[1], pb[2], 4.5, 1.8)
    assert gap[0, 0] >= -OVERLAP_KEPT - 1e-9  # left barely touching, not 1.5 m into each other
    # the velocities are the bodies' own: b was struck from behind and moves on forward
    assert pb[3, 0, 0] > 5.0 and pa[3, 0, 0] < 20.0


def test_a_body_sliding_from_an_impact_before_slides_on_its_tyres_from_the_start():
    a, b = _pair(30.0, sliding_speed=3.0)  # they never meet within the steps
    _, driven, _, _ = rollout(a, b, 0.8, 0.1, 5)
    _, slid, _, _ = rollout(a, b, 0.8, 0.1, 5, np.array([[False], [True]]))
    # not sliding: its driver drives it on along its heading at its speed; sliding: it goes on sideways, slowed by
    # its tyres (mu g: 3 m/s is gone within 0.4 s)
    assert driven[0, 0, -1] == pytest.approx(1.5) and driven[1, 0, -1] == 0.0
    assert slid[0, 0, -1] == 0.0 and 0.4 < slid[1, 0, -1] < 0.6


def test_a_turning_driven_striker_meets_the_other_along_its_heading_at_the_contact():
    """A car 20 m/s, its driver turning it at 1 rad/s, touches a car standing still ahead half way into a 0.1 s
    step: as the simulator does (simulator._exchange), the impulse is exchanged with its velocity along its heading
    at the contact (the pose moved back to it), not along the heading its step ended at (0.05 rad further: 1 m/s
    across)."""
    from crashscene.simulate.embedded import impact
    from crashscene.simulate.embedded.rollout import contact_steps

    a, b = _pair(1.0)
    a.turn = np.ones(1)
    step = next(contact_steps(a, b, 0.8, 0.1, 1))
    assert step.onset[0] and 0.2 < step.frac[0] < 0.8
    xa, ya, yaw_a, xb, yb, yaw_b = step.contact
    one = np.ones(1)
    inertia = impact.yaw_inertia(1500.0 * one, 4.5 * one, 1.8 * one)
    nx, ny, px, py, _ = impact.contact(xa, ya, yaw_a, 4.5 * one, 1.8 * one, xb, yb, yaw_b, 4.5 * one, 1.8 * one)
    va, wa, vb, wb, _ = impact.exchange(nx, ny, px, py, xa, ya, np.stack([20.0 * np.cos(yaw_a), 20.0 * np.sin(yaw_a)]),
                                        one, 1500.0 * one, inertia, xb, yb, np.zeros((2, 1)), 0 * one, 1500.0 * one,
                                        inertia)
    assert (a.vx[0], a.vy[0], a.w[0]) == pytest.approx((va[0, 0], va[1, 0], wa[0]), abs=1e-9)
    assert (b.vx[0], b.vy[0], b.w[0]) == pytest.approx((vb[0, 0], vb[1, 0], wb[0]), abs=1e-9)


def test_stepped_gives_the_poses_the_simulator_records_the_first_contact_at():
    """The pair of `_pair` 0.5 m and 5 m apart: the first contact falls in the first and in the third 0.1 s step;
    the recorded poses are the rollout's at the end of that step (after its exchange and separation)."""
    near, far = _pair(0.5), _pair(5.0)
    a = Bodies(*(np.concatenate([getattr(near[0], f), getattr(far[0], f)]) for f in Bodies.__dataclass_fields__
                 if f != "turn"))
    b = Bodies(*(np.concatenate([getattr(near[1], f), getattr(far[1], f)]) for f in Bodies.__dataclass_fields__
                 if f != "turn"))
    pa, pb, first, _ = rollout(a, b, 0.8, 0.1, 10)
    *_, first_stepped, recorded = stepped(a, b, 0.8, 0.1, 20, 0.05, recorded=True)
    assert 0.0 < first[0] <= 0.1 and 0.2 < first[1] <= 0.3
    assert np.array_equal(first, first_stepped)
    for j, k in ((0, 0), (1, 2)):
        assert recorded[:, j].tolist() == [*pa[:, j, k], *pb[:, j, k]]
