"""Motion after impact: the impulse-momentum exchange at a contact, and the tyre forces until rest.

At a contact the two footprints (oriented rectangles) touch along a normal (the
separating axis of least penetration) at a contact point (the deepest corner, or
the middle of a face lying against a face). The exchange is the planar
impulse-momentum model of accident reconstruction (Brach, "Vehicle Accident
Analysis and Reconstruction Methods"): one impulse at the contact point
on both rigid bodies (mass by vehicle type, yaw inertia of a uniform box),
normal restitution RESTITUTION, and a tangential impulse that makes the contact
points stick when that needs no more than MU_CONTACT times the normal impulse,
else slides at that ratio (Coulomb). Linear and angular momentum are conserved;
no energy is created. A vehicle the impact upsets (`crashscene.upset.upsets`, thresholds shared with the
monitor) is from then on out of its driver's control: each axle slides on its tyres with Coulomb friction against
its contact patch's velocity (mu across the body, ROLL_FRACTION of it along), so a vehicle sliding
sideways keeps spinning, one rolling on stops turning, until it is at rest
(`tyre_slide`). Rigid bodies do not pass through each other: after the exchange, two footprints that still
overlap are pushed apart along the normal until they barely touch (`separate`, each by its share of the inverse
mass, as a rigid-body engine's position projection does), so that bodies turned towards each other by the
impulse (a struck car spun round by an offset impact) meet again face to face instead of rotating through each
other. A second contact is exchanged the same way. `slide` is the
motion of a planned loss of control before any impact (skid), whose yaw the
plan holds. All arrays are per contact (vectorised over the variations that touch).
"""
from __future__ import annotations

import numpy as np

from crashscene.units import G

RESTITUTION = 0.15  # [-] vehicle-to-vehicle impacts are nearly plastic (reconstruction practice: 0.1-0.3)
MU_CONTACT = 0.4  # [-] limiting ratio of tangential to normal impulse between two vehicle bodies (Brach's
# impulse ratio; crushed sheet metal interlocks, so the contact points often stick)
ROLL_FRACTION = 0.35  # [-] rolling deceleration after an impact, as a fraction of mu*g (damaged, braked late)
REST_SPEED = 0.15  # [m/s] below this (and REST_YAW_RATE) a sliding vehicle is at rest
REST_YAW_RATE = 0.05  # [rad/s]
INSIDE_TOLERANCE = 0.02  # [m] a corner this close to the other body counts as inside it
FACE_TOLERANCE = 0.15  # [m] corners this close to the deepest one form a face lying against the other
OVERLAP_KEPT = 0.05  # [m] two bodies pushed apart after an exchange are left this deep in each other (`separate`):
# they still touch in the trace, as the monitor sees contacts
TYRE_SWEEPS = 4  # [-] Gauss-Seidel sweeps of the two axles' friction impulses per step (tyre_slide)


def yaw_inertia(mass: np.ndarray, length: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Yaw moment of inertia [kg m2] of a uniform box."""
    return mass * (length ** 2 + width ** 2) / 12.0


def _corners(x, y, yaw, length, width) -> tuple[np.ndarray, np.ndarray]:
    """(4, N) corner coordinates of footprints."""
    c, s = np.cos(yaw), np.sin(yaw)
    lon = np.array([1.0, 1.0, -1.0, -1.0])[:, None] * (length / 2)
    lat = np.array([1.0, -1.0, -1.0, 1.0])[:, None] * (width / 2)
    return x + lon * c - lat * s, y + lon * s + lat * c


def contact_frame(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) -> tuple[np.ndarray, ...]:
    """(nx, ny, px, py): unit contact normal pointing from a to b, and the contact point [m], of touching pairs."""
    return contact(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb)[:4]


def contact(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) -> tuple[np.ndarray, ...]:
    """`contact_frame`'s (nx, ny, px, py) and the penetration [m] along the normal: the least of the separating
    axes' depths, -`footprint_separation` bit for bit (what `separate` needs of the same poses)."""
    dx, dy = xb - xa, yb - ya
    ca, sa, cb, sb = np.cos(yawa), np.sin(yawa), np.cos(yawb), np.sin(yawb)
    axes = [(ca, sa), (-sa, ca), (cb, sb), (-sb, cb)]
    depth = []
    for ux, uy in axes:
        ra = la / 2 * np.abs(ca * ux + sa * uy) + wa / 2 * np.abs(-sa * ux + ca * uy)
        rb = lb / 2 * np.abs(cb * ux + sb * uy) + wb / 2 * np.abs(-sb * ux + cb * uy)
        depth.append(ra + rb - np.abs(dx * ux + dy * uy))
    depth = np.stack(depth)
    k = np.argmin(depth, axis=0)
    ux = np.choose(k, [ax[0] for ax in axes])
    uy = np.choose(k, [ax[1] for ax in axes])
    sign = np.where(dx * ux + dy * uy >= 0, 1.0, -1.0)
    nx, ny = ux * sign, uy * sign
    # the contact point: the corners of either body that lie inside the other (an offset rear-end touches
    # where the two faces overlap, not at the middle of either face); when none does, the deepest corners
    # of the body reaching into the other's face
    bx, by = _corners(xb, yb, yawb, lb, wb)
    ax_, ay_ = _corners(xa, ya, yawa, la, wa)
    in_a = _inside(bx, by, xa, ya, ca, sa, la, wa)
    in_b = _inside(ax_, ay_, xb, yb, cb, sb, lb, wb)
    n_in = in_a.sum(axis=0) + in_b.sum(axis=0)
    qx = ((bx * in_a).sum(axis=0) + (ax_ * in_b).sum(axis=0)) / np.maximum(n_in, 1)
    qy = ((by * in_a).sum(axis=0) + (ay_ * in_b).sum(axis=0)) / np.maximum(n_in, 1)
    on_a = k < 2
    proj_b = bx * nx + by * ny
    proj_a = -(ax_ * nx + ay_ * ny)
    cx, cy = np.where(on_a, bx, ax_), np.where(on_a, by, ay_)
    proj = np.where(on_a, proj_b, proj_a)
    near = proj <= proj.min(axis=0) + FACE_TOLERANCE
    count = near.sum(axis=0)
    px = np.where(n_in > 0, qx, (cx * near).sum(axis=0) / count)
    py = np.where(n_in > 0, qy, (cy * near).sum(axis=0) / count)
    return nx, ny, px, py, depth.min(axis=0)


def _inside(px, py, x, y, c, s, length, width) -> np.ndarray:
    """(4, N) bool: which of the points (4, N) lie within the footprint at (x, y), heading (c, s) [m]."""
    dx, dy = px - x, py - y
    return (np.abs(dx * c + dy * s) <= length / 2 + INSIDE_TOLERANCE) \
        & (np.abs(-dx * s + dy * c) <= width / 2 + INSIDE_TOLERANCE)


def exchange(nx, ny, px, py, xa, ya, va, wa, ma, ia, xb, yb, vb, wb, mb, ib):
    """Planar impulse exchange at a contact (Brach's impulse-momentum model). va, vb: (2, N) centre velocities
    [m/s]; wa, wb: yaw rates [rad/s]; ma, mb [kg]; ia, ib [kg m2]. Returns the new (va, wa, vb, wb) and the
    impulse on b (2, N) [N s]; where the bodies already separate nothing changes.

    The impulse P on b (-P on a) changes the relative velocity of the contact points by K P, K the 2x2 inverse
    effective mass of the two bodies at the contact (translation and yaw of each). If the impulse that ends the
    sliding along the face (and leaves the normal approach speed reversed times RESTITUTION) lies within the
    friction cone (tangential <= MU_CONTACT x normal), the faces stick; otherwise they slide and the tangential
    impulse is MU_CONTACT times the normal one, against the sliding. Linear and angular momentum are conserved.
    """
    rax, ray = px - xa, py - ya
    rbx, rby = px - xb, py - yb
    vpa = np.stack([va[0] - wa * ray, va[1] + wa * rax])
    vpb = np.stack([vb[0] - wb * rby, vb[1] + wb * rbx])
    rel = vpb - vpa
    vn = rel[0] * nx + rel[1] * ny
    approaching = vn < 0
    inv_m = 1.0 / ma + 1.0 / mb
    kxx = inv_m + ray ** 2 / ia + rby ** 2 / ib
    kyy = inv_m + rax ** 2 / ia + rbx ** 2 / ib
    kxy = -rax * ray / ia - rbx * rby / ib
    det = kxx * kyy - kxy ** 2
    # sticking: the impulse that leaves the contact points with no sliding and the normal speed -E * vn
    tx_, ty_ = -(rel[0] + RESTITUTION * vn * nx), -(rel[1] + RESTITUTION * vn * ny)
    sx, sy = (kyy * tx_ - kxy * ty_) / det, (kxx * ty_ - kxy * tx_) / det
    s_n = sx * nx + sy * ny
    s_t = np.hypot(sx - s_n * nx, sy - s_n * ny)
    sticks = (s_n > 0) & (s_t <= MU_CONTACT * s_n)
    # sliding: the tangential impulse is MU_CONTACT times the normal one, against the sliding direction
    ux, uy = rel[0] - vn * nx, rel[1] - vn * ny
    un = np.hypot(ux, uy)
    ux, uy = np.where(un > 1e-9, ux / np.maximum(un, 1e-9), 0.0), np.where(un > 1e-9, uy / np.maximum(un, 1e-9), 0.0)
    dx, dy = nx - MU_CONTACT * ux, ny - MU_CONTACT * uy
    k_nd = nx * (kxx * dx + kxy * dy) + ny * (kxy * dx + kyy * dy)
    k_nn = nx * (kxx * nx + kxy * ny) + ny * (kxy * nx + kyy * ny)
    # with a strongly eccentric contact the friction could add to the approach: no more than a frictionless push
    k_nd = np.maximum(k_nd, 0.5 * k_nn)
    jn = -(1.0 + RESTITUTION) * vn / k_nd
    jx = np.where(sticks, sx, jn * dx)
    jy = np.where(sticks, sy, jn * dy)
    jx, jy = np.where(approaching, jx, 0.0), np.where(approaching, jy, 0.0)
    vb = vb + np.stack([jx, jy]) / mb
    va = va - np.stack([jx, jy]) / ma
    wb = wb + (rbx * jy - rby * jx) / ib
    wa = wa - (rax * jy - ray * jx) / ia
    return va, wa, vb, wb, np.stack([jx, jy])


def separate(xa, ya, yawa, la, wa, ma, xb, yb, yawb, lb, wb, mb, frame=None) -> tuple[np.ndarray, ...]:
    """(dxa, dya, dxb, dyb) [m]: the moves that leave two overlapping footprints no deeper in each other than
    OVERLAP_KEPT, along the normal of least penetration (`contact_frame`, the separating-axis depth), a's share
    mb / (ma + mb) of it (the lighter body moves further); zero where they overlap less. A contact's onset (moved
    back to where the two first touched) is left as it is, so the trace shows the overlap the monitor reads.
    `frame`: `contact`'s (nx, ny, penetration) of these same poses, when the caller has it."""
    if frame is None:
        nx, ny, _, _, penetration = contact(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb)
    else:
        nx, ny, penetration = frame
    depth = np.maximum(penetration - OVERLAP_KEPT, 0.0)
    share_a = mb / (ma + mb)
    return (-share_a * depth * nx, -share_a * depth * ny, (1.0 - share_a) * depth * nx, (1.0 - share_a) * depth * ny)


def slide(vx, vy, yaw, yaw_rate, friction: float, length, width, dt: float):
    """One step of sliding after an impact: (vx, vy, yaw_rate) decayed by tyre friction over dt [s]."""
    c, s = np.cos(yaw), np.sin(yaw)
    u = vx * c + vy * s  # rolling (along the body)
    w = -vx * s + vy * c  # sliding (across the body)
    mg = friction * G
    u = np.sign(u) * np.maximum(np.abs(u) - ROLL_FRACTION * mg * dt, 0.0)
    w = np.sign(w) * np.maximum(np.abs(w) - mg * dt, 0.0)
    spin_decel = 3.0 * mg * length / (length ** 2 + width ** 2)  # friction torque / box inertia [rad/s2]
    yaw_rate = np.sign(yaw_rate) * np.maximum(np.abs(yaw_rate) - spin_decel * dt, 0.0)
    vx, vy = u * c - w * s, u * s + w * c
    rest = (np.hypot(vx, vy) < REST_SPEED) & (np.abs(yaw_rate) < REST_YAW_RATE)
    return np.where(rest, 0.0, vx), np.where(rest, 0.0, vy), np.where(rest, 0.0, yaw_rate)


def tyre_slide(vx, vy, yaw, yaw_rate, friction, length, width, wheelbase, dt: float):
    """One step of a vehicle's motion after an impact, out of its driver's control: (vx, vy, yaw_rate) after the
    tyre forces of dt [s].

    Each axle (half the wheelbase ahead of and behind the centre of mass, half the weight N on each) slides on
    its tyres against the velocity (u, w) of its contact patch, as a wheel whose demanded force exceeds the
    friction does in PC-Crash's tyre model (Steffan and Moser, SAE 960886: mu N against the wheel's velocity,
    mu N sin(slip angle) across), with the share along the body reduced to ROLL_FRACTION (the wheels still
    roll, braked late): the force -mu N (ROLL_FRACTION u, w) / |(u, w)|. A vehicle sliding sideways, or rolling fast, while it yaws has its
    axles' forces nearly parallel and keeps most of its yaw rate until it slows, as a vehicle spun by an impact
    does; one yawing at low speed has its axles sliding opposite ways and stops turning quickly. The forces are
    applied implicitly (no larger than what stops the sliding within the step). Yaw inertia: the uniform box
    (yaw_inertia). Without yaw the rates are those of `slide`: mu g across, ROLL_FRACTION mu g along.
    """
    c, s = np.cos(yaw), np.sin(yaw)
    u = vx * c + vy * s  # rolling (along the body)
    w = -vx * s + vy * c  # sliding (across the body)
    h = wheelbase / 2  # [m] each axle's distance from the centre of mass
    q = h ** 2 * 12.0 / (length ** 2 + width ** 2)  # h^2 / k^2, k the yaw radius of gyration of the box
    w_f, w_r = w + yaw_rate * h, w - yaw_rate * h
    step = 0.5 * friction * G * dt  # [m/s] the velocity change each axle's friction gives in a step (per unit mass)
    speed_f = np.maximum(np.hypot(u, w_f), 1e-9)
    speed_r = np.maximum(np.hypot(u, w_r), 1e-9)
    du = ROLL_FRACTION * step * np.abs(u) * (1.0 / speed_f + 1.0 / speed_r)
    u = np.sign(u) * np.maximum(np.abs(u) - du, 0.0)
    cap_f, cap_r = step * np.abs(w_f) / speed_f, step * np.abs(w_r) / speed_r
    # the axles' lateral impulses (per unit mass) that would stop both sliding, within each axle's share of the
    # friction (projected Gauss-Seidel on the 2 x 2 system; the coupling 1 - q is small, a few sweeps settle it)
    # (np.minimum/np.maximum: np.clip's arithmetic without its overhead, which the plans' many short slides feel)
    one_minus, one_plus = 1.0 - q, 1.0 + q
    p_r = np.zeros_like(w_r)
    for _ in range(TYRE_SWEEPS):
        p_f = np.minimum(np.maximum(-(w_f + one_minus * p_r) / one_plus, -cap_f), cap_f)
        p_r = np.minimum(np.maximum(-(w_r + one_minus * p_f) / one_plus, -cap_r), cap_r)
    w = w + p_f + p_r
    yaw_rate = yaw_rate + (p_f - p_r) * q / h
    vx, vy = u * c - w * s, u * s + w * c
    rest = (np.hypot(vx, vy) < REST_SPEED) & (np.abs(yaw_rate) < REST_YAW_RATE)
    return np.where(rest, 0.0, vx), np.where(rest, 0.0, vy), np.where(rest, 0.0, yaw_rate)


def glide(x, y, yaw, vx0, vy0, yaw_rate0, vx1, vy1, yaw_rate1, dt: float):
    """The pose (x, y, yaw, the yaw not wrapped) of a sliding vehicle after a step of dt [s] in which its velocity
    [m/s] and yaw rate [rad/s] went from (vx0, vy0, yaw_rate0) to (vx1, vy1, yaw_rate1): trapezoidal, the one
    integration of a slide (the simulator's step, the plans' predictions of it)."""
    return x + 0.5 * (vx0 + vx1) * dt, y + 0.5 * (vy0 + vy1) * dt, yaw + 0.5 * (yaw_rate0 + yaw_rate1) * dt
