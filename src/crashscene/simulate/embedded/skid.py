"""A loss of control planned from its impact: how fast the car spins, how far its path veers and when it loses
control, so that where its footprint first touches its partner's the contact has the written class and areas
(the side of a car rotated ~90 deg for an `angle` contact, its front for a `head_on`).

The skid is the sliding motion of `impact.slide` (one model for the plan and the simulator), integrated at the
simulator's step: the body yaws at the planned rate (held while out of control), the velocity keeps its
direction but decays, the part across the body at the tyre friction, so the path bends toward where the car
points. The partner drives straight on at its planned speed. The first contact is the first simulator step at
which the two footprints overlap (as the monitor finds it), classified by `geometry` as the monitor does.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from crashscene.geometry import (
    ANGLE_RANGE,
    HEAD_ON_MIN,
    REAR_END_MAX,
    TAU as TAU_TURN,
    classify_contact,
    contact_areas,
    heading_difference,
    touch_fraction,
)
from crashscene.simulate.embedded import impact, lockstep

SPIN_RATES = np.array([0.05, 0.15, 0.25, 0.35, 0.5, 0.7, 0.9, 1.2])  # [rad/s] candidate yaw rates of a car out of control
DRIFT_ANGLES = np.array([0.08, 0.15, 0.25, 0.35])  # [rad] candidate veer of the velocity at the loss of control
PLACED_TRIGGER = 1.0  # [s] when the partner is placed to meet the skid, the skid starts this late
HORIZON = 6.0  # [s] a skid that has not reached the partner by then does not count
LATEST = 12.0  # [s] the latest loss of control the plan considers
PLACE_RANGE = 60.0  # [m] how far along its road the partner may be placed to meet the skid
PLACE_STEP = 0.25  # [m] the grid of such placements
PLACE_COST = 0.5  # [rad] a placed partner counts as this much rotation off the drawn one
CROSS_COST = 2.0  # [rad] a contact before my centre is in the partner's lane counts as this much rotation off
CROSS_MARGIN = 0.5  # [m] my centre this far past the boundary counts as in the partner's lane
CENTRAL_TOLERANCE = 0.05  # [rad] offsets whose miss is this close to the best one's count as about as good
AREA_COST = 1.0  # [rad] a contact with other areas than written counts as this much rotation off the drawn one
# relative heading [rad] between the two vehicles at contact that each class needs (rules.md bands, mid)
CLASS_HEADING = {"rear_end": 0.1, "head_on": math.pi - 0.2, "angle": math.pi / 2, "sideswipe": 0.4}


@dataclass(frozen=True)
class Skid:
    """A planned loss of control: signed yaw rate [rad/s] held for `hold` [s], signed velocity veer [rad],
    and the time [s] to lose control so that the partner meets the car `t_meet` [s] later."""

    spin_rate: float
    drift: float
    trigger: float
    t_meet: float
    hold: float
    partner_shift: float = 0.0  # [m] the partner must start this much further along its road to meet


@dataclass(frozen=True)
class Body:
    """A footprint [m]."""

    length: float
    width: float


@dataclass(frozen=True)
class Wanted:
    """The written contact as the skid plan needs it: its class (None: not written) and the area of the
    skidding car and of its partner (None: not written), and whether the skidding car is the monitor's
    `actor_a` (the first of the two in role order)."""

    contact_class: str | None
    area: str | None = None
    partner_area: str | None = None
    skidder_first: bool = True


def candidates() -> tuple[np.ndarray, np.ndarray]:
    """(spin, drift) of every candidate skid, (n_cand,) each: the car drifts left, spinning either way."""
    spin, drift = np.meshgrid(np.concatenate([SPIN_RATES, -SPIN_RATES]), DRIFT_ANGLES)
    return spin.ravel(), drift.ravel()


def trajectories(speeds: np.ndarray, friction: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Left-turning skids of every candidate (spin, drift) from each speed [m/s] (N,): X, Y, YAW (N, n_cand,
    n_steps), along/across the road [m] and the body's turn [rad] every dt [s] after losing control.
    Elementwise on the speeds, so one speed's rows are the same whichever others are integrated with it."""
    spin, drift = candidates()
    speeds = np.maximum(np.asarray(speeds, dtype=float), 0.5)[:, None]
    vx = speeds * np.cos(drift)
    vy = speeds * np.sin(drift)
    shape = vx.shape
    spin = np.broadcast_to(spin, shape)
    yaw, x, y = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    size = np.ones(shape)  # the body's size changes nothing in the velocity (only in a free yaw rate)
    steps = int(round(HORIZON / dt))
    out = np.zeros((3, *shape, steps))
    for k in range(steps):
        vx1, vy1, _ = impact.slide(vx, vy, yaw, spin, friction, size, size, dt)
        turning = np.where(np.hypot(vx1, vy1) > impact.REST_SPEED, spin, 0.0)  # the spin held until rest
        x, y, yaw = impact.glide(x, y, yaw, vx, vy, turning, vx1, vy1, turning, dt)
        vx, vy = vx1, vy1
        out[:, :, :, k] = x, y, yaw
    return out[0], out[1], out[2]


def along_road(paths: tuple[np.ndarray, np.ndarray, np.ndarray], curvature: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The skids `paths` (x, y, yaw: along and across the road where the car loses control, and its turn) as a
    road bending at a constant `curvature` [1/m] (left positive) sees them: the station along the car's path
    round the bend, the offset across it (left positive) and the yaw off the road's direction there (the
    Frenet frame of a circular arc). A car out of control keeps its course in the world while its partner
    follows its lane round the bend: on a bend to the left a skid that goes straight on ends up on the road's
    right. The paths as they are on a straight road (curvature 0.0, as stations.route_bend gives it)."""
    if curvature == 0.0:
        return paths
    x, y, yaw = paths
    k = float(curvature)
    ahead, inward = k * x, 1.0 - k * y  # [-] scaled by the radius: the centre of the bend at (0, 1)
    station = np.arctan2(ahead, inward) / k
    return station, (1.0 - np.hypot(ahead, inward)) / k, yaw - k * station


@dataclass
class SkidPaths:
    """The candidate skids by speed at the loss of control, for one friction and simulator step; a batch's are
    integrated at once (`prepare`), any other speed when first asked."""

    friction: float
    dt: float
    _rows: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=dict)

    def prepare(self, speeds) -> None:
        new = sorted({float(s) for s in np.ravel(speeds) if np.isfinite(s)} - set(self._rows))
        if not new:
            return
        x, y, yaw = trajectories(np.array(new), self.friction, self.dt)
        for i, s in enumerate(new):
            self._rows[s] = (x[i], y[i], yaw[i])

    def get(self, speed: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        self.prepare([speed])
        return self._rows[float(speed)]


def rotation_for(contact_class: str | None, opposite: bool, rng_value: float) -> float:
    """How far [rad] the spinning car should have turned at contact; `rng_value` in [0, 1) varies it."""
    if contact_class is None:
        return math.radians(20.0 + 50.0 * rng_value)  # not written: somewhere between a drift and a side-on slide
    if contact_class == "angle":
        return math.radians(75.0 + 25.0 * rng_value)
    turned = abs((math.pi if opposite else 0.0) - CLASS_HEADING[contact_class])
    return max(turned + math.radians(10.0 * (rng_value - 0.5)), 0.0)


def overlap_interval(dy: np.ndarray, yaw: np.ndarray, me: Body, other: Body) -> tuple[np.ndarray, np.ndarray]:
    """[lo, hi] [m] of the offset along the road of my centre from the other's (which lies along the road) at
    which the footprints overlap, given my lateral offset dy [m] and my yaw [rad] (arrays); lo > hi: never."""
    c, s = np.cos(yaw), np.sin(yaw)
    ac, as_ = np.abs(c), np.abs(s)
    hl, hw, ol, ow = me.length / 2, me.width / 2, other.length / 2, other.width / 2
    reach = hl * ac + hw * as_ + ol  # along the road
    lo, hi = np.full(dy.shape, -reach), np.full(dy.shape, reach)
    apart = np.abs(dy) > hl * as_ + hw * ac + ow  # across the road
    tiny = 1e-9
    # my long axis: |dx c + dy s| <= hl + ol |c| + ow |s|
    r1 = hl + ol * ac + ow * as_
    with np.errstate(divide="ignore", invalid="ignore"):
        a1, b1 = (-r1 - dy * s) / c, (r1 - dy * s) / c
        along = ac > tiny
        lo = np.where(along, np.maximum(lo, np.minimum(a1, b1)), lo)
        hi = np.where(along, np.minimum(hi, np.maximum(a1, b1)), hi)
        apart |= ~along & (np.abs(dy * s) > r1)
        # my lateral axis: |-dx s + dy c| <= hw + ol |s| + ow |c|
        r2 = hw + ol * as_ + ow * ac
        a2, b2 = (dy * c - r2) / s, (dy * c + r2) / s
        across = as_ > tiny
        lo = np.where(across, np.maximum(lo, np.minimum(a2, b2)), lo)
        hi = np.where(across, np.minimum(hi, np.maximum(a2, b2)), hi)
        apart |= ~across & (np.abs(dy * c) > r2)
    return np.where(apart, np.inf, lo), np.where(apart, -np.inf, hi)


def plan(paths: tuple[np.ndarray, np.ndarray, np.ndarray], speed: float, gap: float, partner_speed: float,
         opposite: bool, partner_lateral: float, me: Body, partner: Body, rotation: float, wanted: Wanted,
         dt: float, boundary: float | None = None) -> Skid | None:
    """The loss of control whose first contact with the partner has the wanted class (and areas, where one
    does), turned closest to `rotation` [rad], early rather than late. paths: `SkidPaths.get(speed)`; gap: the
    partner's centre ahead of mine along the road [m] (negative: behind); partner_lateral: its offset [m] (left
    positive); boundary: how far across [m] my centre is in the partner's lane (or across the centre line),
    by default halfway to the partner, and as far beyond its lane centre at most. The partner is met where it
    is when a start time within LATEST fits, else placed (partner_shift). None when no candidate gives the
    written class."""
    sign = 1.0 if partner_lateral >= 0 else -1.0
    found = first_contact(paths, sign, speed, gap, partner_speed, opposite, partner_lateral, me, partner, rotation,
                          wanted, dt, boundary)
    if found is None:
        return None
    c, trigger, t_meet, shift = found
    spin, drift = candidates()
    return Skid(sign * float(spin[c]), sign * float(drift[c]), trigger, t_meet, t_meet + 0.5, shift)


def first_contact(paths: tuple[np.ndarray, np.ndarray, np.ndarray], sign: float, speed: float, gap: float,
                  partner_speed: float, opposite: bool, partner_lateral: float, me: Body, partner: Body,
                  rotation: float, wanted: Wanted, dt: float, boundary: float | None = None,
                  latest: float = LATEST, place: bool = True, fine: int = 1
                  ) -> tuple[int, float, float, float] | None:
    """(path, trigger [s], time from the trigger to the contact [s], the partner's shift [m]) of the best of
    `paths` (x, y, yaw (C, K) every dt after the trigger, turning left; mirrored when `sign` is -1) started on
    a simulator step by `latest` [s], or (when `place`) a second after the start with the partner placed:
    its first contact with the partner has the wanted class (`plan` for the rest). With `fine` > 1 the partner
    may also start up to a step's closing further ahead, in `fine` parts, and the middle of the best run of
    such starts is taken (a narrow window: a glancing contact)."""
    return first_contacts(paths, sign, speed, gap, [partner_speed], opposite, partner_lateral, me, partner,
                          rotation, wanted, dt, boundary, [latest], place, fine)[0]


def first_contacts(paths: tuple[np.ndarray, np.ndarray, np.ndarray], sign: float, speed: float, gap: float,
                   partner_speeds: list[float], opposite: bool, partner_lateral: float, me: Body, partner: Body,
                   rotation: float, wanted: Wanted, dt: float, boundary: float | None = None,
                   latests: list[float] | None = None, place: bool = True, fine: int = 1
                   ) -> list[tuple[int, float, float, float] | None]:
    """`first_contact` at each of `partner_speeds` [m/s] (with its `latests` [s], LATEST by default), searched
    at once (what depends only on the path, the partner's lateral offset and the bodies is measured once): each
    result is the one `first_contact` gives for that speed alone."""
    return [found[0] if found else None for found in
            contact_choices(paths, sign, speed, gap, partner_speeds, opposite, partner_lateral, me, partner,
                            rotation, wanted, dt, boundary, latests, place, fine)]


def contact_choices(paths: tuple[np.ndarray, np.ndarray, np.ndarray], sign: float, speed: float, gap: float,
                    partner_speeds: list[float], opposite: bool, partner_lateral: float, me: Body, partner: Body,
                    rotation: float, wanted: Wanted, dt: float, boundary: float | None = None,
                    latests: list[float] | None = None, place: bool = True, fine: int = 1, count: int = 1
                    ) -> list[list[tuple[int, float, float, float]]]:
    """`first_contacts` with, after each speed's best first contact, up to `count` - 1 other starts whose first
    contact is as written too (`_ranked_each`: the written class and, as the best has them, the written areas), the
    best of each other trigger step (of each other placement, when the partner is placed), best first: the starts a
    plan may choose among for what follows the contact (a clip's slide). [] for a speed with none."""
    x, y, yaw = paths
    n_cand, n_steps = x.shape
    latests = [LATEST] * len(partner_speeds) if latests is None else latests
    tau = dt * np.arange(1, n_steps + 1)
    sigma = -1.0 if opposite else 1.0
    dy = sign * y - partner_lateral
    lo, hi = overlap_interval(dy, sign * yaw, me, partner)
    # the poses from the trigger on (its first column: at the trigger), across and turned
    fixed = [np.concatenate([np.full((n_cand, 1), first), q], axis=1)
             for first, q in ((-partner_lateral, dy), (0.0, sign * yaw))]
    t0 = round(PLACED_TRIGGER / dt) * dt
    shifts = np.arange(-PLACE_RANGE, PLACE_RANGE + PLACE_STEP / 2, PLACE_STEP)
    cross = abs(partner_lateral) / 2 if boundary is None or not np.isfinite(boundary) else abs(boundary)

    def crossed(py: np.ndarray) -> np.ndarray:  # past the boundary, not past the partner's lane
        return (sign * (py + partner_lateral) >= cross + CROSS_MARGIN) \
            & (np.abs(py) <= abs(partner_lateral) - cross - CROSS_MARGIN)

    alongs, passes = [], []  # each speed's poses along the road, and its (offsets, placed) to try in turn
    for partner_speed, latest in zip(partner_speeds, latests):
        closing = speed - sigma * partner_speed
        along = x - sigma * partner_speed * tau[None, :]  # my centre along the road from the partner's, + its start
        alongs.append(np.concatenate([np.zeros((n_cand, 1)), along], axis=1))
        n_trig = int(latest / dt + 1e-9) + 1
        parts = closing * dt * np.arange(fine) / fine  # [m] finer starts of the partner within a step's closing
        starts = ((gap - closing * dt * np.arange(n_trig))[:, None] + parts[None, :]).ravel()  # its offset then
        passes.append(((starts, False, parts), (gap - closing * t0 + shifts, True, parts)) if place
                      else ((starts, False, parts),))
    out: list[list[tuple[int, float, float, float]]] = [[] for _ in partner_speeds]
    for attempt in range(2 if place else 1):
        todo = [g for g in range(len(partner_speeds)) if not out[g]]
        if not todo:
            break
        placed = attempt == 1
        ranked = _ranked_each([alongs[g] for g in todo], fixed, lo, hi, [passes[g][attempt][0] for g in todo], me,
                              partner, rotation, wanted, sigma, tau, crossed, np.abs(shifts) if placed else None,
                              central=fine > 1, fine=fine, count=count)
        for g, choices in zip(todo, ranked):
            for c, j, k in choices:
                trigger = t0 if placed else (j // fine) * dt
                shift = float(shifts[j]) if placed else float(passes[g][attempt][2][j % fine])
                # triggered half a step before the simulator step it is planned on
                out[g].append((c, max(trigger - dt / 2, 0.0), float(tau[k]), shift))
    return out


def _ranked_each(alongs, fixed, lo, hi, offsets_each, me: Body, partner: Body, rotation: float, wanted: Wanted,
                 sigma: float, tau: np.ndarray, crossed, shift_cost: np.ndarray | None, central: bool = False,
                 fine: int = 1, count: int = 1) -> list[list[tuple[int, int, int]]]:
    """[(candidate, offset index, step), ...] of the best first contact over the partner's offsets (O,) at the
    loss of control, for each (my poses along the road, the partner's offsets) pair (`alongs`, `offsets_each`),
    measured at once (each element as it would be alone): the written class; ranked by the miss of the
    rotation, my centre in the partner's lane (`crossed` of my offset across from the partner, CROSS_COST), the
    written areas (AREA_COST) and the placement's cost; with `central`, the middle of the run of offsets about
    as good as the best. After it, up to `count` - 1 others of the same candidate on other trigger steps (offset
    index // `fine`), each its step's best taken the same way, that miss in the lane and the areas no more than
    the best does, fewest misses first. alongs: my poses along the road from the partner's centre less its
    offset (C, K + 1) from the loss of control on; fixed: the same across from it and my yaw, the same for every
    pair."""
    out: list[list[tuple[int, int, int]]] = [[] for _ in alongs]
    found = _first_steps([along[:, 1:] for along in alongs], lo, hi, offsets_each)
    if found is None:
        return out
    group, cc, jj, kk = found
    other_yaw = 0.0 if sigma > 0 else math.pi
    # only contacts whose heading within their step admits the written class are moved back to the touch
    may = _may_be(wanted.contact_class, fixed[1][cc, kk], fixed[1][cc, kk + 1], other_yaw)
    if not may.any():
        return out
    group, cc, jj, kk = group[may], cc[may], jj[may], kk[may]
    px, py, pyaw = _touch(alongs, fixed, offsets_each, group, jj, cc, kk, me, partner, other_yaw)
    klass = monitor_class(px, py, pyaw, other_yaw, me, partner, wanted.skidder_first)
    ok = klass == wanted.contact_class if wanted.contact_class is not None else np.ones(len(cc), dtype=bool)
    if not ok.any():
        return out
    group, cc, jj, kk, px, py, pyaw = group[ok], cc[ok], jj[ok], kk[ok], px[ok], py[ok], pyaw[ok]
    # in the partner's lane a step before they touch (a recorded step before the contact)
    penalty = np.where(crossed(fixed[0][cc, kk]), 0.0, CROSS_COST)  # the misses of what is written, not of degree
    miss = np.abs(np.abs(pyaw) - rotation) + 0.02 * tau[kk] + penalty
    if shift_cost is not None:
        miss = miss + PLACE_COST + 0.005 * shift_cost[jj]
    if wanted.area is not None or wanted.partner_area is not None:
        # the areas at the point the simulator's impact takes (the corners inside the other body, close to
        # the centre of the overlap the monitor takes at a first contact)
        mine, theirs = lockstep.together(_areas, [(px, py, pyaw, me, partner, other_yaw)])[0]
        fits = ((mine == wanted.area) | (wanted.area is None)) & ((theirs == wanted.partner_area)
                                                                  | (wanted.partner_area is None))
        area_miss = np.where(fits, 0.0, AREA_COST)
        penalty = penalty + area_miss
        miss = miss + area_miss
    bounds = np.searchsorted(group, np.arange(len(alongs) + 1))  # each pair's contacts: a run of them
    for g in range(len(alongs)):
        b0, b1 = int(bounds[g]), int(bounds[g + 1])
        if b0 == b1:
            continue
        g_miss, g_cc, g_jj, g_penalty = miss[b0:b1], cc[b0:b1], jj[b0:b1], penalty[b0:b1]
        i = _pick(g_miss, g_cc, g_jj, np.ones(b1 - b0, dtype=bool), central)
        chosen = [i]
        if count > 1:
            # the same candidate on other trigger steps, as much in the lane and on the written areas as the best
            step = g_jj // fine
            same = (g_cc == g_cc[i]) & (g_penalty <= g_penalty[i])
            others = [s for s in np.unique(step[same]) if s != step[i]]
            picks = [_pick(g_miss, g_cc, g_jj, same & (step == s), central) for s in others]
            picks.sort(key=lambda p: (g_miss[p], p))
            chosen += picks[:count - 1]
        out[g] = [(int(g_cc[i]), int(g_jj[i]), int(kk[b0 + i])) for i in chosen]
    return out


def _pick(miss: np.ndarray, cc: np.ndarray, jj: np.ndarray, among: np.ndarray, central: bool) -> int:
    """The index of the best contact `among` (bool mask) a pair's: the least miss; with `central`, the middle of the
    run of offsets of its candidate about as good as it (a narrow window: a glancing contact)."""
    idx = np.nonzero(among)[0]
    i = int(idx[np.argsort(miss[idx], kind="stable")[0]])
    if central:
        run = idx[(cc[idx] == cc[i]) & (miss[idx] <= miss[i] + CENTRAL_TOLERANCE)]
        run = run[np.argsort(jj[run], kind="stable")]
        i = int(run[len(run) // 2])
    return i


def _areas(items: list) -> list[tuple[np.ndarray, np.ndarray]]:
    """(my areas, the partner's areas) of each item's contacts (my poses px, py, pyaw, me, partner, the partner's
    yaw; the partner at the origin), at the point the simulator's impact takes (impact.contact_frame: the corners
    inside the other body, close to the centre of the overlap the monitor takes at a first contact); all at
    once, each element as it would be alone."""
    if not items:
        return []
    sizes = [len(item[0]) for item in items]
    px, py, pyaw = (np.concatenate([item[j] for item in items]) for j in range(3))
    each = lockstep.per_element
    ml, mw = each((item[3].length for item in items), sizes), each((item[3].width for item in items), sizes)
    pl, pw = each((item[4].length for item in items), sizes), each((item[4].width for item in items), sizes)
    zero, oyaw = np.zeros(len(px)), each((item[5] for item in items), sizes)
    _, _, qx, qy = impact.contact_frame(px, py, pyaw, ml, mw, zero, zero, oyaw, pl, pw)
    return lockstep.per_item(contact_areas(px, py, pyaw, ml, mw, zero, zero, oyaw, pl, pw, qx, qy), sizes)


def _first_steps(alongs: list[np.ndarray], lo: np.ndarray, hi: np.ndarray, offsets_each: list[np.ndarray]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """(pair, candidate, offset index, step) of every first overlap, for each pair (along, offsets) of
    `alongs` (C, K) and `offsets_each` (O,) at once: candidate c with the partner at offsets[o] overlaps it
    first at step k, when my centre (along less the offset) is within [lo, hi] (C, K); sorted by pair, then
    candidate, then offset. None when nothing overlaps. Each step's overlapping offsets are a run of the
    sorted offsets, so only those runs are listed."""
    pc, pk = np.nonzero(lo <= hi)
    if not len(pc):
        return None
    n_pairs, n_cand = len(alongs), lo.shape[0]
    width = max(len(offsets) for offsets in offsets_each)
    at = np.stack([along[pc, pk] for along in alongs])  # (pairs, P) my centre along at each overlapping pose
    below, above = at - hi[pc, pk], at - lo[pc, pk]
    first_at, end, order = [], [], []
    for offsets, b, a in zip(offsets_each, below, above):
        rank = np.argsort(offsets, kind="stable")
        ranked = offsets[rank]
        first_at.append(np.searchsorted(ranked, b, side="left"))
        end.append(np.searchsorted(ranked, a, side="right"))
        order.append(rank)
    first_at, end = np.stack(first_at), np.stack(end)
    n = np.maximum(end - first_at, 0).ravel()
    total = int(n.sum())
    if not total:
        return None
    # each pair's sorted offsets one after the other: a pair's rank r is at base + r
    base = np.cumsum([0] + [len(rank) for rank in order[:-1]])
    start = (first_at + base[:, None]).ravel()
    pos = np.repeat(start, n) + np.arange(total) - np.repeat(np.cumsum(n) - n, n)
    pair = np.repeat(np.arange(n_pairs), len(pc))
    cand, step = np.tile(pc, n_pairs), np.tile(pk, n_pairs)
    never = np.iinfo(np.int64).max
    first = np.full(n_pairs * n_cand * width, never)
    cell = (np.repeat(pair, n) * n_cand + np.repeat(cand, n)) * width + np.concatenate(order)[pos]
    np.minimum.at(first, cell, np.repeat(step, n))
    first = first.reshape(n_pairs, n_cand, width)
    gg, cc, jj = np.nonzero(first < never)
    return gg, cc, jj, first[gg, cc, jj]


def _may_be(contact_class: str | None, yaw0: np.ndarray, yaw1: np.ndarray, other_yaw: float) -> np.ndarray:
    """Whether a contact whose yaw lies between yaw0 and yaw1 [rad] can have the class (rules.md heading bands)
    against a partner heading `other_yaw`; always for a sideswipe or an unwritten class."""
    if contact_class not in ("angle", "rear_end", "head_on"):
        return np.ones(len(yaw0), dtype=bool)
    d0, d1 = yaw0 - other_yaw, yaw1 - other_yaw
    low, high = np.minimum(d0, d1), np.maximum(d0, d1)
    r0 = np.degrees(heading_difference(d0, 0.0))
    r1 = np.degrees(heading_difference(d1, 0.0))
    lo_deg, hi_deg = np.minimum(r0, r1), np.maximum(r0, r1)
    # within a step the relative heading may pass 0 or 180 deg between its ends
    lo_deg = np.where(np.floor(high / TAU_TURN) > np.floor(low / TAU_TURN), 0.0, lo_deg)
    hi_deg = np.where(np.floor((high - math.pi) / TAU_TURN) > np.floor((low - math.pi) / TAU_TURN), 180.0, hi_deg)
    if contact_class == "angle":
        return (hi_deg >= ANGLE_RANGE[0]) & (lo_deg <= ANGLE_RANGE[1])
    if contact_class == "rear_end":
        return lo_deg < REAR_END_MAX
    return hi_deg > HEAD_ON_MIN


def _touch(alongs, fixed, offsets_each, group, jj, cc, kk, me: Body, partner: Body, other_yaw: float
           ) -> tuple[np.ndarray, ...]:
    """My pose (along, across, yaw) where candidates cc first touch the partner (at offsets_each[group][jj])
    during step kk, moved back along the step as the simulator does (`simulator._back_to_contact`:
    `geometry.touch_fraction`, linear poses); with other variations' touches at once (`_touches`, lockstep.run)."""
    bounds = np.searchsorted(group, np.arange(len(alongs) + 1))
    runs = [(g, int(bounds[g]), int(bounds[g + 1])) for g in range(len(alongs)) if bounds[g + 1] > bounds[g]]
    before = [np.concatenate([alongs[g][cc[b0:b1], kk[b0:b1]] - offsets_each[g][jj[b0:b1]] for g, b0, b1 in runs]),
              *(q[cc, kk] for q in fixed)]
    after = [np.concatenate([alongs[g][cc[b0:b1], kk[b0:b1] + 1] - offsets_each[g][jj[b0:b1]]
                             for g, b0, b1 in runs]), *(q[cc, kk + 1] for q in fixed)]
    return lockstep.together(_touches, [(before, after, me, partner, other_yaw)])[0]


def _touches(items: list) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """`_touch` of each item (my poses before and after the step (3 arrays), me, partner, the partner's yaw),
    bisected at once, each element as it would be alone."""
    if not items:
        return []
    sizes = [len(item[0][0]) for item in items]
    before = [np.concatenate([item[0][j] for item in items]) for j in range(3)]
    after = [np.concatenate([item[1][j] for item in items]) for j in range(3)]
    each = lockstep.per_element
    ml, mw = each((item[2].length for item in items), sizes), each((item[2].width for item in items), sizes)
    pl, pw = each((item[3].length for item in items), sizes), each((item[3].width for item in items), sizes)
    n = len(ml)
    zero, oyaw = np.zeros(n), each((item[4] for item in items), sizes)

    def pose(f):
        return [b + f * (a - b) for b, a in zip(before, after)]

    hi = touch_fraction(pose, lambda f: (zero, zero, oyaw), ml, mw, pl, pw, n)
    return lockstep.per_item(pose(hi), sizes)


def monitor_class(px, py, pyaw, other_yaw: float, me: Body, partner: Body, skidder_first: bool) -> np.ndarray:
    """The monitor's class (geometry.classify_contact) of contacts with me at (px, py, pyaw) and the partner at
    the origin heading `other_yaw`, in the monitor's actor order."""
    rel = heading_difference(pyaw, np.full(len(px), other_yaw))
    if skidder_first:
        c, s = np.cos(pyaw), np.sin(pyaw)
        lon, lat = -px * c - py * s, px * s - py * c
    else:
        c, s = math.cos(other_yaw), math.sin(other_yaw)
        lon, lat = px * c + py * s, -px * s + py * c
    return classify_contact(rel, lon, lat, (me.length + partner.length) / 2, (me.width + partner.width) / 2)
