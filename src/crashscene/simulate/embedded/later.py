"""Later contacts of a written crash sequence, closed loop: a vehicle still under its driver's control meets one
that an earlier contact set sliding.

In reproduce mode every contact after the first of the DSL's `collisions` between an actor that an earlier
contact has already set sliding (`free`) and one that is still driven is timed like the first contact is
(sync.Meeting): once the free vehicle slides, its motion until rest is predicted with the simulator's own
slide (`impact.slide`, exact until it touches something else), and the driven vehicle's cruise speed is set
so that, keeping to its route, it first touches the sliding one as the written contact says (its class, and
the area of each vehicle where it can). Only its speed changes, from waiting up to FASTER times its planned
cruise: the plan times, it never steers. The prediction is renewed every REPLAN seconds, so what the
driver's response and a further contact change is corrected as it happens.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crashscene.geometry import (
    classify_contact,
    footprint_area,
    footprints_overlap,
    heading_difference,
    relative_position,
)
from crashscene.simulate.embedded import cascade, impact

HORIZON = 6.0  # [s] how far ahead a sliding vehicle's motion is predicted (it rests sooner, mostly)
REPLAN = 0.5  # [s] the prediction and the chosen speed are renewed this often
SPEEDS = 31  # candidate cruise speeds of the driven vehicle, from waiting to FASTER times its planned cruise
FASTER = 1.3  # [-] a driven vehicle may gain this much on its planned cruise to meet (sync.SYNC_RANGE: 1.5)
BRAKE = 3.0  # [m/s2] how fast a driver slows to a lower cruise (drivers: the IDM's comfortable braking)
GAIN = 0.7  # [-] fraction of its full throttle a driver uses to regain its cruise
DRIVEN = ("go_forward", "accelerate", "decelerate", "turn_left", "turn_right", "u_turn")


@dataclass(frozen=True)
class LaterContact:
    """One written later contact between a vehicle sliding after an earlier contact (`free`) and one still
    driven (`driven`), as actor columns, with its class and the area of each."""

    free: int
    driven: int
    klass: str
    area_free: str
    area_driven: str


def later_contacts(contacts: tuple[tuple[str, str, str, str, str], ...], roles: list[str],
                   drivable: list[bool]) -> list[LaterContact]:
    """The written contacts after the first (striking, struck, class, striking area, struck area) in which
    exactly one actor was in an earlier contact and the other, not yet, drives (`drivable` per column)."""
    out: list[LaterContact] = []
    involved: set[str] = set()
    for k, (striking, struck, klass, area_s, area_t) in enumerate(contacts):
        pair = (striking, struck)
        if k > 0 and all(r in roles for r in pair) and striking != struck:
            earlier = [r in involved for r in pair]
            if earlier[0] != earlier[1]:
                free, driven = pair if earlier[0] else pair[::-1]
                area_f, area_d = (area_s, area_t) if free == striking else (area_t, area_s)
                if drivable[roles.index(driven)]:
                    out.append(LaterContact(roles.index(free), roles.index(driven), klass, area_f, area_d))
        involved.update(pair)
    return out


@dataclass
class LaterMeetings:
    """Per written later contact (`contacts`, S of them) and variation (V,): the cruise speed [m/s] chosen for
    the driven vehicle (NaN: none yet, it drives as planned) and when it is next renewed [s]."""

    contacts: list[LaterContact]
    speed: np.ndarray  # (V, S)
    renew: np.ndarray  # (V, S)

    @classmethod
    def none(cls, n_v: int) -> LaterMeetings:
        return cls([], np.zeros((n_v, 0)), np.zeros((n_v, 0)))

    @classmethod
    def of(cls, contacts: list[LaterContact], n_v: int) -> LaterMeetings:
        return cls(contacts, np.full((n_v, len(contacts)), np.nan), np.zeros((n_v, len(contacts))))

    def step(self, t: float, dt: float, state, batch) -> None:
        """Renew the cruise speeds due at time t [s]: where the free vehicle slides and the driven one has not
        yet touched anything; `state` is the simulator's State, `batch` its BatchSetup (cruise, trigger_time
        columns are the drivers' views)."""
        for k, c in enumerate(self.contacts):
            f, q = c.free, c.driven
            live = state.free[:, f] & state.collided[:, f] & ~state.collided[:, q] & ~state.free[:, q] \
                & ~state.gone[:, q] & ~state.gone[:, f]
            due = np.nonzero(live & (t >= self.renew[:, k]))[0]
            if len(due) == 0:
                continue
            self.renew[due, k] = t + REPLAN
            speed = self._choose(due, c, state, batch, dt)
            chosen = np.isfinite(speed)
            idx = due[chosen]
            if len(idx) == 0:
                continue
            self.speed[idx, k] = speed[chosen]
            batch.cruise[idx, q] = speed[chosen]
            # the meeting's speed replaces a scripted slow-down or stop that has not begun
            batch.trigger_time[idx, q] = np.inf

    def _choose(self, idx: np.ndarray, c: LaterContact, state, batch, dt: float) -> np.ndarray:
        """(len(idx),) the cruise speed [m/s] of the driven vehicle that makes its first touch of the sliding
        one the written contact, nearest its planned cruise; NaN where none does."""
        f, q = c.free, c.driven
        steps = int(round(HORIZON / dt))
        # the sliding vehicle until rest, as the simulator will move it (N, T)
        fx, fy, fyaw = cascade.slide_path(state.x[idx, f], state.y[idx, f], state.yaw[idx, f], state.vx[idx, f],
                                          state.vy[idx, f], state.yaw_rate[idx, f], batch.friction,
                                          batch.length[idx, f], batch.width[idx, f], dt, steps)
        # the driven vehicle along its route at its current offset, for each candidate cruise (N, G, T)
        v0 = state.v[idx, q]
        top = FASTER * np.maximum(batch.cruise[idx, q], v0)
        grid = np.linspace(0.0, 1.0, SPEEDS)[None, :] * top[:, None]
        accel = GAIN * batch.columns[q].limits.accel_max
        s = station_profile(state.s[idx, q], v0, grid, accel, dt, steps)
        r = batch.route[idx, q][:, None, None]
        px, py, pyaw = batch.routes.point(r, s)
        d = state.d[idx, q][:, None, None]
        qx, qy = px - np.sin(pyaw) * d, py + np.cos(pyaw) * d
        lq, wq = batch.length[idx, q][:, None, None], batch.width[idx, q][:, None, None]
        lf, wf = batch.length[idx, f][:, None, None], batch.width[idx, f][:, None, None]
        X, Y, YAW = fx[:, None, :], fy[:, None, :], fyaw[:, None, :]
        touch = footprints_overlap(qx, qy, pyaw, lq, wq, X, Y, YAW, lf, wf)
        first = np.argmax(touch, axis=2)  # (N, G)
        hit = touch.any(axis=2)
        n, g = np.meshgrid(np.arange(len(idx)), np.arange(SPEEDS), indexing="ij")
        pick = (n, g, first)
        Lq, Wq, Lf, Wf = (np.broadcast_to(a, touch.shape)[pick] for a in (lq, wq, lf, wf))
        xq, yq, yq_yaw = qx[pick], qy[pick], pyaw[pick]
        xf, yf, yf_yaw = (np.broadcast_to(a, touch.shape)[pick] for a in (X, Y, YAW))
        rel = heading_difference(yq_yaw, yf_yaw)
        lon, lat = relative_position(xq, yq, yq_yaw, xf, yf)
        klass = classify_contact(rel, lon, lat, (Lq + Lf) / 2, (Wq + Wf) / 2)
        flat = [np.ravel(a) for a in (xq, yq, yq_yaw, Lq, Wq, xf, yf, yf_yaw, Lf, Wf)]
        _, _, cx, cy = (a.reshape(xq.shape) for a in impact.contact_frame(*flat))
        area_q = footprint_area(*relative_position(xq, yq, yq_yaw, cx, cy), Lq, Wq)
        area_f = footprint_area(*relative_position(xf, yf, yf_yaw, cx, cy), Lf, Wf)
        good = hit & (klass == c.klass)
        both = good & (area_q == c.area_driven) & (area_f == c.area_free)
        good = np.where(both.any(axis=1, keepdims=True), both, good)
        cost = np.where(good, np.abs(grid - batch.cruise[idx, q][:, None]), np.inf)
        best = np.argmin(cost, axis=1)
        rows = np.arange(len(idx))
        return np.where(np.isfinite(cost[rows, best]), grid[rows, best], np.nan)


def station_profile(s0, v0, target, accel: float, dt: float, steps: int) -> np.ndarray:
    """(N, G, steps) stations [m] of vehicles at s0 [m] and speed v0 [m/s] (N,) that slow at BRAKE or gain
    speed at `accel` [m/s2] to each target speed (N, G) [m/s], then hold it."""
    v = np.broadcast_to(v0[:, None], target.shape).astype(float)
    s = np.broadcast_to(s0[:, None], target.shape).astype(float)
    out = np.zeros(target.shape + (steps,))
    for k in range(steps):
        v1 = np.clip(target, v - BRAKE * dt, v + accel * dt)
        s = s + 0.5 * (v + v1) * dt
        v = v1
        out[..., k] = s
    return out
