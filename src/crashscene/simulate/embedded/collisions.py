"""Oriented-rectangle overlap (separating axis theorem), vectorised over variations."""
from __future__ import annotations

import numpy as np


def rectangles_overlap(xa: np.ndarray, ya: np.ndarray, yawa: np.ndarray, la: np.ndarray, wa: np.ndarray,
                       xb: np.ndarray, yb: np.ndarray, yawb: np.ndarray, lb: np.ndarray,
                       wb: np.ndarray) -> np.ndarray:
    """True where footprint a (centre, yaw, length, width [m, rad]) overlaps footprint b."""
    dx, dy = xb - xa, yb - ya
    ca, sa = np.cos(yawa), np.sin(yawa)
    cb, sb = np.cos(yawb), np.sin(yawb)
    # the four candidate separating axes: a's and b's long and lateral axes
    axes = ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb))
    overlap = np.ones(np.shape(xa), dtype=bool)
    for ux, uy in axes:
        dist = np.abs(dx * ux + dy * uy)
        ra = la / 2 * np.abs(ca * ux + sa * uy) + wa / 2 * np.abs(-sa * ux + ca * uy)
        rb = lb / 2 * np.abs(cb * ux + sb * uy) + wb / 2 * np.abs(-sb * ux + cb * uy)
        overlap &= dist <= ra + rb
    return overlap


def relative_heading(yaw_a: np.ndarray, yaw_b: np.ndarray) -> np.ndarray:
    """Unsigned angle between two headings [rad], in [0, pi]."""
    return np.abs(np.remainder(yaw_b - yaw_a + np.pi, 2 * np.pi) - np.pi)


def classify(yaw_a: float, yaw_b: float, dx: float | None = None, dy: float = 0.0, length_a: float = 4.5,
             length_b: float = 4.5) -> str:
    """Collision class by relative heading (rules.md): rear_end < 30 deg (struck from behind), head_on > 150 deg,
    angle 60-120 deg, sideswipe otherwise or when near-parallel vehicles touch side by side.
    (dx, dy) is b's centre minus a's [m], if known. The monitor's classification replaces this when present."""
    deg = float(np.degrees(relative_heading(np.asarray(yaw_a), np.asarray(yaw_b))))
    side_by_side = dx is not None and abs(dx * np.cos(yaw_a) + dy * np.sin(yaw_a)) < 0.6 * (length_a + length_b) / 2
    if deg < 30:
        return "sideswipe" if side_by_side else "rear_end"
    if deg > 150:
        return "sideswipe" if side_by_side else "head_on"
    if 60 <= deg <= 120:
        return "angle"
    return "sideswipe"
