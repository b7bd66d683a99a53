"""Motion after impact: the impulse-momentum exchange at a contact, and sliding until rest.

At a contact the two footprints (oriented rectangles) touch along a normal (the
separating axis of least penetration) at a contact point (the deepest corner, or
the middle of a face lying against a face). The exchange is a rigid-body impulse
with restitution E and inter-vehicle friction MU_CONTACT, applied to the centre
of mass (mass by vehicle type) and the yaw inertia of a uniform box. From then
on the vehicle is out of its driver's control and slides: its lateral velocity
decays at the tyre friction mu*g, its rolling velocity at ROLL_FRACTION of that
(damaged, the driver braking late), its yaw rate at the friction torque of the
box, until it is at rest. A second contact is exchanged the same way.
All arrays are per contact (vectorised over the variations that touch).
"""
from __future__ import annotations

import numpy as np

from crashscene.units import G

RESTITUTION = 0.15  # [-] vehicle-to-vehicle impacts are nearly plastic (reconstruction practice: 0.1-0.3)
MU_CONTACT = 0.4  # [-] friction between the two bodies along the contact face
ROLL_FRACTION = 0.35  # [-] rolling deceleration after an impact, as a fraction of mu*g
REST_SPEED = 0.15  # [m/s] below this (and REST_YAW_RATE) a sliding vehicle is at rest
REST_YAW_RATE = 0.05  # [rad/s]
INSIDE_TOLERANCE = 0.02  # [m] a corner this close to the other body counts as inside it
FACE_TOLERANCE = 0.15  # [m] corners this close to the deepest one form a face lying against the other


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
    dx, dy = xb - xa, yb - ya
    ca, sa, cb, sb = np.cos(yawa), np.sin(yawa), np.cos(yawb), np.sin(yawb)
    axes = [(ca, sa), (-sa, ca), (cb, sb), (-sb, cb)]
    depth = []
    for ux, uy in axes:
        ra = la / 2 * np.abs(ca * ux + sa * uy) + wa / 2 * np.abs(-sa * ux + ca * uy)
        rb = lb / 2 * np.abs(cb * ux + sb * uy) + wb / 2 * np.abs(-sb * ux + cb * uy)
        depth.append(ra + rb - np.abs(dx * ux + dy * uy))
    k = np.argmin(np.stack(depth), axis=0)
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
    return nx, ny, px, py


def _inside(px, py, x, y, c, s, length, width) -> np.ndarray:
    """(4, N) bool: which of the points (4, N) lie within the footprint at (x, y), heading (c, s) [m]."""
    dx, dy = px - x, py - y
    return (np.abs(dx * c + dy * s) <= length / 2 + INSIDE_TOLERANCE) \
        & (np.abs(-dx * s + dy * c) <= width / 2 + INSIDE_TOLERANCE)


def exchange(nx, ny, px, py, xa, ya, va, wa, ma, ia, xb, yb, vb, wb, mb, ib):
    """Impulse exchange at a contact. va, vb: (2, N) centre velocities [m/s]; wa, wb: yaw rates [rad/s];
    ma, mb [kg]; ia, ib [kg m2]. Returns the new (va, wa, vb, wb) and the impulse on b (2, N) [N s];
    where the bodies already separate nothing changes."""
    rax, ray = px - xa, py - ya
    rbx, rby = px - xb, py - yb
    vpa = np.stack([va[0] - wa * ray, va[1] + wa * rax])
    vpb = np.stack([vb[0] - wb * rby, vb[1] + wb * rbx])
    rel = vpb - vpa
    vn = rel[0] * nx + rel[1] * ny
    approaching = vn < 0

    def eff(tx, ty):
        cra = rax * ty - ray * tx
        crb = rbx * ty - rby * tx
        return 1.0 / ma + 1.0 / mb + cra ** 2 / ia + crb ** 2 / ib

    jn = np.where(approaching, -(1.0 + RESTITUTION) * vn / eff(nx, ny), 0.0)
    tx, ty = rel[0] - vn * nx, rel[1] - vn * ny
    tn = np.hypot(tx, ty)
    tx, ty = np.where(tn > 1e-9, tx / np.maximum(tn, 1e-9), 0.0), np.where(tn > 1e-9, ty / np.maximum(tn, 1e-9), 0.0)
    vt = rel[0] * tx + rel[1] * ty
    jt = np.clip(-vt / eff(tx, ty), -MU_CONTACT * jn, MU_CONTACT * jn)
    jx, jy = jn * nx + jt * tx, jn * ny + jt * ty
    vb = vb + np.stack([jx, jy]) / mb
    va = va - np.stack([jx, jy]) / ma
    wb = wb + (rbx * jy - rby * jx) / ib
    wa = wa - (rax * jy - ray * jx) / ia
    return va, wa, vb, wb, np.stack([jx, jy])


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
