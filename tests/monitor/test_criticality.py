"""Criticality metrics against values computed by hand on synthetic traces."""
from __future__ import annotations

import time

import numpy as np
import pytest

from crashscene.monitor.arrays import build_arrays
from crashscene.monitor.criticality import (
    CRITICALITY_SCHEMA,
    ads_objectives,
    criticality_table,
    summarize,
    time_to_collision,
)
from tests.monitor.builders import tables, track


def _row(tabs) -> dict:
    table = criticality_table(build_arrays(tabs))
    assert table.schema == CRITICALITY_SCHEMA
    return table.to_pylist()[0]


def test_ttc_two_cars_closing_head_on():
    # ego at x=0 east at 12 m/s, npc1 at x=100 west at 8 m/s, both 4.5 m long: gap 95.5 m closes at 20 m/s
    row = _row(tables({"ego": track(steps=20, x0=0.0, speed=12.0, length=4.5, width=1.8),
                       "npc1": track(steps=20, x0=100.0, yaw=np.pi, speed=8.0, length=4.5, width=1.8)}))
    assert row["min_ttc"] == pytest.approx((100.0 - 4.5 - 19 * 0.1 * 20.0) / 20.0, abs=1e-9)  # at the last step
    assert row["min_ttc_t"] == pytest.approx(1.9)
    assert not row["collided"]


def test_ttc_oriented_footprints_crossing_cars():
    # ego east along y=0, npc1 north along x=0; bodies 4 x 2 m. ego front reaches x=-1 (npc1's left side) ...
    ego, npc = np.array([[-10.0, 0.0]]), np.array([[0.0, -10.0]])
    yaw_e, yaw_n = np.array([0.0]), np.array([np.pi / 2])
    half = np.array([[2.0, 1.0]])
    ttc = time_to_collision(ego, npc, yaw_e, yaw_n, half, half, np.array([[10.0, 0.0]]), np.array([[0.0, 5.0]]))
    # overlap needs ego x in [-3, 3] (t in [0.7, 1.3]) and npc1 y in [-3, 3] (t in [1.4, 2.6]): never together
    assert np.isinf(ttc[0])
    ttc = time_to_collision(ego, npc, yaw_e, yaw_n, half, half, np.array([[10.0, 0.0]]), np.array([[0.0, 10.0]]))
    assert ttc[0] == pytest.approx(0.7)  # both intervals [0.7, 1.3]


def test_pet_at_a_crossing():
    # ego east along y=0 from x=-20.5 at 10 m/s, 4 m long: covers (0, 0) from t=1.85 to t=2.25;
    # npc1 north along x=0 from y=-30 at 10 m/s: front reaches (0, 0) at t=2.8 -> PET 0.55 s
    row = _row(tables({"ego": track(steps=50, x0=-20.5, speed=10.0, length=4.0, width=2.0),
                       "npc1": track(steps=50, y0=-30.0, yaw=np.pi / 2, speed=10.0, length=4.0, width=2.0)}))
    assert row["pet"] == pytest.approx(0.55, abs=1e-6)
    assert not row["collided"]


def test_drac_closing_on_a_stopped_car():
    # ego at 20 m/s, a stopped car whose rear is 40 m ahead of ego's front: v^2 / (2 gap) = 400 / 80 = 5 m/s2
    row = _row(tables({"ego": track(steps=1, x0=0.0, speed=20.0, length=4.0, width=2.0),
                       "npc1": track(steps=1, x0=44.0, speed=0.0, length=4.0, width=2.0)}))
    assert row["max_drac"] == pytest.approx(5.0)
    assert row["min_ttc"] == pytest.approx(2.0)
    assert row["min_thw"] == pytest.approx(2.0)  # 40 m at 20 m/s


def test_delta_v_of_a_known_collision():
    # a 1,500 kg car at 15 m/s runs into a stopped 15,000 kg truck (the simulator's masses): common velocity
    # 15 * 1500 / 16500; delta-v car = 15000 / 16500 * 15 = 13.636 m/s, truck = 1500 / 16500 * 15 = 1.364 m/s
    row = _row(tables({"ego": track(steps=30, x0=0.0, speed=15.0, length=4.0, width=2.0, type="car"),
                       "npc1": track(steps=30, x0=20.0, speed=0.0, length=10.0, width=2.5, type="truck")}))
    assert row["collided"]
    assert row["min_ttc"] == 0.0
    assert row["impact_speed"] == pytest.approx(15.0)
    assert row["delta_v_a"] == pytest.approx(15000 / 16500 * 15.0)
    assert row["delta_v_b"] == pytest.approx(1500 / 16500 * 15.0)
    assert row["delta_v_source"] == "momentum"


def test_recorded_delta_v_is_preferred():
    tabs = tables({"ego": track(steps=30, x0=0.0, speed=15.0, length=4.0, width=2.0),
                   "npc1": track(steps=30, x0=20.0, speed=0.0, length=4.0, width=2.0)})
    import pyarrow as pa
    coll = pa.table({"variation": pa.array([0], pa.int32()), "t": [1.2], "actor_a": ["ego"], "actor_b": ["npc1"],
                     "delta_v_a": [6.5], "delta_v_b": [7.0]})
    row = criticality_table(build_arrays(tabs), coll).to_pylist()[0]
    assert (row["delta_v_a"], row["delta_v_b"], row["delta_v_source"]) == (6.5, 7.0, "simulator")


def test_parallel_lanes_never_critical_and_summary():
    tabs = tables({"ego": track(steps=40, speed=10.0), "npc1": track(steps=40, y0=3.5, speed=10.0)}, variations=3)
    table = criticality_table(build_arrays(tabs))
    assert table.num_rows == 3
    assert all(v is None or np.isnan(v) for v in table.column("min_ttc").to_pylist())
    s = summarize(table)
    assert s["min_ttc"] == {"n": 0, "min": None, "p5": None, "median": None}
    assert set(ads_objectives(table)) == {0, 1, 2}


@pytest.mark.slow
def test_vectorised_speed_2000_variations():
    rng = np.random.default_rng(0)
    tabs = tables({"ego": track(steps=200, speed=10.0), "npc1": track(steps=200, x0=50.0, yaw=np.pi, speed=5.0),
                   "npc2": track(steps=200, y0=-40.0, x0=30.0, yaw=np.pi / 2, speed=float(rng.uniform(5, 10)))},
                  variations=2000)
    arrays = build_arrays(tabs)
    start = time.perf_counter()
    table = criticality_table(arrays)
    assert table.num_rows == 2000 * 3
    assert time.perf_counter() - start < 15.0  # ~1-2 s measured on 2 shared cores


def test_min_gap_of_a_pair_side_by_side():
    # two 2 m wide cars side by side at the same speed, centres 3.5 m apart: never on a collision course,
    # closest gap 3.5 - 2 = 1.5 m
    row = _row(tables({"ego": track(steps=30, x0=0.0, speed=10.0, length=4.5, width=2.0),
                       "npc1": track(steps=30, x0=2.0, y0=3.5, speed=10.0, length=4.5, width=2.0)}))
    assert np.isnan(row["min_ttc"])
    assert row["min_gap"] == pytest.approx(1.5)


def _crossing_every_pair(px_a, py_a, px_b, py_b, yaw_a, yaw_b):
    """The crossing point by intersecting every segment pair (V x N x N): what `_crossing_point` must equal."""
    from crashscene.geometry import heading_difference
    from crashscene.monitor.criticality import CROSSING_MIN_ANGLE

    ax0, ay0, ax1, ay1 = px_a[:, :-1, None], py_a[:, :-1, None], px_a[:, 1:, None], py_a[:, 1:, None]
    bx0, by0, bx1, by1 = px_b[:, None, :-1], py_b[:, None, :-1], px_b[:, None, 1:], py_b[:, None, 1:]
    rx, ry, sx, sy = ax1 - ax0, ay1 - ay0, bx1 - bx0, by1 - by0
    denom = rx * sy - ry * sx
    qx, qy = bx0 - ax0, by0 - ay0
    with np.errstate(divide="ignore", invalid="ignore"):
        u = (qx * sy - qy * sx) / denom
        v = (qx * ry - qy * rx) / denom
        hit = (u >= 0) & (u <= 1) & (v >= 0) & (v <= 1) & (denom != 0)
    vi, ii, jj = np.nonzero(hit)
    angle = heading_difference(yaw_a[vi, ii], yaw_b[vi, jj])
    hit[vi, ii, jj] = (angle >= CROSSING_MIN_ANGLE) & (angle <= np.pi - CROSSING_MIN_ANGLE)
    flat = hit.reshape(len(hit), -1)
    k = np.argmax(flat, axis=1)
    i, j, rows = k // hit.shape[2], k % hit.shape[2], np.arange(len(hit))
    with np.errstate(invalid="ignore"):
        x = ax0[rows, i, 0] + u[rows, i, j] * rx[rows, i, 0]
        y = ay0[rows, i, 0] + u[rows, i, j] * ry[rows, i, 0]
    return np.where(flat.any(axis=1), x, np.nan), np.where(flat.any(axis=1), y, np.nan)


def test_crossing_point_tests_only_near_segments_and_equals_every_pair():
    from crashscene.monitor.criticality import _crossing_point

    rng = np.random.default_rng(4)
    n_var, n = 400, 30
    # two random walks per variation: crossing, parallel (same line, opposite ways), far apart, not alive (NaN)
    heading = rng.uniform(-np.pi, np.pi, (2, n_var, 1)) + np.cumsum(rng.normal(0, 0.15, (2, n_var, n)), axis=2)
    step = rng.uniform(0.0, 2.5, (2, n_var, n))
    start = rng.uniform(-30, 30, (2, n_var, 2))
    px = start[..., :1] + np.cumsum(step * np.cos(heading), axis=2)
    py = start[..., 1:] + np.cumsum(step * np.sin(heading), axis=2)
    yaw = heading.copy()
    px[1, :50], py[1, :50], yaw[1, :50] = px[0, :50][:, ::-1], py[0, :50][:, ::-1], yaw[0, :50][:, ::-1] + np.pi
    px[1, 50:80] += 500.0
    px[0, 80:90, 10:15] = np.nan
    got = _crossing_point(px[0], py[0], px[1], py[1], yaw[0], yaw[1])
    want = _crossing_every_pair(px[0], py[0], px[1], py[1], yaw[0], yaw[1])
    assert np.isfinite(want[0]).sum() > 50  # the walks do cross
    for a, b in zip(got, want):
        assert np.array_equal(a, b, equal_nan=True)


def test_delta_v_estimate_weighs_vehicles_as_the_simulator_does():
    from crashscene.simulate.embedded.vehicles import limits_for
    from crashscene.vehicle_mass import mass_of

    for actor_type in ("car", "truck", "motorcycle", "unknown"):
        assert mass_of(actor_type) == limits_for(actor_type).mass


def test_ttc_measured_on_the_used_samples_alone_gives_the_same_floats(monkeypatch):
    """_pair_ttc gathers the samples it uses (both present, before the first contact) when they are few: the
    table is the one measured on every sample, bit for bit, for pairs that collide early, late and never."""
    import crashscene.monitor.criticality as criticality

    tabs = tables({"ego": track(steps=80, x0=0.0, speed=12.0, length=4.5, width=1.8),
                   "npc1": track(steps=80, x0=60.0, yaw=np.pi, speed=9.0, length=4.5, width=1.8),
                   "npc2": track(steps=80, x0=-30.0, y0=0.3, speed=15.0, length=4.0, width=1.7),
                   "npc3": track(steps=80, x0=5.0, y0=-25.0, yaw=np.pi / 2 + 0.2, speed=6.0)}, variations=3)
    arrays = build_arrays(tabs)
    got = {}
    for share in (0.0, 2.0):  # always gathered, never gathered
        monkeypatch.setattr(criticality, "USED_SHARE", share)
        got[share] = criticality_table(arrays)
    assert got[0.0].column("collided").to_pylist().count(True) >= 3
    for name in CRITICALITY_SCHEMA.names:
        a, b = (got[share].column(name).to_numpy(zero_copy_only=False) for share in (0.0, 2.0))
        assert a.dtype == b.dtype
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
