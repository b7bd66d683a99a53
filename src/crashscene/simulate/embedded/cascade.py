"""The motion a first impact gives the vehicles it involves, predicted for planning a later contact (a cascade).

A rear-end can push the struck car out of its lane when it strikes one rear corner: the impulse
(`impact.exchange`, the simulator's own model) turns the struck car and it slides (`impact.tyre_slide`) the
way its nose points. `pushed_path` predicts that motion from the moment of contact, the two bodies stepped
through it as the simulator steps them (`rollout`: at its step the two go on touching and exchange again, which
can turn the striker the other way than the first exchange does), so that the plan can place the third vehicle
of the written sequence where the pushed car will be, when it is there.
`slide_path` is that slide for any vehicle already sliding; `clip_slide`, the slide of a car that clips the car
ahead while pulling out, so that the plan can place a third vehicle where the clip sends it. How the third vehicle
meets the moving one (`meeting_mode`: it drives into it, or the moving one comes alongside into its side) decides
which face of the moving one turns towards it and the class of their contact.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from crashscene.geometry import (
    ANGLE_RANGE,
    HEAD_ON_MIN,
    REAR_END_MAX,
    classify_contact,
    footprints_overlap,
    touch_fraction,
    wrap_angle,
)
from crashscene.simulate.backend import DEFAULT_DT as SIM_DT
from crashscene.simulate.embedded import impact, lockstep, rollout, swerve
from crashscene.simulate.embedded.vehicles import limits_for
from crashscene.upset import upsets

DT = 0.05  # [s] integration step of the prediction
HORIZON = 4.0  # [s] how long after the impact the pushed car is followed
CORNER = 0.4  # [-] the striker's centre is this fraction of the struck car's width off its centre line
CAR_WHEELBASE_RATIO = limits_for("car").wheelbase_ratio  # [-] the struck vehicle's when not given
CORNERS = (0.3, 0.4, 0.5, 0.6)  # [-] the fractions a plan chooses among where it can predict the push well
SEPARATE_STEPS = 2  # [-] the two bodies of a nearly plastic impact may still touch this many steps after it


def pushed_path(v_striker: float, v_struck: float, side: float, m_striker: float, m_struck: float,
                l_striker: float, w_striker: float, l_struck: float, w_struck: float, friction: float,
                head_on: bool = False, corner: float = CORNER) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, left, yaw) of the struck car every DT after a rear-end (or a head-on), in its own frame at
    the impact ([m], [m], [rad]); the striker comes from behind (from ahead, the other way) at `v_striker`
    [m/s], its centre `side` * `corner` * width to the struck car's left (side = +1) or right (-1); the struck
    car moves at `v_struck` [m/s]."""
    fwd, left, yaw = pushed_paths(v_striker, v_struck, np.array([side * corner]), m_striker, m_struck, l_striker,
                                  w_striker, l_struck, w_struck, friction, head_on)
    return fwd[0], left[0], yaw[0]


def pushed_paths(v_striker: float, v_struck: float, offsets: np.ndarray, m_striker: float, m_struck: float,
                 l_striker: float, w_striker: float, l_struck: float, w_struck: float, friction: float,
                 head_on: bool = False, striker: bool = False, wheelbase_ratios: tuple[float, float] = (
                     CAR_WHEELBASE_RATIO, CAR_WHEELBASE_RATIO), stepped: bool = True):
    """`pushed_path` for several striker centres at once, `offsets` (N,) times the struck car's width to its
    left: (forward, left, yaw) (N, steps); with `striker`, also the striker's own slide after the impact in the
    same frame, ((forward, left, yaw), (x, y, yaw)); `wheelbase_ratios` [-] the striker's and the struck car's
    (vehicles.VehicleLimits); `stepped`: as Push.stepped."""
    struck, mine = pushes([Push(v_striker, v_struck, np.asarray(offsets, dtype=float), m_striker, m_struck, l_striker,
                                w_striker, l_struck, w_struck, friction, head_on, wheelbase_ratios,
                                stepped=stepped)], striker)[0]
    return (struck, mine) if striker else struck


@dataclass(frozen=True)
class Push:
    """An end-on impact `pushed_paths` predicts: the striker at `v_striker` [m/s] from behind (from ahead when
    `head_on`), its centre `offsets` (N,) times the struck car's width to the struck car's left, the struck car at
    `v_struck` [m/s]; masses [kg], lengths and widths [m], the road's friction [-], the two wheelbase ratios [-]."""

    v_striker: float
    v_struck: float
    offsets: np.ndarray
    m_striker: float
    m_struck: float
    l_striker: float
    w_striker: float
    l_struck: float
    w_struck: float
    friction: float
    head_on: bool = False
    wheelbase_ratios: tuple[float, float] = (CAR_WHEELBASE_RATIO, CAR_WHEELBASE_RATIO)
    dt: float = SIM_DT  # [s] the simulator's step, which the contact is stepped at (`rollout`)
    approach: float = 0.0  # [rad] the striker's heading off the struck car's (left positive) as it touches it
    approach_rate: float = 0.0  # [rad/s] ...and how fast its driver turns it then (a drift into the car)
    stepped: bool = True  # the contact stepped as the simulator steps it (`rollout`), else one exchange at the
    # first touch and each body's slide from it (a striker its driver drives on into the car is carried on by the
    # caller: knock._room_to_leave)
    lead: float = 0.0  # [s] how long after the simulator's last step before it the touch happens (`step_lead`); the
    # whole step when 0: where in its step the simulator finds the touch decides how deep the next steps' overlaps
    # are, so the repeated exchanges and what they turn the cars


def pushes_moving(items: list[Push]) -> list[tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]]:
    """`pushes(items)` with each body's velocity too: per item ((forward, left, yaw, v forward, v left, yaw rate)
    of the struck car, the same of the striker) [m, rad, m/s, rad/s], each (N, steps); the velocities of rows not
    `stepped` from their poses' differences."""
    return pushes(items, True, True)


def pushes(items: list[Push], striker: bool = True, motion: bool = False
           ) -> list[tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...] | None]]:
    """`pushed_paths(..., striker=striker)` of each item, every offset of every item integrated at once (each
    element as it would be alone: lockstep.together batches the plans' pushes): per item ((forward, left, yaw),
    (x, y, yaw) of the striker, None without `striker`), each (N, steps); `motion`: as `pushes_moving`."""
    if not items:
        return []
    sizes = [len(p.offsets) for p in items]

    def each(field) -> np.ndarray:
        return lockstep.per_element((field(p) for p in items), sizes)

    head_on = each(lambda p: p.head_on).astype(bool)
    l_striker, w_striker = each(lambda p: p.l_striker), each(lambda p: p.w_striker)
    l_struck, w_struck = each(lambda p: p.l_struck), each(lambda p: p.w_struck)
    reach = (l_striker + l_struck) / 2 - 0.05
    xa = np.where(head_on, reach, -reach)
    ya = np.concatenate([p.offsets for p in items]) * w_struck
    zero = np.zeros(len(xa))
    yaw_a = np.where(head_on, math.pi, 0.0)
    v_striker, v_struck = each(lambda p: p.v_striker), each(lambda p: p.v_struck)
    vxa = np.where(head_on, -v_striker, v_striker)
    ma, mb = each(lambda p: p.m_striker), each(lambda p: p.m_struck)
    ra, rb = each(lambda p: p.wheelbase_ratios[0]) * l_striker, each(lambda p: p.wheelbase_ratios[1]) * l_struck
    friction = each(lambda p: p.friction)
    steps = int(HORIZON / DT)
    rows = 6 if motion else 3
    struck, mine = np.zeros((rows, len(xa), steps)), np.zeros((rows, len(xa), steps))
    dt = each(lambda p: p.dt)
    stepped = each(lambda p: p.stepped).astype(bool)
    once = np.nonzero(~stepped)[0]
    if len(once):
        r = once  # [-] the rows predicted with one exchange
        nx, ny, px, py = impact.contact_frame(xa[r], ya[r], yaw_a[r], l_striker[r], w_striker[r], zero[r], zero[r],
                                              zero[r], l_struck[r], w_struck[r])
        va, wa, vb, wb, _ = impact.exchange(
            nx, ny, px, py, xa[r], ya[r], np.stack([vxa[r], zero[r]]), zero[r], ma[r],
            impact.yaw_inertia(ma[r], l_striker[r], w_striker[r]), zero[r], zero[r], np.stack([v_struck[r], zero[r]]),
            zero[r], mb[r], impact.yaw_inertia(mb[r], l_struck[r], w_struck[r]))
        struck[:3, r] = slide_path(zero[r], zero[r], zero[r], vb[0], vb[1], wb, friction[r], l_struck[r],
                                   w_struck[r], DT, steps, rb[r])
        if striker:  # the striker's own slide only when asked for (the room check asks for the struck car's)
            mine[:3, r] = slide_path(xa[r], ya[r], yaw_a[r], va[0], va[1], wa, friction[r], l_striker[r],
                                     w_striker[r], DT, steps, ra[r])
        if motion:
            for out in (struck, mine):
                out[3:, r] = np.gradient(out[:3, r], DT, axis=2)
    free = np.zeros(len(xa), dtype=bool)
    # the pair one simulator step before they touch, stepped through the contact as the simulator steps them; the
    # striker's centre where the two first touch end to end, at its approach heading (one exchange at the first
    # touch takes it square), at the touch: its driver turns it at the approach rate, so that a step before it
    # (`lead` before the touch) it was less turned (swerve.bicycle_before)
    lead = each(lambda p: p.lead)
    lead = np.where(lead > 0, lead, dt)
    rate = each(lambda p: p.approach_rate)
    touching = np.where(head_on, 1.0, -1.0) * (l_striker + l_struck) / 2
    x_s, y_s, heading = swerve.bicycle_before(touching, ya, yaw_a + each(lambda p: p.approach), v_striker, rate,
                                              lead)
    vx_s, vy_s = v_striker * np.cos(heading), v_striker * np.sin(heading)
    striker_body = rollout.Bodies(x_s, y_s, heading, vx_s, vy_s, zero, l_striker, w_striker, ma, ra, free, rate)
    struck_body = rollout.Bodies(-v_struck * lead, zero, zero, v_struck, zero, zero, l_struck, w_struck, mb, rb, free)
    for one_dt in np.unique(dt[stepped]):
        r = np.nonzero(stepped & (dt == one_dt))[0]
        pa, pb, first = rollout.stepped(striker_body.take(r), struck_body.take(r), friction[r], float(one_dt), steps,
                                        DT, motion=motion)
        # in the struck car's frame at the moment of contact (it drove straight on until then)
        x0 = v_struck[r] * (np.nan_to_num(first, nan=lead[r]) - lead[r])
        struck[:, r] = pb[0] - x0[:, None], *pb[1:]
        mine[:, r] = pa[0] - x0[:, None], *pa[1:]
    mine = tuple(mine) if striker else None
    struck = tuple(struck)
    by_item = lockstep.per_item(struck, sizes)
    mine_by_item = lockstep.per_item(mine, sizes) if striker else [None] * len(items)
    return list(zip(by_item, mine_by_item))


def step_lead(t: float, dt: float) -> float:
    """[s] how long after the simulator's last step before it (steps every `dt` [s] from 0) a touch at `t` [s]
    happens: in (0, dt]."""
    k = math.ceil(t / dt - 1e-9) - 1
    return float(t - k * dt)


def touch_again(struck: tuple[np.ndarray, np.ndarray, np.ndarray], striker: tuple[np.ndarray, np.ndarray, np.ndarray],
                l_struck: float, w_struck: float, l_striker: float, w_striker: float) -> np.ndarray:
    """(N, steps) bool: whether the two slides of `pushed_paths(..., striker=True)` have touched again by each step:
    met after they were apart (a new contact, which a prediction from one exchange does not hold); two bodies that
    go on touching after the impact (pushed apart until they barely touch, impact.separate) touch on, not again."""
    (fb, lb, yb), (xa, ya, yaw_a) = struck, striker
    touch = footprints_overlap(xa, ya, yaw_a, l_striker, w_striker, fb, lb, yb, l_struck, w_struck)
    touch[:, :SEPARATE_STEPS] = True
    apart = np.logical_or.accumulate(~touch, axis=1)
    return np.logical_or.accumulate(touch & apart, axis=1)


def slide_path(x, y, yaw, vx, vy, yaw_rate, friction: float, length, width, dt: float, steps: int, wheelbase=None):
    """(x, y, yaw) (N, steps) of N sliding vehicles every dt [s] from now ([m], [m/s], [rad/s] (N,)), integrated
    as the simulator moves a vehicle after an impact (rollout.slide_step, as simulator._move), exact
    until it touches something else; `wheelbase` [m] (N,), a car's share of the length when not given."""
    wheelbase = CAR_WHEELBASE_RATIO * length if wheelbase is None else wheelbase
    out = np.zeros((3, len(x), steps))
    for k in range(steps):
        x, y, yaw, vx, vy, yaw_rate = rollout.slide_step(x, y, yaw, vx, vy, yaw_rate, friction, length, width,
                                                         wheelbase, dt)
        out[:, :, k] = x, y, yaw
    return out[0], out[1], out[2]


def meeting_mode(klass: str, third_area: str | None) -> str:
    """How the third vehicle of a later contact meets the vehicle a contact set moving, by its own written area:
    'side' (a sideswipe on its side: the moving vehicle comes alongside into it), else 'front' (it drives into the
    moving vehicle)."""
    return "side" if klass == "sideswipe" and third_area in ("left", "right") else "front"


def toward_third(yaw_third: np.ndarray, third_area: str) -> np.ndarray:
    """[rad] the direction from a moving vehicle to the side `third_area` ('left', 'right') of a third vehicle
    heading `yaw_third` [rad] that it strikes there (`meeting_mode` 'side')."""
    return np.asarray(yaw_third) + (math.pi / 2 if third_area == "right" else -math.pi / 2)


def class_margin(relative_yaw: np.ndarray, klass: str, side: bool = False) -> np.ndarray:
    """[deg] how far contacts at these relative headings [rad] are inside the heading range of `klass` (rules.md;
    negative outside): how much a heading may be off before the class changes. `side`: the contacts are side to
    side, so a near-parallel one is a sideswipe too (geometry.classify_contact)."""
    deg = np.degrees(np.abs(wrap_angle(np.asarray(relative_yaw, dtype=float))))
    if side and klass == "sideswipe":
        return np.where(deg < 90.0, ANGLE_RANGE[0] - deg, deg - ANGLE_RANGE[1])
    if klass == "rear_end":
        return REAR_END_MAX - deg
    if klass == "head_on":
        return deg - HEAD_ON_MIN
    if klass == "angle":
        return np.minimum(deg - ANGLE_RANGE[0], ANGLE_RANGE[1] - deg)
    lo = np.where(deg < 90.0, REAR_END_MAX, ANGLE_RANGE[1])
    hi = np.where(deg < 90.0, ANGLE_RANGE[0], HEAD_ON_MIN)
    return np.minimum(deg - lo, hi - deg)


def contact_class(relative_yaw: np.ndarray, side: bool = False) -> np.ndarray:
    """The classes (rules.md, geometry.classify_contact) of end-on contacts at these relative headings [rad]; with
    `side`, of side-to-side ones (a near-parallel one is a sideswipe)."""
    return classify_contact(np.abs(wrap_angle(np.asarray(relative_yaw, dtype=float))), end_on=not side)


AREAS = ("front", "left", "rear", "right")  # a body's faces, counter-clockwise from its heading


def facing_area(yaw_struck: np.ndarray, yaw_striker: np.ndarray) -> np.ndarray:
    """The faces of struck bodies [rad heading] that strikers coming at headings `yaw_striker` [rad] meet: the
    one whose outward normal points most nearly back at it."""
    toward = np.asarray(yaw_striker, dtype=float) + math.pi
    cos = np.stack([np.cos(np.asarray(yaw_struck) + k * math.pi / 2 - toward) for k in range(4)])
    return np.asarray(AREAS, dtype=object)[np.argmax(cos, axis=0)]


def to_world(x0: float, y0: float, yaw0: float, fwd: np.ndarray, left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World coordinates [m] of points given in the frame of a pose (x0, y0, yaw0)."""
    c, s = math.cos(yaw0), math.sin(yaw0)
    return x0 + fwd * c - left * s, y0 + fwd * s + left * c


@dataclass(frozen=True)
class Clip:
    """A car clipping a car driving straight on ahead of it (`clip_slides`). rows: its path (x, y, yaw every dt
    [s] from the start of its manoeuvre, turning left; mirrored when `sign` is -1; swerve.path or a skid's); it
    starts at `speed` [m/s], `lateral` [m] from its route's centre line, the partner's centre `partner_ahead` [m]
    ahead of it at `partner_lateral` [m], driving at `partner_speed` [m/s]; `t_meet` [s] the step they overlap
    first. me, partner: (length, width [m], mass [kg], wheelbase ratio [-]); friction [-] the road's."""

    rows: tuple[np.ndarray, np.ndarray, np.ndarray]
    sign: float
    speed: float
    lateral: float
    partner_ahead: float
    partner_speed: float
    partner_lateral: float
    t_meet: float
    dt: float
    me: tuple[float, float, float, float]
    partner: tuple[float, float, float, float]
    friction: float


def clip_slide(rows: tuple[np.ndarray, np.ndarray, np.ndarray], sign: float, speed: float, lateral: float,
               partner_ahead: float, partner_speed: float, partner_lateral: float, t_meet: float, dt: float,
               me: tuple[float, float, float, float], partner: tuple[float, float, float, float], friction: float
               ) -> tuple[float, tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
    """The slide of a car after it clips a car driving straight on ahead of it (`Clip` for the arguments), as the
    simulator gives it: `clip_slides` of that one clip."""
    return clip_slides([Clip(rows, sign, speed, lateral, partner_ahead, partner_speed, partner_lateral, t_meet, dt,
                             me, partner, friction)])[0]


def clip_slides(clips: list[Clip]) -> list[tuple[float, tuple[np.ndarray, np.ndarray, np.ndarray]] | None]:
    """The slide of each car after it clips a car driving straight on ahead of it, as the simulator gives it
    (impact.exchange, then tyre_slide): (time [s] from the start of its manoeuvre to the touch, (along, across,
    yaw) every DT after it); the frame: along the road from where the manoeuvre starts, across from the centre
    line. None for a clip whose rows do not reach t_meet, or that does not upset the car (crashscene.upset: its
    driver drives on). All clips are integrated at once, each element by
    element as it would be alone."""
    out: list = [None] * len(clips)
    live, before, after, t_before = [], [], [], []
    for i, c in enumerate(clips):
        x, y, yaw = c.rows
        k = int(round(c.t_meet / c.dt)) - 1
        if k < 0 or k >= len(x):
            continue

        def pose_at(j: int, c: Clip = c, x=x, y=y, yaw=yaw) -> tuple[float, float, float]:
            if j < 0:
                return 0.0, c.lateral, 0.0
            return float(x[j]), c.lateral + c.sign * float(y[j]), c.sign * float(yaw[j])

        live.append(i)
        before.append(pose_at(k - 1))
        after.append(pose_at(k))
        t_before.append(k * c.dt)
    if not live:
        return out
    n = len(live)
    sel = [clips[i] for i in live]

    def column(values) -> np.ndarray:
        return np.array(list(values), dtype=float)

    b = [column(p[j] for p in before) for j in range(3)]
    step = [column(p[j] - q[j] for p, q in zip(after, before)) for j in range(3)]
    dt, t0 = column(c.dt for c in sel), column(t_before)
    ahead, p_speed = column(c.partner_ahead for c in sel), column(c.partner_speed for c in sel)
    p_lateral = column(c.partner_lateral for c in sel)
    la, wa, ma, ra = (column(c.me[j] for c in sel) for j in range(4))
    lb, wb, mb = (column(c.partner[j] for c in sel) for j in range(3))
    friction = column(c.friction for c in sel)

    def mine(f):
        return tuple(bj + f * dj for bj, dj in zip(b, step))

    def theirs(f):
        return ahead + p_speed * (t0 + f * dt), p_lateral, np.zeros(n)

    f = touch_fraction(mine, theirs, la, wa, lb, wb, n)
    xa, ya, yaw_a = mine(f)
    xb, yb, yaw_b = theirs(f)
    v_a = np.hypot(step[0], step[1]) / dt
    va = np.stack([v_a * np.cos(yaw_a), v_a * np.sin(yaw_a)])  # along its heading, as the simulator has it
    vb = np.stack([p_speed, np.zeros(n)])
    nx, ny, px, py = impact.contact_frame(xa, ya, yaw_a, la, wa, xb, yb, yaw_b, lb, wb)
    va0, w0 = va, step[2] / dt
    va, w_a, _, _, _ = impact.exchange(nx, ny, px, py, xa, ya, va0, w0, ma, impact.yaw_inertia(ma, la, wa),
                                       xb, yb, vb, np.zeros(n), mb, impact.yaw_inertia(mb, lb, wb))
    # a clip that does not upset the car leaves its driver driving on (the simulator's rule): no slide follows
    slides = upsets(np.hypot(*(va - va0)), w_a - w0)
    along, across, turn = slide_path(xa, ya, yaw_a, va[0], va[1], w_a, friction, la, wa, DT, int(HORIZON / DT),
                                     ra * la)
    for j, i in enumerate(live):
        if slides[j]:
            out[i] = t_before[j] + float(f[j]) * clips[i].dt, (along[j], across[j], turn[j])
    return out
