"""Where a bird's-eye picture looks: its focus (first contact, closest approach, or the lone vehicle) and frame.

The frame is centred on the focus at a scale that shows the junction or curve
around it (never the whole map): at least MIN_HALF around the focus, grown to
hold a nearby junction, the vehicles at the key moment and their approach over
APPROACH seconds, and at least one stretch of road (a vehicle that left the road
is still shown beside it), capped at MAX_HALF.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from crashscene.geometry import footprint_corners
from crashscene.report.roadmap import MapGeometry
from crashscene.report.tracks import ActorTrack

MIN_HALF = (28.0, 16.0)  # [m] smallest half width, half height
MAX_HALF = 75.0  # [m] largest half extent
JUNCTION_REACH = 35.0  # [m] a junction this close to the focus is shown whole
MARGIN = 8.0  # [m] around what must be in frame
APPROACH = 1.0  # [s] of each vehicle's approach kept in frame
ROAD_SHOWN = 12.0  # [m] of road beside a vehicle that left it
DEPARTURE_AFTER = 1.0  # [s] after leaving the road: the picture of a run-off-road crash
MAX_ASPECT = 2.0  # width / height at most; frames are never taller than wide


@dataclass(frozen=True)
class Focus:
    """What a picture is about: `kind` contact | closest | departure | alone, at time t [s] and point (x, y) [m]."""

    kind: str
    t: float
    x: float
    y: float
    pair: tuple[str, str] | None = None  # roles
    gap: float | None = None  # [m] between the two footprints at the closest approach
    points: tuple[tuple[float, float], tuple[float, float]] | None = None  # nearest footprint points [m]


@dataclass(frozen=True)
class Frame:
    """A view window: centre and half extents [m]."""

    cx: float
    cy: float
    hx: float
    hy: float


def closest_approach(tracks: list[ActorTrack], involving: str | None = None) -> Focus | None:
    """The moment two vehicles came closest (footprint gap), or None with fewer than two vehicles.

    `involving` (a role) restricts the pairs to those with that vehicle, e.g. the ADS under test."""
    from shapely.geometry import Polygon
    from shapely.ops import nearest_points

    best = None
    for i in range(len(tracks)):
        for j in range(i + 1, len(tracks)):
            a, b = tracks[i], tracks[j]
            if involving is not None and involving not in (a.role, b.role):
                continue
            times = np.union1d(a.t, b.t)
            pa_, pb_ = np.array([a.at(t)[:2] for t in times]), np.array([b.at(t)[:2] for t in times])
            centre = np.hypot(*(pa_ - pb_).T)
            for k in np.argsort(centre, kind="stable")[:5]:  # the footprint gap is near the centre minimum
                t = float(times[k])
                fa, fb = Polygon(footprint_corners(*a.at(t), a.length, a.width)), Polygon(footprint_corners(*b.at(t), b.length, b.width))
                gap = float(fa.distance(fb))
                if best is None or gap < best[0] - 1e-9:
                    near = nearest_points(fa, fb)
                    best = (gap, t, (a.role, b.role), ((near[0].x, near[0].y), (near[1].x, near[1].y)))
    if best is None:
        return None
    gap, t, pair, points = best
    (x0, y0), (x1, y1) = points
    return Focus("closest", t, (x0 + x1) / 2, (y0 + y1) / 2, pair=pair, gap=gap,
                 points=((float(x0), float(y0)), (float(x1), float(y1))))


def alone(tracks: list[ActorTrack], t: float) -> Focus:
    """The lone vehicle's position at time t [s]."""
    x, y, _ = tracks[0].at(t)
    return Focus("alone", t, x, y)


def road_departure(geometry: MapGeometry, track: ActorTrack) -> Focus | None:
    """The vehicle DEPARTURE_AFTER seconds after its centre first left the drivable area, or None if it never did."""
    import shapely

    on = shapely.contains_xy(geometry.region, track.x, track.y)
    off = np.nonzero(~on)[0]
    if not len(off) or off[0] == 0:
        return None
    t = min(float(track.t[off[0]]) + DEPARTURE_AFTER, float(track.t[-1]))
    x, y, _ = track.at(t)
    return Focus("departure", t, x, y)


def choose_frame(geometry: MapGeometry, tracks: list[ActorTrack], focus: Focus) -> Frame:
    """The window around `focus` that shows the junction or curve, the vehicles and the road."""
    keep = [(focus.x, focus.y)]
    for tr in tracks:
        mask = (tr.t >= focus.t - APPROACH) & (tr.t <= focus.t)
        xs, ys = (tr.x[mask], tr.y[mask]) if mask.any() else (np.array([tr.at(focus.t)[0]]),
                                                              np.array([tr.at(focus.t)[1]]))
        keep += [(float(x), float(y)) for x, y in zip(xs, ys)]
    for ring in geometry.junctions:
        lo, hi = ring.min(axis=0), ring.max(axis=0)
        dx = max(lo[0] - focus.x, 0.0, focus.x - hi[0])
        dy = max(lo[1] - focus.y, 0.0, focus.y - hi[1])
        if math.hypot(dx, dy) <= JUNCTION_REACH:
            keep += [(float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1]))]
    for tr in tracks:
        x, y, _ = tr.at(focus.t)
        rx, ry, dist = geometry.nearest_road_point(x, y)
        if dist > 0.5 and math.isfinite(dist):  # off the road: the nearest road and a stretch of it
            keep += [(rx + (rx - x) / dist * ROAD_SHOWN, ry + (ry - y) / dist * ROAD_SHOWN)]
    pts = np.asarray(keep)
    hx = max(MIN_HALF[0], float(np.max(np.abs(pts[:, 0] - focus.x))) + MARGIN)
    hy = max(MIN_HALF[1], float(np.max(np.abs(pts[:, 1] - focus.y))) + MARGIN)
    hx, hy = min(hx, MAX_HALF), min(hy, MAX_HALF)
    hx, hy = max(hx, hy), max(hy, hx / MAX_ASPECT)
    return Frame(float(focus.x), float(focus.y), float(hx), float(hy))
