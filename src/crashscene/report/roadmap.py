"""The road map as the report draws it: drivable area, lane edges, centre lines and junctions of an OpenDRIVE file.

Parsed once per map content by Scenic's `Network.fromFile` (Scenic caches its
`.snet` beside the map) and kept in memory, keyed by the file's hash, so cases
sharing a generated map parse it once per process. `north` is True only when
the file carries a `<geoReference>`: then +y is grid north. Generated maps are
laid out in the ego's frame (the ego approaches along +x) and have no north.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np


@dataclass
class MapGeometry:
    drivable: list[np.ndarray]  # exterior rings [m]
    holes: list[np.ndarray]  # interior rings [m]
    lane_edges: list[np.ndarray]  # polylines [m]
    center_lines: list[np.ndarray]  # polylines [m] between opposing directions
    junctions: list[np.ndarray]  # exterior rings [m] of junction areas
    north: bool  # +y is grid north (the map is georeferenced)
    _region: object = field(default=None, repr=False)

    @property
    def region(self):
        """The drivable area as one shapely geometry (built on first use)."""
        if self._region is None:
            from shapely.geometry import Polygon
            from shapely.ops import unary_union

            self._region = unary_union([Polygon(ring) for ring in self.drivable]).buffer(0)
        return self._region

    def nearest_road_point(self, x: float, y: float) -> tuple[float, float, float]:
        """The drivable point nearest to (x, y) [m] and its distance [m] (0 on the road)."""
        from shapely.geometry import Point
        from shapely.ops import nearest_points

        region = self.region
        if region.is_empty:
            return x, y, float("inf")
        point = Point(x, y)
        near = nearest_points(region, point)[0]
        return float(near.x), float(near.y), float(region.distance(point))


def load_map(path: str | Path) -> MapGeometry:
    """The drawable geometry of an OpenDRIVE file (cached by content)."""
    data = Path(path).read_bytes()
    return _load(hashlib.sha256(data).hexdigest(), str(path))


@lru_cache(maxsize=16)
def _load(digest: str, path: str) -> MapGeometry:
    from scenic.domains.driving.roads import Network

    network = Network.fromFile(path)
    polys = network.drivableRegion.polygons
    polys = list(getattr(polys, "geoms", [polys]))
    drivable = [np.asarray(p.exterior.coords)[:, :2] for p in polys]
    holes = [np.asarray(r.coords)[:, :2] for p in polys for r in p.interiors]
    edges = [np.asarray(edge.points, dtype=float)[:, :2] for lane in network.lanes
             for edge in (lane.leftEdge, lane.rightEdge)]
    centers = [np.asarray(road.forwardLanes.leftEdge.points, dtype=float)[:, :2] for road in network.roads
               if road.forwardLanes is not None and road.backwardLanes is not None]
    junctions = []
    for junction in network.intersections:
        shapes = junction.polygon
        for poly in getattr(shapes, "geoms", [shapes]):
            junctions.append(np.asarray(poly.exterior.coords)[:, :2])
    with open(path, "rb") as f:
        head = f.read(4096)
    return MapGeometry(drivable, holes, edges, centers, junctions, north=b"<geoReference" in head)
