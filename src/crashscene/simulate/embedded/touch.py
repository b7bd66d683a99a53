"""Where two actors of a written junction contact touch with the written class, found on the paths they drive.

A junction plan times a written contact at the point where the two routes first meet (`world._conflicts`): the
striker's front at the struck car's side there (arrivals._meeting_offset, sync.Meeting). Where two
paths cross, that point has about the crossing's relative heading. Where they join (a turn into a lane), they
meet almost aligned, and a contact there is a rear-end or a sideswipe by rules.md's classes; the angle class
happens earlier on the turn, where the turner's nose enters the other's path while the turner is still turned
well across it. `class_meeting` finds where: it drives both actors along their routes as the simulator's drivers
steer (pure pursuit, `swerve`), shifts one against the other in time, takes each shift's first touch (the same
footprints and classes as the monitor's, `geometry`) and returns the touch at the middle of the widest run of
shifts that have the written class (the written areas preferred): the two centres' stations there. A driver the
oracle charges with not yielding has entered the other's path before the other is past it (rules.md measures the
other's time to reach the conflict area then), so its front is ahead of the other's centre at the touch. The plan
and the closed-loop meeting then time the pair to it instead of the routes' meeting point; an actor that stops at
its line first waits there and pulls out when its partner is as far from the touch as it takes from rest
(`Waiting`, pullout.PullOut).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crashscene.geometry import (
    classify_contact,
    contact_areas,
    footprint_separation,
    heading_difference,
    pose_class,
    relative_position,
    touch_fraction,
    wrap_angle,
)
from crashscene.simulate.drivers.base import idm_accel
from crashscene.simulate.drivers.longitudinal import CURVE_FLOOR
from crashscene.simulate.embedded import cascade, swerve
from crashscene.simulate.embedded.vehicles import VehicleLimits
from crashscene.simulate.roads import ROUTE_DS

DT = 0.05  # [s] step of the predicted paths and of the time shifts between them
BEFORE = 30.0  # [m] a predicted path starts this far before the routes' meeting point (or at its stop line)
AFTER = 15.0  # [m] ...and ends this far after it
SHIFTS = 2.5  # [s] the time shifts tried, to either side of both reaching the routes' meeting point together
ROBUST = 0.15  # [s] a shift is counted with the shifts this near it: the meeting is not kept to the step
HORIZON = 30.0  # [s] a predicted path ends after this long at the latest
CLASS_MARGIN = 2.0  # [deg] a chosen touch's relative heading is this far inside its class's range (a predicted
# path's heading is off the driven one by about that much where a turn is cut)
PATHS_KEPT = 256  # [-] predicted drives kept per batch's route arrays (driven_path)
AREA_WEIGHT = 0.05  # [-] a written area matched counts this much against one more robust shift


@dataclass(frozen=True)
class Mover:
    """One actor of the pair: its route, the station [m] where its route meets the other's, its planned speed
    [m/s], the station [m] of its centre at rest at a stop line it pulls away from (None: it drives through at
    its speed), its body [m] and its vehicle limits."""

    route: int
    meet: float
    speed: float
    rest: float | None
    length: float
    width: float
    limits: VehicleLimits
    yields_not: bool = False  # its oracle charges it with not yielding to the other (a yield code)


def needs_moving(arrays, r_s: int, cs_s: float, r_t: int, cs_t: float, klass: str | None) -> bool:
    """Whether the routes' meeting point (stations cs_s on the striker's route r_s, cs_t on the struck one's r_t)
    cannot give the written class: it is an angle contact and the two headings there are outside the angle range
    anywhere along a car's length around it on the struck route (where arrivals.struck_offset could place the struck
    centre); paths that cross keep their meeting."""
    if klass != "angle":
        return False
    n = arrays.yaw.shape[1] - 1
    yaw_s = arrays.yaw[r_s, min(int(cs_s / ROUTE_DS), n)]
    k = np.clip(((cs_t + np.linspace(-2.5, 2.5, 11)) / ROUTE_DS).astype(int), 0, n)
    return not bool(np.any(classify_contact(heading_difference(yaw_s, arrays.yaw[r_t, k])) == "angle"))


def driven_path(arrays, m: Mover) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """`drive`, kept on the route arrays per mover (a batch's variations share their routes, and often a mover: a
    turning car held to its curve's speed), up to PATHS_KEPT of them; the arrays returned may be shared, not to be
    written to."""
    paths = arrays.__dict__.setdefault("_driven_paths", {})
    if m in paths:
        return paths[m]
    path = drive(arrays, m)
    if len(paths) < PATHS_KEPT:
        paths[m] = path
    return path


def drive(arrays, m: Mover) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(time [s], x, y [m], yaw [rad], station [m]) every DT of actor m driving its route as the simulator's
    scripted driver does: pure pursuit at the lookahead of its speed, bounded wheel angle and rate, kinematic
    bicycle (simulator._move), its speed by the free-road IDM towards its planned speed, held down to the speed
    its curves ahead allow (drivers.longitudinal.desired_speed, world.curve_lookahead); from BEFORE its meeting
    point at its planned speed, or from rest at its stop line (`Mover.rest`), to AFTER it."""
    r = np.array(m.route)
    start = max(m.meet - BEFORE if m.rest is None else max(m.rest, m.meet - BEFORE), 0.0)
    x, y, yaw = (float(q) for q in arrays.point(r, np.array(start)))
    s, v = start, (m.speed if m.rest is None else 0.0)
    steer = 0.0
    wheelbase = m.limits.wheelbase_ratio * m.length
    rows = []
    t = 0.0
    end = min(m.meet + AFTER, float(arrays.length[m.route]) - 1.0)
    while s < end and t < HORIZON:
        rows.append((t, x, y, yaw, s))
        _, curve = arrays.curve_lookahead(r, np.array(s), np.array(v))
        desired = max(min(m.speed, max(float(curve), CURVE_FLOOR)), 0.1)
        accel = float(idm_accel(np.array(v), np.array(desired), np.array(np.inf), np.array(np.nan),
                                m.limits.accel_max, m.limits.brake_comfort, 0.0))  # on a free road
        v_new = max(v + accel * DT, 0.0)
        look = float(swerve.lookahead(np.array(v)))
        tx, ty, _ = (float(q) for q in arrays.point(r, np.array(s + look)))
        alpha = wrap_angle(float(np.arctan2(ty - y, tx - x)) - yaw)
        steer = float(swerve.steer_step(np.array(steer), np.array(alpha), np.array(look), wheelbase,
                                        m.limits.steer_rate, m.limits.steer_max, DT))
        v_mid = 0.5 * (v + v_new)
        x, y, yaw = (float(q) for q in swerve.bicycle_move(x, y, yaw, v_mid,
                                                           swerve.bicycle_yaw_rate(v_mid, steer, wheelbase), DT))
        s_new, _, _ = arrays.local_coordinates(r, np.array(x), np.array(y), np.array(s + v_mid * DT))
        s = float(s_new)
        v = v_new
        t += DT
    out = np.array(rows)
    return out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 4]


@dataclass(frozen=True)
class Waiting:
    """A touch one of whose actors stops at its line first: it waits there and pulls out (pullout.PullOut) when its
    partner is as far in time from the touch as it takes from rest: the two actors, its line's station, the
    partner's front's station at the touch, that time [s], its centre's station at rest [m] and its speed at the
    touch [m/s] (from rest further back it takes longer, by the extra distance at that speed)."""

    actor: int
    partner: int
    line: float
    partner_front: float
    tta: float
    rest: float
    touch_speed: float


@dataclass(frozen=True)
class Touch:
    """Where the pair touches: each centre's station [m] on its route, when [s] each is there on its predicted
    path (from the path's start: from rest at its line for an actor that stops there) and how fast."""

    striker_s: float
    struck_s: float
    striker_t: float
    struck_t: float
    striker_v: float  # [m/s] each one's speed there
    struck_v: float


def class_meeting(arrays, striker: Mover, struck: Mover, wanted: tuple[str, str | None, str | None]
                  ) -> Touch | None:
    """Where the pair first touches with the written class `wanted[0]` (and, preferred, the striker's and the
    struck car's written areas), on the paths they drive (`driven_path`) shifted against each other in time: the
    middle of the widest run of shifts with the class (CLASS_MARGIN inside its range), counted over ROBUST to
    either side. None when no shift gives the class."""
    klass, area_s, area_t = wanted
    ts, xs, ys, yaws, ss = driven_path(arrays, striker)
    tt, xt, yt, yawt, st = driven_path(arrays, struck)
    if len(ts) < 3 or len(tt) < 3:
        return None
    # shift 0: both reach the routes' meeting point at once
    t_s0 = float(np.interp(striker.meet, ss, ts))
    t_t0 = float(np.interp(struck.meet, st, tt))
    shifts = np.arange(-SHIFTS, SHIFTS + 1e-9, DT)
    # the striker's time at each of the struck actor's steps, per shift (n_shift, n_t)
    t_at = tt[None, :] - t_t0 + t_s0 + shifts[:, None]
    inside = (t_at >= ts[0]) & (t_at <= ts[-1])

    yaws = np.unwrap(yaws)

    def striker_pose(t):
        return np.interp(t, ts, xs), np.interp(t, ts, ys), np.interp(t, ts, yaws)

    px, py, pyaw = striker_pose(t_at)
    gap = footprint_separation(px, py, pyaw, striker.length, striker.width, xt[None, :], yt[None, :],
                               yawt[None, :], struck.length, struck.width)
    touching = (gap <= 0) & inside
    n_shift = len(shifts)
    k = np.argmax(touching, axis=1)
    rows = np.nonzero(k > 0)[0]  # a first touch after the shift's first step (argmax is 0 where none touches)
    ok = np.zeros(n_shift, dtype=bool)
    score = np.zeros(n_shift)
    stations = np.full((n_shift, 6), np.nan)  # the two stations [m], times [s] and speeds [m/s] of each touch
    if len(rows):
        k1 = k[rows]
        k0 = k1 - 1

        def mine(f, rows=rows, k0=k0, k1=k1):
            return striker_pose(t_at[rows, k0] + f * (t_at[rows, k1] - t_at[rows, k0]))

        def theirs(f, k0=k0, k1=k1):
            return (xt[k0] + f * (xt[k1] - xt[k0]), yt[k0] + f * (yt[k1] - yt[k0]),
                    yawt[k0] + f * (yawt[k1] - yawt[k0]))

        n = len(rows)
        ls, ws, lt, wt = (np.full(n, size) for size in (striker.length, striker.width, struck.length, struck.width))
        f = touch_fraction(mine, theirs, ls, ws, lt, wt, n)
        t_s = t_at[rows, k0] + f * (t_at[rows, k1] - t_at[rows, k0])
        xa, ya, yawa = striker_pose(t_s)
        xb, yb, yawb = theirs(f)
        got, rel, _, _ = pose_class(xa, ya, yawa, ls, ws, xb, yb, yawb, lt, wt)
        a_s, a_t = contact_areas(xa, ya, yawa, ls, ws, xb, yb, yawb, lt, wt)
        # the class with a margin (the predicted heading is off the driven one by a few degrees), the written
        # areas only to choose among equally robust touches
        ok[rows] = (got == klass) & (cascade.class_margin(rel, klass) >= CLASS_MARGIN)
        # a driver charged with not yielding entered the other's path before the other was past it (rules.md: the
        # other's time to reach the conflict area is measured then): at the touch its front is ahead of the other's
        # centre, along the other's heading
        for me, pose, other in ((striker, (xa, ya, yawa), (xb, yb, yawb)), (struck, (xb, yb, yawb), (xa, ya, yawa))):
            if me.yields_not:
                fx = pose[0] + me.length / 2 * np.cos(pose[2])
                fy = pose[1] + me.length / 2 * np.sin(pose[2])
                ok[rows] &= relative_position(*other, fx, fy)[0] >= 0.0
        score[rows] = np.where(ok[rows], 1.0 + AREA_WEIGHT * ((a_s == area_s).astype(float) + (a_t == area_t)), 0.0)
        vs, vt = np.gradient(ss, ts), np.gradient(st, tt)
        stations[rows] = np.stack([np.interp(t_s, ts, ss), st[k0] + f * (st[k1] - st[k0]), t_s, tt[k0] + f * DT,
                                   np.interp(t_s, ts, vs), vt[k0] + f * (vt[k1] - vt[k0])], axis=1)
    if not ok.any():
        return None
    w = int(round(ROBUST / DT))
    around = np.convolve(np.pad(score, w), np.ones(2 * w + 1), mode="valid")
    around = np.where(ok, around, -1.0)
    tied = np.nonzero(around == around.max())[0]
    best = int(tied[len(tied) // 2])  # the middle of the most robust shifts
    return Touch(*(float(q) for q in stations[best]))
