"""The embedded backend: a batched kinematic simulator over (variations x actors), stepped in time.

Per step: the simulator builds every actor's `Observation` (vectorised over
variations), asks each actor's driver for an `Action`, moves the vehicles with
a kinematic bicycle model (pure-pursuit steering along the route at the
commanded lateral offset, acceleration/brake/steering limits per vehicle
type), and checks every pair of footprints for overlap. At each contact onset
the two vehicles exchange an impulse, and each one the impulse upsets slides out
of its driver's control until at rest (`impact`), so a second contact can follow;
each onset is recorded. The only Python loops in the step loop run over actors and
actor pairs, never over variations.
"""
from __future__ import annotations

import math
import time

import numpy as np

from crashscene.geometry import LANE_WIDTH, footprints_overlap, pair_indices, touch_fraction, wrap_angle
from crashscene.simulate.backend import (
    BatchResult,
    SimulationRequest,
    SimulationSettings,
    Simulator,
    check_ego_role,
)
from crashscene.simulate.drivers.ads import load_driver
from crashscene.simulate.drivers.base import (
    CONTROL_SIGNAL,
    SIGNAL_NONE,
    Action,
    DriverContext,
    Observation,
    ads_step,
)
from crashscene.simulate.drivers.behaviors import BehaviorDriver
from crashscene.simulate.embedded import setup as batch_setup
from crashscene.simulate.embedded import impact, refine, signals
from crashscene.simulate.embedded.swerve import lookahead as pursuit_lookahead
from crashscene.simulate.embedded.swerve import bicycle_move, bicycle_yaw_rate, steer_step
from crashscene.simulate.embedded.record import Recorder
from crashscene.simulate.roads import STOP_LINE_SETBACK, RoadMap
from crashscene.upset import upsets

ACTOR_VARIATIONS = 3000  # (variation, actor) pairs simulated together: bounds memory; results do not depend on it
DEFAULT_DRIFT = 0.15  # [rad] veer of a skidding car's velocity when no plan sets it


class EmbeddedSimulator(Simulator):
    """Batched numpy simulator on the scenario's OpenDRIVE map (default backend)."""

    name = "embedded"

    def simulate(self, request: SimulationRequest) -> BatchResult:
        settings = self.settings
        check_ego_role(request.scenario, settings)
        start = time.perf_counter()
        roadmap = RoadMap.load(request.map_file)
        recorder = Recorder(roadmap, settings)
        scenes = list(request.scenes)
        size = chunk_size(scenes)
        for first in range(0, len(scenes), size):
            chunk = scenes[first:first + size]
            batch = batch_setup.build(request.scenario, chunk, roadmap, settings)
            if settings.mode == "reproduce" and request.scenario.collisions and settings.refine:
                # the chunk's run, judged: kept when no plan is replanned, else the replanned chunk run instead
                run = refine.dry_run(batch)
                better = refine.replanned(batch, run)
                if better is None:
                    recorder.absorb(run)
                else:
                    run_batch(better, recorder)
            else:
                run_batch(batch, recorder)
            if request.progress is not None:
                request.progress(len(chunk))
        tables = recorder.tables(scenes)
        return BatchResult(backend=self.name, tables=tables, seconds=time.perf_counter() - start)


def chunk_size(scenes) -> int:
    """Variations simulated together: the step loop's cost per step is mostly fixed, so as many as memory allows."""
    return max(1, ACTOR_VARIATIONS // max(1, len(scenes[0].actors))) if scenes else 1


def make_drivers(batch: batch_setup.BatchSetup, settings: SimulationSettings) -> list:
    drivers = []
    n_v = batch.n_variations
    for a, col in enumerate(batch.columns):
        driver = load_driver(settings.ads, settings.ads_params) if col.is_ads else BehaviorDriver()
        ctx = DriverContext(
            role=col.role, behavior=col.behavior, actor_type=col.actor_type, dispositions=col.dispositions,
            n_variations=n_v, dt=settings.dt, limits=col.limits, length=batch.length[:, a],
            width=batch.width[:, a], cruise_speed=batch.cruise[:, a], trigger_time=batch.trigger_time[:, a],
            hold_until=batch.hold_until[:, a], lateral_target=batch.lateral_target[:, a],
            initial_offset=batch.d0[:, a], lane_width=batch.lane_width[:, a],
            condition_factor=batch.condition_factor, friction=batch.friction,
            params=_role_params(batch.scenes, col.role),
        )
        driver.reset(ctx)
        drivers.append(driver)
    return drivers


def _role_params(scenes, role: str) -> dict[str, np.ndarray]:
    """The scenes' numeric parameters of one role (`npc1_SPEED`, `EGO_SPEED` -> "SPEED"), one entry per
    variation (NaN where a scene lacks it): per-variation values, never the first scene's."""
    prefixes = (f"{role}_", f"{role.upper()}_")
    keys = set().union(*(scene.params.keys() for scene in scenes))  # the scenes of a program share their keys
    names = sorted({key.split("_", 1)[1] for key in keys if key.startswith(prefixes)})
    out: dict[str, np.ndarray] = {}
    for name in names:
        own, upper = f"{role}_{name}", f"{role.upper()}_{name}"
        raws = [scene.params.get(own, scene.params.get(upper)) for scene in scenes]
        out[name] = np.array([float(raw) if isinstance(raw, (int, float)) else np.nan for raw in raws])
    return out


def run_batch(batch: batch_setup.BatchSetup, recorder: Recorder) -> None:
    """Simulate one set-up batch and hand every step to the recorder."""
    settings = batch.settings
    dt, n_steps = settings.dt, settings.steps
    n_v, n_a = batch.n_variations, batch.n_actors
    limits = batch.columns
    accel_max = np.array([c.limits.accel_max for c in limits])[None, :]
    brake_max = np.array([c.limits.brake_max for c in limits])[None, :]
    steer_max = np.array([c.limits.steer_max for c in limits])[None, :]
    steer_rate = np.array([c.limits.steer_rate for c in limits])[None, :]
    speed_max = np.array([c.limits.speed_max for c in limits])[None, :]
    wheelbase = batch.length * np.array([c.limits.wheelbase_ratio for c in limits])[None, :]
    drivers = make_drivers(batch, settings)
    ranges = np.array([getattr(d, "perception_range", math.inf) for d in drivers])

    state = State(batch)
    fixed = Fixed(batch)
    veers = np.isfinite(batch.spin_rate).any(axis=0)
    recorder.begin(batch)
    _check_collisions(batch, state, recorder, 0.0, initial=True)
    lat_cmd = batch.d0.copy()
    variations = [scene.index for scene in batch.scenes]
    planned_cruise = batch.cruise.copy()
    meeting = batch.meeting
    for step in range(n_steps + 1):
        t = step * dt
        geo = _geometry(batch, state, t, fixed)
        recorder.record(step, t, state, geo, lat_cmd)
        if step == n_steps:
            break
        batch.pullout.step(t, state.s, state.v, batch.length, batch.hold_until, batch.invalid)
        idx, cruise = meeting.cruise(state.s, state.v, state.a, batch.length, batch.width, planned_cruise, batch.cruise)
        if len(idx):
            batch.cruise[idx, meeting.follower[idx]] = cruise  # the drivers hold views of these columns
        accel_cmd = np.zeros((n_v, n_a))
        observations = _observe_all(batch, state, geo, t, ranges, fixed)
        for a, driver in enumerate(drivers):
            if batch.columns[a].is_ads:  # the ADS under test gets read-only copies, and its action is checked
                action: Action = ads_step(driver, observations[a].read_only(), batch.columns[a].role, step,
                                          variations)
            else:  # a built-in behaviour driver never writes into its observation: no copies
                action = driver.step(observations[a])
            accel_cmd[:, a] = np.broadcast_to(np.asarray(action.accel, dtype=float), (n_v,))
            if action.lateral_offset is not None:
                lat_cmd[:, a] = np.broadcast_to(np.asarray(action.lateral_offset, dtype=float), (n_v,))
            else:
                lat_cmd[:, a] = 0.0
            if action.lose_control is not None:
                _lose_control(batch, state, a, np.asarray(action.lose_control, dtype=bool), action.spin_rate, t)
            elif veers[a]:
                # a planned sudden veer (plan: a lateral manoeuvre ending in an angle contact)
                _lose_control(batch, state, a, np.isfinite(batch.spin_rate[:, a]) & (t >= batch.trigger_time[:, a]),
                              None, t)
        _move(batch, state, accel_cmd, lat_cmd, dt, t + dt, accel_max, brake_max, steer_max, steer_rate,
              speed_max, wheelbase, fixed.lateral_rate)
        _check_collisions(batch, state, recorder, t + dt)
    recorder.end(batch, state)


def _lose_control(batch: batch_setup.BatchSetup, state: State, a: int, lose: np.ndarray, spin, t: float) -> None:
    """From now on actor a slides (impact.slide) yawing at the planned rate (else the driver's), its velocity
    veered by the planned drift angle: a loss of control planned from its impact (skid)."""
    newly = lose & ~state.lost[:, a] & ~state.free[:, a] & ~state.gone[:, a]
    if not newly.any():
        return
    driver_spin = np.broadcast_to(np.asarray(spin if spin is not None else 0.35, dtype=float), newly.shape)
    rate = np.where(np.isfinite(batch.spin_rate[:, a]), batch.spin_rate[:, a], driver_spin)
    drift = np.where(np.isfinite(batch.drift[:, a]), batch.drift[:, a], np.sign(rate) * DEFAULT_DRIFT)
    heading = state.yaw[:, a] + drift
    state.vx[:, a] = np.where(newly, state.v[:, a] * np.cos(heading), state.vx[:, a])
    state.vy[:, a] = np.where(newly, state.v[:, a] * np.sin(heading), state.vy[:, a])
    state.yaw_rate[:, a] = np.where(newly, rate, state.yaw_rate[:, a])
    state.spin[:, a] = np.where(newly, rate, state.spin[:, a])
    state.lost[:, a] |= newly
    state.free[:, a] |= newly
    state.lost_time[:, a] = np.where(newly, t, state.lost_time[:, a])


class State:
    """Dynamic state, arrays (V, A)."""

    def __init__(self, batch: batch_setup.BatchSetup):
        self.x = batch.x.copy()
        self.y = batch.y.copy()
        self.yaw = batch.yaw.copy()
        self.v = batch.speed.copy()
        self.a = np.zeros_like(self.x)
        self.yaw_rate = np.zeros_like(self.x)
        self.steer = np.zeros_like(self.x)
        self.s = batch.s0.copy()
        self.d = batch.d0.copy()
        self.d_ref = batch.d0.copy()
        self.lost = np.zeros(self.x.shape, dtype=bool)
        self.spin = np.zeros_like(self.x)
        self.lost_time = np.full(self.x.shape, np.nan)  # [s] when the actor lost control
        self.collided = np.zeros(self.x.shape, dtype=bool)  # has had a contact
        self.free = np.zeros(self.x.shape, dtype=bool)  # sliding after an impact (or a loss of control), out of
        # its driver's control
        self.vx = np.zeros_like(self.x)  # [m/s] velocity of a sliding vehicle (world frame)
        self.vy = np.zeros_like(self.x)
        n_a = self.x.shape[1]
        self.touching = np.zeros((self.x.shape[0], n_a, n_a), dtype=bool)  # pair (a < b) overlapped last check
        self.mass = np.array([c.limits.mass for c in batch.columns])[None, :] * np.ones_like(self.x)  # [kg]
        self.inertia = impact.yaw_inertia(self.mass, batch.length, batch.width)  # [kg m2]
        self.gone = np.zeros(self.x.shape, dtype=bool)  # reached the end of its route (left the map)
        self.gone_time = np.full(self.x.shape, np.nan)
        self.moved = np.zeros_like(self.x)  # [m] distance travelled
        self.prev_x, self.prev_y, self.prev_yaw = self.x.copy(), self.y.copy(), self.yaw.copy()


class Fixed:
    """What the step loop reads of the batch that no step changes, gathered once: each actor's junction entries
    and exits along its route (V, A, J), and for every observer a and its k-th other actor `others[a, k]` (in
    actor order) the pair's routes, sizes, conflict stations and priority, arrays (A, A - 1, V)."""

    def __init__(self, batch: batch_setup.BatchSetup):
        routes, n_a = batch.routes, batch.n_actors
        self.entries = routes.entry_s[batch.route]  # (V, A, J)
        self.exits = routes.entry_exit[batch.route]
        n_v, n_j = batch.route.shape[0], self.entries.shape[-1]
        if not batch.entry_control.shape == batch.entry_group.shape == self.entries.shape:
            raise AssertionError(f"junction entry tables disagree: {batch.entry_control.shape}, "
                                 f"{batch.entry_group.shape}, {self.entries.shape}")
        self.entry_rows = np.arange(n_v * n_a).reshape(n_v, n_a) * n_j  # flat index of each (v, a)'s first entry
        self.lateral_rate = batch.lateral_rate
        self.others = np.array([[b for b in range(n_a) if b != a] for a in range(n_a)],
                               dtype=np.intp).reshape(n_a, -1)
        others, observer = self.others, np.arange(n_a)[:, None]
        self.observer = observer
        self.r, self.la, self.wa = (np.ascontiguousarray(arr.T) for arr in (batch.route, batch.length, batch.width))
        r, la, wa = self.r, self.la, self.wa
        self.r_b, self.lb, self.wb = r[others], la[others], wa[others]
        lb, wb = self.lb, self.wb
        self.route_length = routes.length[r]
        self.unseen = batch.unseen[observer, others][..., None]
        self.in_path_half = (wa[:, None] + wb) / 2 + 0.3
        self.half_lengths = (la[:, None] + lb) / 2
        self.cs_a = routes.conflict_s[r[:, None], self.r_b]
        self.crosses = ~np.isnan(self.cs_a)
        cs_b = routes.conflict_s[self.r_b, r[:, None]]
        self.cs_b_less_1 = cs_b - 1.0
        clear_zone = wa[:, None] / 2 + 1.0
        self.zone_start, self.zone_end = cs_b - clear_zone, cs_b + clear_zone
        self.prio = batch.priority.transpose(1, 2, 0)[observer, others]
        self.half_lb, self.minus_half_wb = lb / 2, -wb / 2


class Geometry:
    """Per-step quantities derived from the state and the routes, shared by observations and the recorder."""

    __slots__ = (
        "control",
        "entry",
        "front",
        "in_junction_route",
        "junction",
        "junction_dist",
        "lane_width",
        "maneuver",
        "route_lane",
        "route_yaw",
        "signal",
        "speed_limit",
        "stop_line_dist",
    )


def _geometry(batch: batch_setup.BatchSetup, state: State, t: float, fixed: Fixed | None = None) -> Geometry:
    routes, r = batch.routes, batch.route
    g = Geometry()
    k, _ = routes.index(state.s)
    g.route_yaw = routes.yaw[r, k]
    g.route_lane = routes.lane[r, k]
    g.front = state.s + batch.length / 2
    if fixed is not None:
        entries, exits = fixed.entries, fixed.exits  # (V, A, J)
    else:  # the shared recorder of the other backends
        entries, exits = routes.entry_s[r], routes.entry_exit[r]
    rear = state.s - batch.length / 2
    g.in_junction_route = routes.junction[r, k] >= 0
    n_j = entries.shape[-1]
    # the current junction is the first one the vehicle has not yet cleared
    current = np.sum(exits <= rear[..., None], axis=-1)
    has = (current < n_j)
    cur = np.minimum(current, n_j - 1)
    at = (fixed.entry_rows if fixed is not None else np.arange(cur.size).reshape(cur.shape) * n_j) + cur
    entry_s = entries.reshape(-1)[at]  # each (variation, actor)'s entry `cur` of its (V, A, J) entries
    has &= np.isfinite(entry_s)
    g.entry = np.where(has, cur, -1)
    g.junction_dist = np.where(has, entry_s - g.front, np.nan)
    ctrl = batch.entry_control.reshape(-1)[at]
    g.control = np.where(has, ctrl, 0).astype(np.int8)
    g.stop_line_dist = np.where(has & (g.control > 0), entry_s - STOP_LINE_SETBACK - g.front, np.nan)
    g.maneuver = np.where(has, routes.entry_maneuver[r, cur], 0).astype(np.int8)
    g.junction = np.where(has, routes.entry_junction[r, cur], -1)
    group = batch.entry_group.reshape(-1)[at]
    sig = signals.signal_state(group, t, batch.phase[:, None])
    g.signal = np.where(g.control == CONTROL_SIGNAL, sig, SIGNAL_NONE).astype(np.int8)
    limit = routes.speed_limit[r, k]
    g.speed_limit = np.where(np.isnan(limit), batch.default_speed_limit, limit)
    g.lane_width = np.where(g.route_lane >= 0, batch.lane_width_table[np.maximum(g.route_lane, 0)],
                            LANE_WIDTH)
    return g


def _observe_all(batch: batch_setup.BatchSetup, state: State, geo: Geometry, t: float,
                 ranges: np.ndarray, fixed: Fixed) -> list[Observation]:
    """Every actor's `Observation` this step (`ranges` [m]: each driver's perception range).

    What actor a sees of each other actor is computed for all of them at once, as arrays (A, A - 1, V):
    observer a, its k-th other actor `others[a, k]` (in actor order), variations last (contiguous). The nearest
    vehicle of each kind is then kept by a loop over k, as each actor's own loop over the others would keep it.
    """
    n_a = batch.n_actors
    routes = batch.routes
    x, y, yaw, v, s, d, acc = (np.ascontiguousarray(arr.T) for arr in (state.x, state.y, state.yaw, state.v,
                                                                         state.s, state.d, state.a))
    r = fixed.r
    front, lane_w, target = (np.ascontiguousarray(arr.T) for arr in (geo.front, geo.lane_width,
                                                                      batch.lateral_target))
    others = fixed.others
    x_b, y_b, v_b, s_b, lb, wb = x[others], y[others], v[others], s[others], fixed.lb, fixed.wb
    dist_all = np.hypot(x_b - x[:, None], y_b - y[:, None])  # (A, A - 1, V)
    hidden = (dist_all > ranges[:, None, None]) | state.gone.T[others]
    visible = ~hidden
    # b's station on a's route minus a's, b's lateral offset from a's route, the route's heading there
    px, py, pyaw = (q[:, None] for q in routes.point(r, s))
    g0 = (x_b - px) * np.cos(pyaw) + (y_b - py) * np.sin(pyaw)
    qx, qy, qyaw = routes.point(r[:, None], s[:, None] + g0)
    ex, ey = x_b - qx, y_b - qy
    cq, sq = np.cos(qyaw), np.sin(qyaw)
    ds, lat = g0 + ex * cq + ey * sq, -ex * sq + ey * cq
    near_route = np.abs(ds) < 150.0
    rel_yaw = wrap_angle(yaw[others] - qyaw)
    speed_along = v_b * np.cos(rel_yaw)
    # an inattentive striker (setup.unseen_partners) does not see what it strikes in its path
    in_path = visible & near_route & (np.abs(lat - d[:, None]) < fixed.in_path_half) & (ds > 0) & ~fixed.unseen
    gap = ds - fixed.half_lengths
    in_target = visible & near_route & (np.abs(lat - target[:, None]) < lane_w[:, None] / 2 + wb / 4)
    ahead = in_target & (gap > -lb) & (ds >= 0)
    behind = in_target & (ds < 0)
    rear_gap = -ds - fixed.half_lengths
    # every vehicle whose path crosses ours ahead (for defensive drivers), and gap acceptance
    # against those with priority
    crossing = visible & fixed.crosses
    mine = fixed.cs_a - front[:, None]
    sb_front = s_b + fixed.half_lb
    sb_rear = s_b - fixed.half_lb
    theirs = fixed.cs_b_less_1 - sb_front
    ahead_both = crossing & (mine > 0) & (theirs > 0)
    v_b_min = np.maximum(v_b, 0.1)
    tta_b = theirs / v_b_min
    prio = fixed.prio & visible
    occupied = prio & (sb_front > fixed.zone_start) & (sb_rear < fixed.zone_end)
    approaching = prio & (sb_front <= fixed.zone_start)
    tta = (fixed.zone_start - sb_front) / v_b_min
    relevant = prio & (mine > fixed.minus_half_wb)
    accel_b = acc[others]

    shape = x.shape  # (A, V)
    lead_gap, lead_speed, lead_rel_yaw = np.full(shape, np.inf), np.full(shape, np.nan), np.full(shape, np.nan)
    tgt_front, tgt_rear, tgt_rear_speed = np.full(shape, np.inf), np.full(shape, np.inf), np.full(shape, np.nan)
    yield_tta, conflict_dist = np.full(shape, np.inf), np.full(shape, np.nan)
    cross_tta, cross_accel, cross_dist = np.full(shape, np.inf), np.full(shape, np.nan), np.full(shape, np.nan)
    for k in range(n_a - 1):  # the loop each actor ran over the others, in actor order
        closer = in_path[:, k] & (gap[:, k] < lead_gap)
        lead_gap = np.where(closer, gap[:, k], lead_gap)
        lead_speed = np.where(closer, speed_along[:, k], lead_speed)
        lead_rel_yaw = np.where(closer, rel_yaw[:, k], lead_rel_yaw)
        tgt_front = np.where(ahead[:, k] & (gap[:, k] < tgt_front), np.maximum(gap[:, k], 0.0), tgt_front)
        closer_rear = behind[:, k] & (rear_gap[:, k] < tgt_rear)
        tgt_rear = np.where(closer_rear, np.maximum(rear_gap[:, k], 0.0), tgt_rear)
        tgt_rear_speed = np.where(closer_rear, speed_along[:, k], tgt_rear_speed)
        sooner = ahead_both[:, k] & (tta_b[:, k] < cross_tta)
        cross_tta = np.where(sooner, tta_b[:, k], cross_tta)
        cross_accel = np.where(sooner, accel_b[:, k], cross_accel)
        cross_dist = np.where(sooner, mine[:, k], cross_dist)
        yield_tta = np.where(approaching[:, k] & (tta[:, k] < yield_tta), tta[:, k], yield_tta)
        conflict_dist = np.where(relevant[:, k] & ~(conflict_dist < mine[:, k]), mine[:, k], conflict_dist)
    yield_occ = occupied.any(axis=1)
    curvature, curve_speed = routes.curve_lookahead(r, s, v)
    seen = np.ones((n_a, n_a) + shape[1:], dtype=bool)  # (A, B, V): an actor always sees itself
    seen[fixed.observer, others] = visible
    others_x = np.where(seen, x[None], np.nan).transpose(0, 2, 1)
    others_y = np.where(seen, y[None], np.nan).transpose(0, 2, 1)
    route_remaining = fixed.route_length - s
    dt = batch.settings.dt
    return [Observation(
        t=t, dt=dt, x=x[a], y=y[a], yaw=yaw[a], speed=v[a],
        accel=acc[a], s=s[a], d=d[a], route_remaining=route_remaining[a],
        lane_width=lane_w[a], speed_limit=geo.speed_limit[:, a], curvature_ahead=curvature[a],
        curve_speed=curve_speed[a],
        lead_gap=lead_gap[a], lead_speed=lead_speed[a], lead_rel_yaw=lead_rel_yaw[a],
        control=geo.control[:, a], signal=geo.signal[:, a],
        stop_line_dist=geo.stop_line_dist[:, a], junction_dist=geo.junction_dist[:, a],
        in_junction=geo.in_junction_route[:, a], maneuver=geo.maneuver[:, a], yield_tta=yield_tta[a],
        yield_occupied=yield_occ[a], conflict_dist=conflict_dist[a], cross_tta=cross_tta[a],
        cross_accel=cross_accel[a], cross_dist=cross_dist[a], target_gap_front=tgt_front[a],
        target_gap_rear=tgt_rear[a], target_rear_speed=tgt_rear_speed[a], others_x=others_x[a],
        others_y=others_y[a], others_yaw=state.yaw, others_speed=state.v, collided=state.collided[:, a],
    ) for a in range(n_a)]


def _move(batch: batch_setup.BatchSetup, state: State, accel_cmd: np.ndarray, lat_cmd: np.ndarray, dt: float,
          t_next: float, accel_max, brake_max, steer_max, steer_rate, speed_max, wheelbase, lateral_rate) -> None:
    routes, r = batch.routes, batch.route
    frozen = state.gone | state.free
    state.prev_x, state.prev_y, state.prev_yaw = state.x.copy(), state.y.copy(), state.yaw.copy()
    # lateral reference moves toward the command at a bounded rate
    rate = lateral_rate[None, :] * dt
    state.d_ref += np.clip(lat_cmd - state.d_ref, -rate, rate)
    lookahead = pursuit_lookahead(state.v)
    tx, ty, tyaw = routes.point(r, state.s + lookahead)
    px = tx - np.sin(tyaw) * state.d_ref
    py = ty + np.cos(tyaw) * state.d_ref
    alpha = np.arctan2(py - state.y, px - state.x) - state.yaw
    alpha = wrap_angle(alpha)
    state.steer = steer_step(state.steer, alpha, lookahead, wheelbase, steer_rate, steer_max, dt)

    accel = np.clip(accel_cmd, -brake_max, accel_max)
    v_new = np.clip(state.v + accel * dt, 0.0, speed_max)
    v_new = np.where(frozen, 0.0, v_new)
    accel = np.where(frozen, 0.0, (v_new - state.v) / dt)
    v_mid = 0.5 * (state.v + v_new)
    yaw_rate = np.where(frozen, 0.0, bicycle_yaw_rate(v_mid, state.steer, wheelbase))
    x_new, y_new, yaw_new = bicycle_move(state.x, state.y, state.yaw, v_mid, yaw_rate, dt)
    sliding = state.free & ~state.gone
    if sliding.any():
        # only the sliding (variation, actor) elements, gathered flat: each element's arithmetic is its own
        rows = np.flatnonzero(sliding)
        vx0, vy0, yaw0, w0, collided, lost = (arr.reshape(-1)[rows] for arr in (
            state.vx, state.vy, state.yaw, state.yaw_rate, state.collided, state.lost))
        length, width = batch.length.reshape(-1)[rows], batch.width.reshape(-1)[rows]
        vx, vy, w = _slide_step(vx0, vy0, yaw0, w0, collided, batch.friction, length, width,
                                wheelbase.reshape(-1)[rows], dt)
        held = ~(t_next - state.lost_time.reshape(-1)[rows] > batch.spin_hold.reshape(-1)[rows])  # NaN: until rest
        spinning = lost & ~collided & held & (np.hypot(vx, vy) > impact.REST_SPEED)
        w = np.where(spinning, state.spin.reshape(-1)[rows], w)  # out of control the yaw is held until an impact
        # or rest
        v_slide = np.hypot(vx, vy)
        # (x_new ... v_new are this step's own arrays: written in place)
        x1, y1, yaw1 = impact.glide(state.x.reshape(-1)[rows], state.y.reshape(-1)[rows], yaw0, vx0, vy0, w0, vx, vy,
                                    w, dt)
        np.put(x_new, rows, x1)
        np.put(y_new, rows, y1)
        np.put(yaw_new, rows, yaw1)
        np.put(accel, rows, (v_slide - state.v.reshape(-1)[rows]) / dt)
        np.put(yaw_rate, rows, w)
        np.put(v_new, rows, v_slide)
        state.vx, state.vy = np.zeros_like(state.vx), np.zeros_like(state.vy)
        np.put(state.vx, rows, vx)
        np.put(state.vy, rows, vy)
    step_len = np.hypot(x_new - state.x, y_new - state.y)
    state.x, state.y = x_new, y_new
    state.yaw = wrap_angle(yaw_new)
    state.moved += step_len
    state.v = v_new
    state.a = accel
    state.yaw_rate = yaw_rate

    # project back onto the route: predict with the route heading, then correct along the tangent
    ryaw = routes.yaw_at(r, state.s)
    s_pred = state.s + (state.x - state.prev_x) * np.cos(ryaw) + (state.y - state.prev_y) * np.sin(ryaw)
    state.s, state.d, _ = routes.local_coordinates(r, state.x, state.y, s_pred)
    newly_gone = ~state.gone & (state.s >= routes.length[r] - batch.length / 2 - 0.5) & ~state.lost & ~state.free
    state.gone_time = np.where(newly_gone, t_next, state.gone_time)
    state.gone |= newly_gone


def _slide_step(vx, vy, yaw, yaw_rate, collided, friction: float, length, width, wheelbase, dt: float):
    """(vx, vy, yaw_rate) of sliding vehicles after a step: after an impact (`collided`) the tyre forces of each
    axle (impact.tyre_slide), before any (a planned skid) impact.slide; each model run on its own vehicles only."""
    if collided.all() or not collided.any():
        if collided.all():
            return impact.tyre_slide(vx, vy, yaw, yaw_rate, friction, length, width, wheelbase, dt)
        return impact.slide(vx, vy, yaw, yaw_rate, friction, length, width, dt)
    out = np.empty((3, len(vx)))
    skid = ~collided
    out[:, skid] = impact.slide(vx[skid], vy[skid], yaw[skid], yaw_rate[skid], friction, length[skid], width[skid],
                                dt)
    out[:, collided] = impact.tyre_slide(vx[collided], vy[collided], yaw[collided], yaw_rate[collided], friction,
                                         length[collided], width[collided], wheelbase[collided], dt)
    return out[0], out[1], out[2]


def _check_collisions(batch: batch_setup.BatchSetup, state: State, recorder: Recorder, t: float,
                      initial: bool = False) -> None:
    """Overlap of every pair; an onset (not touching at the last check) is a contact, recorded; every pair
    that touches and still approaches exchanges an impulse (impact.exchange).

    Pairs are taken in order (a, b), a < b: an exchange moves its two vehicles, so the pairs after it are
    tested on the moved state. Until the first pair that touches, all pairs are tested at once."""
    ia, ib = pair_indices(batch.n_actors)
    if not len(ia):
        return
    x, y, yaw, gone = state.x, state.y, state.yaw, state.gone
    L, W = batch.length, batch.width
    together = len(ia) > 1  # one pair: tested on its own
    if together:
        overlap_all = ~(gone[:, ia] | gone[:, ib]) & _overlapping(x[:, ia], y[:, ia], yaw[:, ia], L[:, ia],
                                                                  W[:, ia], x[:, ib], y[:, ib], yaw[:, ib],
                                                                  L[:, ib], W[:, ib])
    moved = np.zeros(len(x), dtype=bool)  # variations where an exchange moved vehicles back to their contact:
    # the remaining pairs are tested again there, on the new state (elsewhere the state is the one tested at once)
    for p, (a, b) in enumerate(zip(ia.tolist(), ib.tolist())):
        if not together:
            active = ~(state.gone[:, a] | state.gone[:, b])
            overlap = active & _overlapping(state.x[:, a], state.y[:, a], state.yaw[:, a], L[:, a], W[:, a],
                                            state.x[:, b], state.y[:, b], state.yaw[:, b], L[:, b], W[:, b])
        elif moved.any():
            rows = np.flatnonzero(moved)
            overlap = overlap_all[:, p].copy()
            overlap[rows] = ~(gone[rows, a] | gone[rows, b]) & _overlapping(
                state.x[rows, a], state.y[rows, a], state.yaw[rows, a], L[rows, a], W[rows, a],
                state.x[rows, b], state.y[rows, b], state.yaw[rows, b], L[rows, b], W[rows, b])
        else:
            overlap = overlap_all[:, p]
        onset = overlap & ~state.touching[:, a, b]
        state.touching[:, a, b] = overlap
        if not overlap.any():
            continue
        if initial:
            recorder.collision(onset, a, b, t, state, initial)
            continue  # a spawn overlap invalidates the variation; the vehicles are not stopped
        frac = _back_to_contact(batch, state, onset, a, b)
        _exchange(batch, state, recorder, overlap, onset, a, b, t - (1.0 - frac) * batch.settings.dt)
        moved |= onset  # _back_to_contact moved a and b there; _exchange changed velocities only


NEAR_MARGIN = 0.01  # [m] footprints whose centres are further apart than their half diagonals and this never touch


def _overlapping(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) -> np.ndarray:
    """`footprints_overlap` of arrays of one shape, its separating-axis test run only where the centres are within
    the two half diagonals (two footprints that touch share a point, so their centres are no further apart; the
    margin covers rounding): the same answers, most pairs rejected by one distance."""
    with np.errstate(invalid="ignore"):  # a NaN pose is never near
        near = np.hypot(xb - xa, yb - ya) <= (np.hypot(la, wa) + np.hypot(lb, wb)) / 2 + NEAR_MARGIN
    out = np.zeros(near.shape, dtype=bool)
    if near.any():
        i = np.flatnonzero(near)
        out.reshape(-1)[i] = footprints_overlap(*(q.reshape(-1)[i] for q in (xa, ya, yawa, la, wa, xb, yb, yawb,
                                                                               lb, wb)))
    return out


def _exchange(batch: batch_setup.BatchSetup, state: State, recorder: Recorder, overlap: np.ndarray,
              onset: np.ndarray, a: int, b: int, t: np.ndarray) -> None:
    """Impulse between a and b where they overlap; record the onsets with each vehicle's delta-v [m/s]."""
    idx = np.nonzero(overlap)[0]
    L, W = batch.length, batch.width

    def kin(k: int):
        free = state.free[idx, k]
        vx = np.where(free, state.vx[idx, k], state.v[idx, k] * np.cos(state.yaw[idx, k]))
        vy = np.where(free, state.vy[idx, k], state.v[idx, k] * np.sin(state.yaw[idx, k]))
        return np.stack([vx, vy]), state.yaw_rate[idx, k]

    poses = (state.x[idx, a], state.y[idx, a], state.yaw[idx, a], L[idx, a], W[idx, a],
             state.x[idx, b], state.y[idx, b], state.yaw[idx, b], L[idx, b], W[idx, b])
    nx, ny, px, py, penetration = impact.contact(*poses)
    (va, wa), (vb, wb) = kin(a), kin(b)
    ma, mb = state.mass[idx, a], state.mass[idx, b]
    va1, wa1, vb1, wb1, _ = impact.exchange(nx, ny, px, py, poses[0], poses[1], va, wa, ma, state.inertia[idx, a],
                                            poses[5], poses[6], vb, wb, mb, state.inertia[idx, b])
    n_v = batch.n_variations
    dva, dvb, cx, cy = (np.full(n_v, np.nan) for _ in range(4))
    dva[idx] = np.hypot(*(va1 - va))
    dvb[idx] = np.hypot(*(vb1 - vb))
    cx[idx], cy[idx] = px, py
    recorder.collision(onset, a, b, t, state, False, delta_v=(dva, dvb), point=(cx, cy))
    for k, vel, w, vel0, w0 in ((a, va1, wa1, va, wa), (b, vb1, wb1, vb, wb)):
        state.vx[idx, k], state.vy[idx, k] = vel
        state.yaw_rate[idx, k] = w
        state.v[idx, k] = np.hypot(*vel)
        state.free[idx, k] |= upsets(np.hypot(*(vel - vel0)), w - w0)  # else its driver drives on
        state.collided[idx, k] = True
    # the bodies do not pass through each other: pushed apart until they barely touch (impact.separate)
    # (the exchange changed velocities only: the poses, normal and penetration are the contact's)
    dxa, dya, dxb, dyb = impact.separate(*poses[:5], ma, *poses[5:], mb, frame=(nx, ny, penetration))
    state.x[idx, a] += dxa
    state.y[idx, a] += dya
    state.x[idx, b] += dxb
    state.y[idx, b] += dyb


def _back_to_contact(batch: batch_setup.BatchSetup, state: State, hit: np.ndarray, a: int, b: int) -> np.ndarray:
    """Move the two vehicles of each hit variation back along their last step to the moment of first contact.

    A 10 Hz step can carry two cars a metre or more into each other; resting them where they
    first touched keeps the recorded contact geometry (and so its class) true. Returns, per
    variation, the fraction of the step at which contact began (1 where nothing was moved).
    """
    idx = np.nonzero(hit)[0]
    frac = np.ones(batch.n_variations)
    if len(idx) == 0:
        return frac

    def pose(actor: int, f: np.ndarray):
        yaw0, yaw1 = state.prev_yaw[idx, actor], state.yaw[idx, actor]
        dyaw = wrap_angle(yaw1 - yaw0)
        return (state.prev_x[idx, actor] + f * (state.x[idx, actor] - state.prev_x[idx, actor]),
                state.prev_y[idx, actor] + f * (state.y[idx, actor] - state.prev_y[idx, actor]), yaw0 + f * dyaw)

    hi = touch_fraction(lambda f: pose(a, f), lambda f: pose(b, f), batch.length[idx, a], batch.width[idx, a],
                        batch.length[idx, b], batch.width[idx, b], len(idx))
    for actor in (a, b):
        x, y, yaw = pose(actor, hi)
        state.x[idx, actor], state.y[idx, actor], state.yaw[idx, actor] = x, y, yaw
    frac[idx] = hi
    return frac
