"""A side slap after an offset angle impact: where along the struck car's side the striker's front must meet it
so that the two cars, turned by the impulse, touch again side to side.

A front striking a side ahead of the struck car's centre turns the struck car away from the striker's path (the
normal impulse's moment about its centre beats the opposite moment of the friction along its side), and the
friction turns the striker's front along with the struck car's motion: the two rotate opposite ways, and the
struck car's rear swings into the striker's side while they are still close (impact: the bodies do not pass
through each other, so they meet face to face). The sides meet nearly parallel, far inside the sideswipe range
(rules.md), so the slap's class does not hinge on its timing; whether it happens does, on where along the struck
side the first touch is, and the first touch must keep its own (angle) class: a touch further ahead on a turning
car meets it less far through its turn. `slap_offset` measures both for every candidate touch along the struck
side, on the paths the two drive (touch.driven_path: the simulator's steering, so the headings at the touch are
the driven ones, not the lane's), with the simulator's own contact physics (`after_touch`), and returns the
middle of the widest run of touches that give both with a margin. Where none does (a turner crossing the
striker's lane early in its turn is still turned too little there for an angle contact ahead of its centre), the
plan keeps its usual touch and no slap is planned.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from crashscene.geometry import classify_contact, footprint_separation, heading_difference, pose_class, relative_position
from crashscene.simulate.embedded import cascade, impact, rollout, touch

STEP = 0.1  # [m] between candidate touches along the struck side
HORIZON = 2.5  # [s] a slap is looked for this long after the first touch
FIRST_MARGIN = 5.0  # [deg] the first touch's relative heading is this far inside its class's range
SLAP_MARGIN = 15.0  # [deg] ...and the slap's inside the sideswipe range
BISECTIONS = 8  # [-] halvings of a step of the striker's path to find where it first touches


@dataclass(frozen=True)
class Body:
    """One vehicle of the pair: how it drives to the meeting (touch.Mover: its route, the routes' meeting point on
    it, its speed there, body and limits) and its mass [kg]."""

    mover: touch.Mover
    mass: float


def slaps_after(contacts, striking: str, struck: str) -> bool:
    """Whether the written sequence (striking, struck, class, ... per contact, in order) has the pair's first
    contact an angle one and the same pair's next contact a sideswipe, with no other contact of either in between:
    a side slap after an offset angle impact."""
    pair = {striking, struck}
    mine = [c for c in contacts if {c[0], c[1]} & pair]
    return (len(mine) >= 2 and {mine[0][0], mine[0][1]} == pair and {mine[1][0], mine[1][1]} == pair
            and mine[0][2] == "angle" and mine[1][2] == "sideswipe")


def slap_offset(arrays, striker: Body, struck: Body, friction: float, dt: float) -> float | None:
    """[m] how far past the striker's path the struck centre is when the striker's front meets its side
    (arrivals.struck_offset's terms; negative: short of it) for a slap to follow; None when no touch along the struck
    side gives both the angle first touch and the slap with their margins. Each car drives its route as its
    driver steers (touch.driven_path, from before the routes' meeting point `mover.meet`); the struck centre is
    `d` short of its meeting point, and the striker's front meets its side where the striker's path first
    touches it there; their velocities and yaw rates are the driven paths' at those points."""
    paths = [touch.driven_path(arrays, b.mover) for b in (striker, struck)]
    if min(len(p[0]) for p in paths) < 3:
        return None
    (ts, xs_, ys_, yaws_, ss), (tt, xt_, yt_, yawt_, st) = paths
    yaws_, yawt_ = np.unwrap(yaws_), np.unwrap(yawt_)
    half = struck.mover.length / 2
    d = np.arange(-half + 0.3, half - 0.05, STEP)
    n = len(d)
    t_t = np.interp(struck.mover.meet - d, st, tt)
    xt, yt, yawt = (np.interp(t_t, tt, q) for q in (xt_, yt_, yawt_))
    ls, ws, lt, wt = striker.mover.length, striker.mover.width, struck.mover.length, struck.mover.width

    def at(t):
        return [np.interp(t, ts, q) for q in (xs_, ys_, yaws_)]

    def gap(t):
        return footprint_separation(*at(t), ls, ws, xt, yt, yawt, lt, wt)

    # the striker's front reaches the struck side: its first touch along the striker's path, then bisected
    grid = np.arange(ts[0], ts[-1], touch.DT)
    touching = gap(grid[:, None]) <= 0  # (n_grid, n)
    k = np.argmax(touching, axis=0)
    reached = touching.any(axis=0) & (k > 0)
    lo, hi = grid[np.maximum(k - 1, 0)], grid[k]
    for _ in range(BISECTIONS):
        mid = (lo + hi) / 2
        touching = gap(mid) <= 0
        hi = np.where(touching, mid, hi)
        lo = np.where(touching, lo, mid)
    xs, ys, yaws = at(hi)
    first, rel, _, _ = pose_class(xs, ys, yaws, ls, ws, xt, yt, yawt, lt, wt)
    ok = reached & (first == "angle") & (cascade.class_margin(rel, "angle") >= FIRST_MARGIN)
    if not ok.any():
        return None

    def motion(t, times, x, y, yaw):
        return [np.interp(t, times, np.gradient(q, times)) for q in (x, y, yaw)]

    margin = after_touch(([xs, ys, yaws], [xt, yt, yawt]),
                         (motion(hi, ts, xs_, ys_, yaws_), motion(t_t, tt, xt_, yt_, yawt_)),
                         (striker, struck), np.ones(n), friction, dt)
    ok &= margin >= SLAP_MARGIN
    if not ok.any():
        return None
    # the middle of the widest run of candidate touches that give both
    edges = np.diff(np.concatenate([[0], ok.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    widest = int(np.argmax(ends - starts))
    return -float(d[(starts[widest] + ends[widest] - 1) // 2])


def after_touch(poses, motion, bodies, one: np.ndarray, friction: float, dt: float) -> np.ndarray:
    """[deg] (N,) how far inside the sideswipe range (side to side) the pair's next touch after a first one is
    (cascade.class_margin; -inf where they do not touch again within HORIZON), from the first touch's poses
    ([x, y, yaw] per body, (N,) each) and motions ([vx, vy, yaw rate] [m/s, rad/s]), stepped by the simulator's
    `dt` [s] as it steps them (rollout.contact_steps, the one copy of that stepping: the impulse at every check
    they overlap, their separation, a body one impulse upsets sliding on its tyres, one it does not driven on by
    its driver at its speed, turning at the yaw rate it had at the first touch, as the simulator's driver does,
    not carried on at the impulse's velocity and yaw rate); a touch again is an overlap after a check apart,
    classed where they first touch within the step."""
    n = len(one)

    def body(k: int) -> rollout.Bodies:
        b = bodies[k]
        x, y, yaw = (np.asarray(q, dtype=float) * one for q in poses[k])
        vx, vy, w = (np.asarray(q, dtype=float) * one for q in motion[k])
        return rollout.Bodies(x, y, yaw, vx, vy, w, b.mover.length * one, b.mover.width * one, b.mass * one,
                              b.mover.limits.wheelbase_ratio * b.mover.length * one, np.zeros(n, dtype=bool),
                              np.array(w, copy=True))

    a, b = body(0), body(1)
    half_length, half_width = (a.length + b.length) / 2, (a.width + b.width) / 2
    out = np.full(n, -np.inf)
    done = np.zeros(n, dtype=bool)
    for step in rollout.contact_steps(a, b, friction, dt, int(round(HORIZON / dt)), at_contact=np.ones(n, dtype=bool)):
        out, done = touched_again(step, out, done, half_length, half_width)
        still = [(np.hypot(q.vx, q.vy) < impact.REST_SPEED) & (np.abs(q.w) < impact.REST_YAW_RATE) for q in (a, b)]
        if (done | (still[0] & still[1] & ~step.overlap)).all():
            break  # every pair slapped, or at rest apart
    return out


def touched_again(step: rollout.Step, out: np.ndarray, done: np.ndarray, half_length, half_width):
    """`after_touch`'s margins and slapped pairs (N,) after one more step: each pair not yet slapped that touches
    again in it keeps the larger of its margin and this touch's (cascade.class_margin inside the sideswipe range,
    side to side; -inf for a touch of another class), classed at its poses where they first touch."""
    onset = step.onset & ~done
    if not onset.any():
        return out, done
    xa, ya, yawa, xb, yb, yawb = step.contact
    rel = heading_difference(yawa, yawb)
    lon, lat = relative_position(xa, ya, yawa, xb, yb)
    klass = classify_contact(rel, lon, lat, half_length, half_width)
    margin = np.where(klass == "sideswipe", cascade.class_margin(rel, "sideswipe", side=True), -np.inf)
    return np.where(onset & (margin > out), margin, out), done | (onset & (klass == "sideswipe"))
