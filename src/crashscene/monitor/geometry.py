"""Footprints and relative positions of actors, vectorised over (variation, actor, step).

Footprints are oriented rectangles centred on (x, y) with the actor's length
along its yaw and width across it [m].
"""
from __future__ import annotations

import numpy as np

from crashscene.monitor.timeseries import wrap_angle


def corners(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, length: np.ndarray,
            width: np.ndarray) -> np.ndarray:
    """(..., 4, 2) footprint corners: front-left, front-right, rear-right, rear-left [m]."""
    c, s = np.cos(yaw), np.sin(yaw)
    hl, hw = length / 2, width / 2
    signs = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]], dtype=float)
    lon = signs[:, 0] * hl[..., None]
    lat = signs[:, 1] * hw[..., None]
    cx = x[..., None] + lon * c[..., None] - lat * s[..., None]
    cy = y[..., None] + lon * s[..., None] + lat * c[..., None]
    return np.stack([cx, cy], axis=-1)


def rectangles_overlap(ca: np.ndarray, cb: np.ndarray, yaw_a: np.ndarray, yaw_b: np.ndarray) -> np.ndarray:
    """Separating-axis test of two oriented rectangles given their corners (..., 4, 2); NaN -> False."""
    overlap = np.isfinite(ca).all(axis=(-1, -2)) & np.isfinite(cb).all(axis=(-1, -2))
    for yaw in (yaw_a, yaw_b):
        for angle in (yaw, yaw + np.pi / 2):
            axis = np.stack([np.cos(angle), np.sin(angle)], axis=-1)[..., None, :]
            pa = (ca * axis).sum(-1)
            pb = (cb * axis).sum(-1)
            with np.errstate(invalid="ignore"):
                overlap &= (pa.max(-1) >= pb.min(-1)) & (pb.max(-1) >= pa.min(-1))
    return overlap


def relative_position(x_a, y_a, yaw_a, x_b, y_b) -> tuple[np.ndarray, np.ndarray]:
    """Position of b in a's frame: (longitudinal ahead > 0, lateral left > 0) [m]."""
    dx, dy = x_b - x_a, y_b - y_a
    c, s = np.cos(yaw_a), np.sin(yaw_a)
    return dx * c + dy * s, -dx * s + dy * c


def heading_difference(yaw_a: np.ndarray, yaw_b: np.ndarray) -> np.ndarray:
    """Absolute heading difference in [0, pi] [rad]."""
    return np.abs(wrap_angle(yaw_b - yaw_a))


def pair_indices(n_actors: int) -> tuple[np.ndarray, np.ndarray]:
    """Unordered actor pairs (i < j) as two index arrays."""
    i, j = np.triu_indices(n_actors, k=1)
    return i, j
