"""Two vehicles through a contact, stepped as the embedded simulator steps them: the prediction a plan makes of
what a contact does.

One impulse exchange at the moment of first contact (`cascade.pushes`) is not what the simulator gives when the
bodies go on touching: at its step (10 Hz) two cars that struck each other off-centre turn into each other within
the next step, and every step they still overlap and approach they exchange again, the contact normal then taken
across the penetrated bodies (simulator._check_collisions). A car rear-ended on one corner can so throw the striker
the other way than the first exchange turns it. `rollout` steps a pair the way the simulator does (its order:
move, then overlap, back to the moment of first contact at an onset, exchange while they approach, then the two
pushed apart until they barely touch, `impact.separate`; a vehicle an exchange upsets slides on its tyres,
`impact.tyre_slide`, one it does not keeps its driver, who drives on at the speed the impulse leaves, turning as it
did), vectorised over many pairs, so that a plan can choose among its options by what the simulator will do with
them. A body may come into the contact already sliding from an impact before (`sliding`). That stepping is written
once (`contact_steps`); `rollout` records its poses, slap.after_touch reads its touches.
"""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from crashscene.geometry import footprints_overlap, touch_fraction, wrap_angle
from crashscene.simulate.embedded import impact
from crashscene.simulate.embedded.swerve import bicycle_move
from crashscene.upset import upsets


@dataclass
class Bodies:
    """N vehicles (arrays (N,)): pose [m, m, rad], velocity [m/s], yaw rate [rad/s], size [m], mass [kg],
    wheelbase [m], whether each is out of its driver's control (`free`: it slides on its tyres), and the yaw rate
    [rad/s] its driver steers while it is not (`turn`, held through the rollout; none: straight on)."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    length: np.ndarray
    width: np.ndarray
    mass: np.ndarray
    wheelbase: np.ndarray
    free: np.ndarray
    turn: np.ndarray | None = None

    def copy(self) -> Bodies:
        turn = np.zeros(len(self.x)) if self.turn is None else self.turn
        return Bodies(*(np.array(getattr(self, f), copy=True) for f in self.__dataclass_fields__ if f != "turn"),
                      turn=np.array(turn, dtype=float, copy=True))

    def take(self, rows: np.ndarray) -> Bodies:
        """The bodies at `rows` (copies)."""
        whole = self.copy()
        return Bodies(*(getattr(whole, f)[rows] for f in self.__dataclass_fields__))


def stepped(a: Bodies, b: Bodies, friction: float | np.ndarray, dt: float, steps: int, dt_out: float,
            sliding: np.ndarray | None = None, motion: bool = False, recorded: bool = False) -> tuple:
    """`rollout` of N pairs that touch within their first step, resampled from their first contact on: (x, y, yaw)
    of a and of b (3, N, steps) every dt_out [s] after it (the simulator's pose at each of its steps taken at the
    step's time, as it records it, linearly between; from the first step's end where they never touch), and the
    time [s] of the first contact from the start (NaN where they never touch); `sliding`, `motion`: as `rollout`
    (with `motion`, each body's velocity too, (6, N, steps)). With `recorded`, also the poses (x, y, yaw of a,
    then of b; (6, N)) the simulator records at the end of the step the first contact falls in (the step's
    exchange and separation done), which the monitor classifies the contact by (the step's end where they never
    touch)."""
    sim_steps = int(np.ceil(steps * dt_out / dt)) + 2
    pa, pb, first, _ = rollout(a, b, friction, dt, sim_steps, sliding, motion)
    times = dt * np.arange(1, sim_steps + 1)
    want = np.where(np.isnan(first), dt, first)[:, None] + dt_out * np.arange(1, steps + 1)[None, :]
    out = []
    for p in (pa, pb):
        rows = [p[0], p[1], np.unwrap(p[2], axis=1), *p[3:]]
        out.append(np.stack([_interp(want, times, q) for q in rows]))
    if not recorded:
        return out[0], out[1], first
    # the first contact at (k + fraction) steps, fraction in (0, 1]: recorded at the end of step k
    k = np.clip(np.ceil(np.nan_to_num(first, nan=dt) / dt - 1e-9).astype(np.intp) - 1, 0, sim_steps - 1)
    rows = np.arange(len(k))
    return out[0], out[1], first, np.stack([q[rows, k] for p in (pa, pb) for q in p[:3]])


def _interp(want: np.ndarray, times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """values (N, K) at `times` (K,), linearly at `want` (N, M) (held beyond the ends)."""
    k = np.clip(np.searchsorted(times, want) - 1, 0, len(times) - 2)
    f = np.clip((want - times[k]) / (times[k + 1] - times[k]), 0.0, 1.0)
    rows = np.arange(len(values))[:, None]
    return values[rows, k] + f * (values[rows, k + 1] - values[rows, k])


def rollout(a: Bodies, b: Bodies, friction: float | np.ndarray, dt: float, steps: int,
            sliding: np.ndarray | None = None, motion: bool = False
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The poses of N pairs (a, b) every dt [s] for `steps` steps, stepped as the simulator steps them (module
    docstring, `contact_steps`): (x, y, yaw) of a and of b, each (3, N, steps) (with `motion`, (x, y, yaw, vx, vy,
    yaw rate), (6, N, steps)), the time [s] of each pair's first contact (NaN when they never touch) and whether
    each of a, b was upset by then (2, N) at the end. `sliding` (2, N) bool: which bodies come already sliding on
    their tyres from an impact before (they must be `free` too; none when not given). The inputs are not changed."""
    a, b = a.copy(), b.copy()
    n = len(a.x)
    out = np.zeros((2, 6 if motion else 3, n, steps))
    first = np.full(n, np.nan)
    for k, step in enumerate(contact_steps(a, b, friction, dt, steps, sliding)):
        if step.onset.any():
            first = np.where(step.onset & np.isnan(first), (k + step.frac) * dt, first)
        for i, q in enumerate((a, b)):
            out[i, :, :, k] = (q.x, q.y, q.yaw, q.vx, q.vy, q.w) if motion else (q.x, q.y, q.yaw)
    return out[0], out[1], first, np.stack([a.free, b.free])


@dataclass
class Step:
    """One simulator step of N pairs (`contact_steps`): which pairs overlap at its check (N,), which began to touch
    in it (`onset`), the fraction of the step at which they did (1 elsewhere) and, when any did, their poses at
    that moment, before the exchange moves them apart: (x, y, yaw) of a, then of b, (N,) each (the step's end
    elsewhere)."""

    overlap: np.ndarray
    onset: np.ndarray
    frac: np.ndarray
    contact: tuple[np.ndarray, ...] | None


def contact_steps(a: Bodies, b: Bodies, friction: float | np.ndarray, dt: float, steps: int,
                  sliding: np.ndarray | None = None, at_contact: np.ndarray | None = None) -> Iterator[Step]:
    """The simulator's stepping of N pairs through their contact, the one copy of it (`rollout` and
    slap.after_touch read it): each step moves both bodies (`_move`), tests their overlap, moves the pairs that
    began to touch back to that moment (`_back_to_contact`) and exchanges an impulse where they overlap
    (`_exchange`), in the simulator's order (simulator._check_collisions); a `Step` is yielded after each, with
    `a` and `b` (changed in place) at its end. As in the simulator (simulator._exchange), a body is upset by what
    one exchange changes (crashscene.upset), and one not upset keeps its driver, who drives on at its speed along
    its heading, its yaw rate the driver's (`turn`), not the impulse's. `sliding`: as `rollout`. `at_contact` (N,)
    bool: pairs whose poses are the moment of their first contact (a touch found by the caller): they exchange
    before the first step, as the simulator does at a contact's onset before it steps on."""
    n = len(a.x)
    touching = footprints_overlap(a.x, a.y, a.yaw, a.length, a.width, b.x, b.y, b.yaw, b.length, b.width)
    collided = np.zeros((2, n), dtype=bool) if sliding is None else np.array(sliding, dtype=bool, copy=True)
    friction = np.broadcast_to(np.asarray(friction, dtype=float), (n,))
    for q in (a, b):
        if q.turn is None:
            q.turn = np.zeros(n)
    if at_contact is not None and at_contact.any():
        touching = touching | at_contact
        _exchange(a, b, at_contact, collided)
        collided[:, at_contact] = True
    for _ in range(steps):
        prev = [(q.x.copy(), q.y.copy(), q.yaw.copy()) for q in (a, b)]
        for i, q in enumerate((a, b)):
            _move(q, collided[i], friction, dt)
        overlap = footprints_overlap(a.x, a.y, a.yaw, a.length, a.width, b.x, b.y, b.yaw, b.length, b.width)
        onset = overlap & ~touching
        touching = overlap
        frac, contact = np.ones(n), None
        if onset.any():
            frac = _back_to_contact(a, b, prev, onset)
            contact = tuple(np.array(v, copy=True) for q in (a, b) for v in (q.x, q.y, q.yaw))
        if overlap.any():
            _exchange(a, b, overlap, collided)
            collided[:, overlap] = True
        yield Step(overlap, onset, frac, contact)


def _move(q: Bodies, collided: np.ndarray, friction: np.ndarray, dt: float) -> None:
    """One step of each body: a free one slides on its tyres (trapezoidal, as simulator._move), a driven one
    drives on at its speed, turning at the yaw rate its driver had (held: its steering over one step)."""
    speed = np.hypot(q.vx, q.vy)
    slide_x, slide_y, slide_yaw, vx, vy, w = slide_step(q.x, q.y, q.yaw, q.vx, q.vy, q.w, friction, q.length,
                                                        q.width, q.wheelbase, dt)
    free = q.free & collided
    drive_x, drive_y, drive_yaw = bicycle_move(q.x, q.y, q.yaw, speed, q.turn, dt)
    q.x = np.where(free, slide_x, drive_x)
    q.y = np.where(free, slide_y, drive_y)
    q.yaw = wrap_angle(np.where(free, slide_yaw, drive_yaw))
    q.vx = np.where(free, vx, speed * np.cos(q.yaw))
    q.vy = np.where(free, vy, speed * np.sin(q.yaw))
    q.w = np.where(free, w, q.turn)


def slide_step(x, y, yaw, vx, vy, yaw_rate, friction, length, width, wheelbase, dt: float):
    """One step [s] of bodies sliding on their tyres after an impact (impact.tyre_slide), integrated as
    simulator._move integrates a sliding vehicle (impact.glide): (x, y, yaw (not wrapped), vx, vy, yaw rate) at its
    end."""
    vx1, vy1, w1 = impact.tyre_slide(vx, vy, yaw, yaw_rate, friction, length, width, wheelbase, dt)
    return (*impact.glide(x, y, yaw, vx, vy, yaw_rate, vx1, vy1, w1, dt), vx1, vy1, w1)


def _back_to_contact(a: Bodies, b: Bodies, prev, hit: np.ndarray) -> np.ndarray:
    """Both bodies of each hit pair moved back along their last step to the moment of first contact
    (simulator._back_to_contact); the fraction of the step it began at (1 elsewhere)."""
    idx = np.nonzero(hit)[0]
    frac = np.ones(len(hit))

    def pose(q: Bodies, p, f):
        x0, y0, yaw0 = (v[idx] for v in p)
        return (x0 + f * (q.x[idx] - x0), y0 + f * (q.y[idx] - y0), yaw0 + f * wrap_angle(q.yaw[idx] - yaw0))

    hi = touch_fraction(lambda f: pose(a, prev[0], f), lambda f: pose(b, prev[1], f), a.length[idx], a.width[idx],
                        b.length[idx], b.width[idx], len(idx))
    for q, p in ((a, prev[0]), (b, prev[1])):
        q.x[idx], q.y[idx], q.yaw[idx] = pose(q, p, hi)
    frac[idx] = hi
    return frac


def _exchange(a: Bodies, b: Bodies, overlap: np.ndarray, collided: np.ndarray) -> None:
    """The impulse between the bodies of each overlapping pair (simulator._exchange), then the two pushed apart
    until they barely touch (impact.separate); a body it upsets is free. `collided` (2, N): which of a, b slide
    on their tyres (with `free`: `_move`); the others are driven, and as in simulator._exchange a driven body
    meets the other at its speed along its heading at the contact (the pose `_back_to_contact` turned back to),
    not along the heading its step ended at (a driver turning at 0.05 rad/s turns 0.005 rad in a 0.1 s step:
    0.14 m/s across at 28 m/s, which the impact keeps)."""
    i = np.nonzero(overlap)[0]
    for q, slides in ((a, collided[0]), (b, collided[1])):
        driven = i[~(q.free[i] & slides[i])]
        speed = np.hypot(q.vx[driven], q.vy[driven])
        q.vx[driven], q.vy[driven] = speed * np.cos(q.yaw[driven]), speed * np.sin(q.yaw[driven])
    poses = (a.x[i], a.y[i], a.yaw[i], a.length[i], a.width[i], b.x[i], b.y[i], b.yaw[i], b.length[i], b.width[i])
    nx, ny, px, py, penetration = impact.contact(*poses)
    va, vb = np.stack([a.vx[i], a.vy[i]]), np.stack([b.vx[i], b.vy[i]])
    ia = impact.yaw_inertia(a.mass[i], a.length[i], a.width[i])
    ib = impact.yaw_inertia(b.mass[i], b.length[i], b.width[i])
    va1, wa1, vb1, wb1, _ = impact.exchange(nx, ny, px, py, a.x[i], a.y[i], va, a.w[i], a.mass[i], ia, b.x[i],
                                            b.y[i], vb, b.w[i], b.mass[i], ib)
    for q, v1, w1, v0, w0 in ((a, va1, wa1, va, a.w[i]), (b, vb1, wb1, vb, b.w[i])):
        q.free[i] |= upsets(np.hypot(*(v1 - v0)), w1 - w0)
        q.vx[i], q.vy[i], q.w[i] = v1[0], v1[1], w1
    # the exchange changed velocities only: the poses, normal and penetration are the contact's
    dxa, dya, dxb, dyb = impact.separate(*poses[:5], a.mass[i], *poses[5:], b.mass[i], frame=(nx, ny, penetration))
    a.x[i] += dxa
    a.y[i] += dya
    b.x[i] += dxb
    b.y[i] += dyb
