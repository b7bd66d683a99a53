"""The small geometric vocabulary every stage builds on: angles, footprints, contacts, lanes.

Conventions: yaw 0 = +x (OpenDRIVE), counter-clockwise [rad]; an actor's
footprint is an oriented rectangle centred on (x, y) with its length along
its yaw and its width across it [m]; "b in a's frame" is (longitudinal,
ahead > 0; lateral, left > 0) [m]. Everything is vectorised: arrays of any
shape broadcast together. Route geometry (station s and lateral offset d along
a route) lives on the routes themselves: `RouteArrays.point` /
`RouteArrays.local_coordinates` and `Route.local_coordinates`
(`crashscene.simulate`).
"""
from __future__ import annotations

import math

import numpy as np
import shapely

LANE_WIDTH = 3.5  # [m] lane width of generated maps, and the fallback where a map gives none
TAU = 2.0 * math.pi  # [rad] one turn

# collision classes by relative heading (rules.md): bounds [deg]
REAR_END_MAX = 30.0  # [deg] below: same direction (rear-end, or sideswipe when side to side)
HEAD_ON_MIN = 150.0  # [deg] above: opposite directions (head-on, or sideswipe when side to side)
ANGLE_RANGE = (60.0, 120.0)  # [deg] within: an angle (T-bone) collision; anything else is a sideswipe


def wrap_angle(angle, exact: bool = False):
    """Angle [rad] wrapped to [-pi, pi].

    A scalar is wrapped exactly (IEEE remainder, `math.remainder`) and comes
    back as a float; so is an array with `exact=True` (element by element).
    Otherwise an array is wrapped as (angle + pi) mod 2 pi - pi, in [-pi, pi),
    which can differ from the exact value in the last bit: the simulator's
    state has always been wrapped that way, and seeded runs keep their bytes.
    Use `exact=True` where values must agree with scalars wrapped elsewhere
    (a recorded yaw with the sampled scene's yaw).
    """
    if np.ndim(angle) == 0 and not isinstance(angle, np.ndarray):
        return math.remainder(float(angle), TAU)
    angle = np.asarray(angle, dtype=float)
    if exact:
        # fmod is exact, and so is the one-turn correction (Sterbenz): the IEEE remainder, vectorised
        r = np.fmod(angle, TAU)
        r = np.where(r > np.pi, r - TAU, np.where(r < -np.pi, r + TAU, r))
        # halfway (+-pi): the remainder takes the even number of turns
        odd = (np.abs(r) == np.pi) & (np.round((angle - r) / TAU) % 2 == 1)
        return np.where(odd, -r, r)
    return np.remainder(angle + np.pi, TAU) - np.pi


def clip_scalar(x: float, lo: float, hi: float) -> float:
    """`float(np.clip(x, lo, hi))` of one number without numpy's call overhead (~5 us, which plans that clip a few
    numbers per variation feel): the same float, as numpy's clip gives it: a NaN (of x or a bound) stays NaN, and a
    value equal to a bound is kept as it is (-0.0 clipped to [0, 1] stays -0.0)."""
    if x != x or lo != lo or hi != hi:
        return float(x if x != x else lo if lo != lo else hi)
    m = lo if x < lo else x  # np.maximum, then np.minimum (inverted bounds give hi, as numpy's do)
    return float(hi if m > hi else m)


def heading_difference(yaw_a, yaw_b):
    """Unsigned angle between two headings [rad], in [0, pi]."""
    return np.abs(wrap_angle(np.asarray(yaw_b) - np.asarray(yaw_a)))


def relative_position(x_a, y_a, yaw_a, x_b, y_b, cos_sin=None) -> tuple[np.ndarray, np.ndarray]:
    """Position of b in a's frame: (longitudinal ahead > 0, lateral left > 0) [m]. `cos_sin`: (cos, sin) of
    yaw_a when the caller has them (yaw_a is then not read)."""
    dx, dy = x_b - x_a, y_b - y_a
    c, s = (np.cos(yaw_a), np.sin(yaw_a)) if cos_sin is None else cos_sin
    return dx * c + dy * s, -dx * s + dy * c


def pose_class(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) -> tuple[np.ndarray, ...]:
    """The class (`classify_contact`) of contacts between a and b at their poses [m, m, rad] and sizes [m], as
    the monitor classifies a contact (a the earlier actor of the pair), with what it reads it by: (class, the
    relative heading [rad], b's offset in a's frame (lon, lat [m], `relative_position`))."""
    rel = heading_difference(yawa, yawb)
    lon, lat = relative_position(xa, ya, yawa, xb, yb)
    return classify_contact(rel, lon, lat, (la + lb) / 2, (wa + wb) / 2), rel, lon, lat


def footprint_corners(x, y, yaw, length, width) -> np.ndarray:
    """(..., 4, 2) footprint corners [m]: front-left, front-right, rear-right, rear-left."""
    x, y, yaw = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float), np.asarray(yaw, float))
    c, s = np.cos(yaw), np.sin(yaw)
    hl, hw = np.asarray(length, float) / 2, np.asarray(width, float) / 2
    signs = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]], dtype=float)
    lon = signs[:, 0] * hl[..., None]
    lat = signs[:, 1] * hw[..., None]
    cx = x[..., None] + lon * c[..., None] - lat * s[..., None]
    cy = y[..., None] + lon * s[..., None] + lat * c[..., None]
    return np.stack([cx, cy], axis=-1)


def footprint_separation(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb, trig=None) -> np.ndarray:
    """[m] the largest gap between footprints a and b (centre, yaw, length, width [m, rad]) along the four
    separating axes (a's and b's long and lateral axes): positive when apart (a lower bound of their
    distance, exact when a face separates them), zero or negative when they overlap or touch; NaN for a
    NaN pose. `trig`: (cos yawa, sin yawa, cos yawb, sin yawb) when the caller has them."""
    dx, dy = xb - xa, yb - ya
    ca, sa, cb, sb = (np.cos(yawa), np.sin(yawa), np.cos(yawb), np.sin(yawb)) if trig is None else trig
    axes = ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb))
    gap = np.full(np.broadcast(dx, dy, ca, cb).shape, -np.inf)
    for ux, uy in axes:
        dist = np.abs(dx * ux + dy * uy)
        # half extent of each rectangle projected on the axis
        ra = la / 2 * np.abs(ca * ux + sa * uy) + wa / 2 * np.abs(-sa * ux + ca * uy)
        rb = lb / 2 * np.abs(cb * ux + sb * uy) + wb / 2 * np.abs(-sb * ux + cb * uy)
        gap = np.maximum(gap, dist - (ra + rb))
    return gap


def footprints_overlap(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) -> np.ndarray:
    """True where footprint a (centre, yaw, length, width [m, rad]) overlaps or touches footprint b
    (the separating-axis test, `footprint_separation` <= 0); a NaN pose never overlaps."""
    with np.errstate(invalid="ignore"):
        return footprint_separation(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) <= 0


TOUCH_HALVINGS = 8  # [-] bisections of a step to find where two footprints first touch (1/256 of the step)


def touch_fraction(pose_a, pose_b, la, wa, lb, wb, n: int) -> np.ndarray:
    """The fraction (0, 1] of a step at which two footprints first touch, each moving through the step along
    `pose(f)` -> (x, y, yaw) at fraction f (n,) of it: the end of the last of TOUCH_HALVINGS bisections (they
    touch there), 1 where they touch only at the step's end."""
    lo, hi = np.zeros(n), np.ones(n)
    for _ in range(TOUCH_HALVINGS):
        mid = (lo + hi) / 2
        touching = footprints_overlap(*pose_a(mid), la, wa, *pose_b(mid), lb, wb)
        hi = np.where(touching, mid, hi)
        lo = np.where(touching, lo, mid)
    return hi


def classify_contact(rel_heading, lon=None, lat=None, half_len=None, half_wid=None, end_on=None) -> np.ndarray:
    """Collision class names (rules.md) for contacts, given their relative heading [rad].

    `rear_end` under 30 deg, `head_on` over 150 deg, `angle` within 60-120 deg,
    `sideswipe` otherwise. Given b's offset in a's frame (`lon`, `lat` [m]) and
    the sums of the two half lengths / half widths [m], a near-parallel contact
    is end-on (rear-end or head-on) only when the longitudinal gap is closer to
    touching than the lateral one, and a sideswipe when side to side; `end_on`
    (a bool, or one per contact) says which instead, for contacts whose offsets
    are not known; with neither, every contact counts as end-on.
    """
    deg = np.degrees(np.asarray(rel_heading, dtype=float))
    if end_on is not None:
        if lon is not None:
            raise ValueError("classify_contact: give the offsets (lon, lat, ...) or end_on, not both")
        end_on = np.broadcast_to(np.asarray(end_on, dtype=bool), deg.shape)
    elif lon is None:
        end_on = np.ones(deg.shape, dtype=bool)
    else:
        end_on = (np.abs(lon) - half_len) > (np.abs(lat) - half_wid)
    out = np.full(deg.shape, "sideswipe", dtype=object)
    out[(deg < REAR_END_MAX) & end_on] = "rear_end"
    out[(deg > HEAD_ON_MIN) & end_on] = "head_on"
    out[(deg >= ANGLE_RANGE[0]) & (deg <= ANGLE_RANGE[1])] = "angle"
    return out


def footprint_area(lon, lat, length, width) -> np.ndarray:
    """The area (front, rear, left, right: the quarter of a footprint split by its diagonals) holding the point
    (lon, lat) of the footprint's own frame [m]."""
    with np.errstate(invalid="ignore", divide="ignore"):
        u, w = lon / (length / 2), lat / (width / 2)
    return np.where(np.abs(u) >= np.abs(w), np.where(u >= 0, "front", "rear"),
                    np.where(w >= 0, "left", "right")).astype(object)


def overlap_centre(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb) -> tuple[np.ndarray, np.ndarray]:
    """Centroid [m] of the overlap of footprints a and b (1-D arrays); NaN where they do not overlap."""
    boxes = [shapely.polygons(footprint_corners(x, y, yaw, length, width))
             for x, y, yaw, length, width in ((xa, ya, yawa, la, wa), (xb, yb, yawb, lb, wb))]
    centre = shapely.centroid(shapely.intersection(*boxes))
    coords = np.full((len(centre), 2), np.nan)
    found = ~shapely.is_empty(centre) & ~shapely.is_missing(centre)
    coords[found] = shapely.get_coordinates(centre[found])
    return coords[:, 0], coords[:, 1]


def contact_areas(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb, cx=None, cy=None) -> tuple[np.ndarray, np.ndarray]:
    """The area of each footprint that touched (`footprint_area`) at the contact point (cx, cy) [m], by default
    the centre of their overlap (1-D arrays)."""
    if cx is None:
        cx, cy = overlap_centre(xa, ya, yawa, la, wa, xb, yb, yawb, lb, wb)
    return (footprint_area(*relative_position(xa, ya, yawa, cx, cy), la, wa),
            footprint_area(*relative_position(xb, yb, yawb, cx, cy), lb, wb))


def pair_indices(n_actors: int) -> tuple[np.ndarray, np.ndarray]:
    """Unordered actor pairs (i < j) as two index arrays."""
    i, j = np.triu_indices(n_actors, k=1)
    return i, j
