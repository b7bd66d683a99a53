"""Road coordinates on an OpenDRIVE map: a point (x, y) [m] -> (road id, s, t, lane id).

Reads the plan view (line and arc geometries, which is what the generated maps use
outside junctions) and the constant lane widths of each road; junction connecting
roads are left out, since exported positions are on approaches and exits.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from crashscene.export.errors import ExportError


@dataclass(frozen=True)
class RoadPoint:
    road: str  # OpenDRIVE road id
    s: float  # [m] along the reference line
    t: float  # [m] lateral, + = left of the reference line
    lane: int  # OpenDRIVE lane id (+ left of the reference line, - right)
    distance: float  # [m] from the query point to the road's lanes, 0 when on one
    length: float  # [m] road length


@dataclass(frozen=True)
class _Geometry:
    s: float
    x: float
    y: float
    hdg: float
    length: float
    curvature: float  # [1/m], 0 for a line

    def project(self, px: float, py: float) -> tuple[float, float, float]:
        """(ds along this piece, t, distance beyond its ends) of point (px, py)."""
        dx, dy = px - self.x, py - self.y
        c, s = math.cos(self.hdg), math.sin(self.hdg)
        if self.curvature == 0.0:
            u, v = dx * c + dy * s, -dx * s + dy * c
        else:
            r = 1.0 / self.curvature
            cx, cy = self.x - r * s, self.y + r * c  # centre of the circle
            start = math.atan2(self.y - cy, self.x - cx)
            ang = math.atan2(py - cy, px - cx)
            sweep = (ang - start) * math.copysign(1.0, r)
            sweep = (sweep + math.pi) % (2 * math.pi) - math.pi
            u = sweep * abs(r)
            v = (abs(r) - math.hypot(px - cx, py - cy)) * math.copysign(1.0, r)
        outside = max(0.0, -u, u - self.length)
        return min(max(u, 0.0), self.length), v, outside


class RoadFrame:
    """Non-junction roads of an OpenDRIVE file, for projecting points to road coordinates."""

    def __init__(self, path: Path):
        try:
            root = ET.parse(path).getroot()
        except (ET.ParseError, OSError) as exc:
            raise ExportError(f"{path}: cannot read the OpenDRIVE map: {exc}") from exc
        self.path = Path(path)
        self.roads: dict[str, tuple[float, list[_Geometry], list[tuple[int, float]], list[tuple[int, float]]]] = {}
        for road in root.iter("road"):
            if road.get("junction", "-1") != "-1":
                continue
            pieces = []
            for g in road.iterfind("./planView/geometry"):
                kind = next(iter(g), None)
                if kind is None or kind.tag not in ("line", "arc"):
                    raise ExportError(f"{path}: road {road.get('id')} has a {getattr(kind, 'tag', 'missing')} "
                                      "geometry; exported positions support line and arc roads")
                pieces.append(_Geometry(float(g.get("s")), float(g.get("x")), float(g.get("y")), float(g.get("hdg")),
                                        float(g.get("length")),
                                        float(kind.get("curvature")) if kind.tag == "arc" else 0.0))
            section = road.find("./lanes/laneSection")
            left = sorted(((int(ln.get("id")), float(ln.find("width").get("a")))
                           for ln in section.iterfind("./left/lane")), key=lambda p: p[0])
            right = sorted(((int(ln.get("id")), float(ln.find("width").get("a")))
                            for ln in section.iterfind("./right/lane")), key=lambda p: -p[0])
            self.roads[road.get("id")] = (float(road.get("length")), pieces, left, right)

    def curvature(self, road: str, s: float) -> float:
        """[1/m] of the reference line of `road` at `s` (0 on lines)."""
        pieces = self.roads[road][1]
        current = pieces[0]
        for g in pieces:
            if s >= g.s:
                current = g
        return current.curvature

    def lane_center(self, road: str, lane: int) -> float:
        """[m] lateral offset t of the centre of lane `lane` of `road` (+ left)."""
        _, _, left, right = self.roads[road]
        widths = [w for lane_id, w in (left if lane > 0 else right) if abs(lane_id) <= abs(lane)]
        if not widths:
            return 0.0
        center = sum(widths[:-1]) + widths[-1] / 2
        return center if lane > 0 else -center

    def locate(self, x: float, y: float) -> RoadPoint:
        """The road point nearest to (x, y) [m] among roads whose lanes contain it (else the nearest road)."""
        best: tuple[float, RoadPoint] | None = None
        for rid, (length, pieces, left, right) in self.roads.items():
            for g in pieces:
                ds, t, outside = g.project(x, y)
                lane, width = _lane_at(t, left, right)
                miss = outside + max(0.0, abs(t) - width)  # 0 when the point is on this road's lanes
                key = miss * 1e3 + abs(t)
                if best is None or key < best[0]:
                    best = (key, RoadPoint(rid, g.s + ds, t, lane, miss, length))
        if best is None:
            raise ExportError(f"{self.path}: no road outside junctions to place actors on")
        return best[1]


def _lane_at(t: float, left: list[tuple[int, float]], right: list[tuple[int, float]]) -> tuple[int, float]:
    """(lane id at lateral offset t [m], total width of that side [m])."""
    lanes = left if t >= 0 else right
    edge = 0.0
    for lane_id, width in lanes:
        edge += width
        if abs(t) <= edge:
            return lane_id, edge
    if lanes:
        return lanes[-1][0], edge
    return (1 if t >= 0 else -1), 0.0
