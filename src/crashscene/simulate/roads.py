"""Road geometry for the embedded simulator, built from Scenic's parsed OpenDRIVE network.

`RoadMap.load(path)` parses the map once (`scenic.domains.driving.roads.Network.fromFile`)
and keeps, per lane, its centre line in the direction of travel, width, successor,
junction manoeuvres, neighbours and the lateral offset of the road's centre line.
`RoadMap.route(...)` chains lanes into a route polyline, resampled every `ROUTE_DS`
metres, with per-sample lane, junction, centre-line offset and speed limit:
the (s, d) frame in which drivers think (s: station along the route [m],
d: lateral offset, positive to the left [m]). A raster of the drivable area
gives the lane and junction under any point in O(1), vectorised.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from crashscene.geometry import LANE_WIDTH
from crashscene.simulate.backend import SimulationError

ROUTE_DS = 0.5  # [m] spacing of route samples
CHORD_RESOLVED = 2 * ROUTE_DS  # [m] a centre line with vertices this close has its bends read from its samples
# heading (central differences over two samples); a longer chord is a straight piece between two turns
GRID_RES = 0.5  # [m] raster cell size of the lane/junction lookup
STOP_LINE_SETBACK = 1.0  # [m] stop line before the junction entry

MANEUVER_TOKENS = {"STRAIGHT": "straight", "LEFT_TURN": "left", "RIGHT_TURN": "right", "U_TURN": "u_turn"}
MANEUVER_CODES = ("none", "straight", "left", "right", "u_turn")  # = traces.MANEUVERS
MARKERS = ("none", "broken_line", "solid_line", "double_solid_line", "solid_and_broken_line", "not_mentioned")
_MARK_TYPES = {"solid solid": "double_solid_line", "solid": "solid_line", "broken": "broken_line",
               "broken broken": "broken_line", "solid broken": "solid_and_broken_line",
               "broken solid": "solid_and_broken_line", "none": "none", "botts dots": "broken_line"}


@dataclass
class Lane:
    """One lane, its centre line ordered in the direction of travel."""

    index: int
    uid: str
    road: str
    points: np.ndarray  # (N, 2) [m]
    width: float  # [m]
    speed_limit: float  # [m/s], NaN if the map does not say
    successor: str | None
    maneuvers: list[tuple[str, str, str, str]]  # (token, connecting lane, end lane, junction uid)
    junction: str | None  # junction uid for connecting lanes inside a junction
    left: str | None  # same-direction lane to the left
    right: str | None  # same-direction lane to the right
    opposite: str | None  # nearest opposite-direction lane across the centre line
    centerline_offset: float  # [m] from this lane's centre to the road's centre line (left), NaN if one-way
    marker: str  # MARKERS of the road's centre line
    forward: bool = True  # travels along the road's reference line (False: the opposite direction)
    length: float = 0.0

    def __post_init__(self) -> None:
        self.length = float(np.sum(np.hypot(*np.diff(self.points, axis=0).T)))


LOCATE_CHUNK = 16  # segments per disc of `locate_on_line`'s pruning
HEADING_SPAN = 1.0  # [m] `heading_near` reads a lane's direction this far either side of a point (a car's
# wheelbase is ~2.7 m; joints' kinks are a few cm)


def locate_on_line(xy: np.ndarray, x, y, block: int = 512) -> np.ndarray:
    """[m] distance along the polyline `xy` (K, 2) of the point on it nearest to each (x, y): exactly
    `shapely.line_locate_point(LineString(xy), points(x, y))`, the same floats, 5x faster on long routes.

    GEOS (LengthIndexOfPoint) walks every segment for every point; so does this, with GEOS's arithmetic
    (Distance::pointToSegment, LineSegment::projectionFactor, the measure summed segment by segment, the first
    segment of least distance kept), but only over segments that can be nearest: the segments are grouped into
    discs of LOCATE_CHUNK, and a disc whose nearest edge is farther than some vertex of the line is skipped
    (every segment in it is farther than the nearest one). A non-finite point is left to GEOS (which refuses it).
    """
    xy = np.asarray(xy, dtype=float)
    px, py = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    n_seg = len(xy) - 1
    ax, ay, bx, by = xy[:-1, 0], xy[:-1, 1], xy[1:, 0], xy[1:, 1]
    ex, ey = bx - ax, by - ay
    len2 = ex * ex + ey * ey
    seg_len = np.sqrt(len2)
    start = np.zeros(n_seg)  # [m] measure at each segment's start, summed in order as GEOS sums it
    np.cumsum(seg_len[:-1], out=start[1:])
    first_v = np.arange(-(-n_seg // LOCATE_CHUNK)) * LOCATE_CHUNK
    vertices = np.minimum(first_v[:, None] + np.arange(LOCATE_CHUNK + 1), n_seg)  # each disc's vertices
    cx, cy = xy[vertices, 0].mean(axis=1), xy[vertices, 1].mean(axis=1)
    radius = np.sqrt(((xy[vertices, 0] - cx[:, None]) ** 2 + (xy[vertices, 1] - cy[:, None]) ** 2).max(axis=1))
    radius += 1e-9
    out = np.empty(px.shape)
    fx, fy, flat = px.reshape(-1), py.reshape(-1), out.reshape(-1)
    finite = np.isfinite(fx) & np.isfinite(fy)
    if not finite.all():
        odd = np.flatnonzero(~finite)
        flat[odd] = shapely.line_locate_point(shapely.LineString(xy), shapely.points(fx[odd], fy[odd]))
    todo = np.flatnonzero(finite)
    for lo in range(0, len(todo), block):
        rows = todo[lo:lo + block]
        qx, qy = fx[rows, None], fy[rows, None]
        # a vertex's distance is no shorter than the nearest segment's; a disc's edge is no farther than its segments
        near = np.sqrt(((qx - xy[first_v, 0]) ** 2 + (qy - xy[first_v, 1]) ** 2).min(axis=1))
        edge = np.sqrt((qx - cx) ** 2 + (qy - cy) ** 2) - radius
        pi, ci = np.nonzero(edge <= near[:, None] + 1e-6)
        si = (ci[:, None] * LOCATE_CHUNK + np.arange(LOCATE_CHUNK)).reshape(-1)
        pi = np.repeat(pi, LOCATE_CHUNK)
        keep = si < n_seg
        pi, si = pi[keep], si[keep]
        x, y = qx[pi, 0], qy[pi, 0]
        a_x, a_y, b_x, b_y, e_x, e_y, l2 = ax[si], ay[si], bx[si], by[si], ex[si], ey[si], len2[si]
        with np.errstate(invalid="ignore", divide="ignore"):
            r = ((x - a_x) * e_x + (y - a_y) * e_y) / l2
            cross = ((a_y - y) * e_x - (a_x - x) * e_y) / l2
            to_a = np.sqrt((x - a_x) * (x - a_x) + (y - a_y) * (y - a_y))
            to_b = np.sqrt((x - b_x) * (x - b_x) + (y - b_y) * (y - b_y))
            dist = np.where(r <= 0.0, to_a, np.where(r >= 1.0, to_b, np.abs(cross) * np.sqrt(l2)))
            dist = np.where((a_x == b_x) & (a_y == b_y), to_a, dist)
            f = np.where((x == a_x) & (y == a_y), 0.0, np.where((x == b_x) & (y == b_y), 1.0, r))
            measure = np.where(f <= 0.0, start[si], np.where(f <= 1.0, start[si] + f * seg_len[si],
                                                             start[si] + seg_len[si]))
        order = np.lexsort((si, dist, pi))  # per point, least distance first, then the first segment
        by_point = pi[order]
        first = np.ones(len(order), dtype=bool)
        first[1:] = by_point[1:] != by_point[:-1]
        flat[rows[by_point[first]]] = measure[order][first]
    return out


@dataclass
class Junction:
    index: int
    uid: str
    polygon: shapely.Geometry
    signalised: bool
    incoming_roads: list[str]


@dataclass
class JunctionEntry:
    """Where a route enters a junction."""

    s: float  # [m] station of the junction entry (end of the approach lane)
    junction: int  # junction index
    maneuver: str  # MANEUVER token
    approach_road: str  # road uid of the approach lane
    approach_lane: str


@dataclass
class Route:
    """A polyline through the network, sampled every ROUTE_DS metres."""

    key: tuple
    xy: np.ndarray  # (K, 2) [m]
    yaw: np.ndarray  # (K,) [rad]
    curvature: np.ndarray  # (K,) [1/m]
    lane: np.ndarray  # (K,) lane index, -1 on synthetic pieces
    junction: np.ndarray  # (K,) junction index or -1
    centerline_offset: np.ndarray  # (K,) [m], NaN if one-way
    speed_limit: np.ndarray  # (K,) [m/s]
    entries: list[JunctionEntry] = field(default_factory=list)

    @property
    def length(self) -> float:
        return (len(self.xy) - 1) * ROUTE_DS

    def local_coordinates(self, x: np.ndarray, y: np.ndarray, first_lane: bool = False
                          ) -> tuple[np.ndarray, np.ndarray]:
        """(s, d) of world points: station [m] along the route (its nearest point) and signed lateral
        offset [m], left positive. `first_lane` projects onto the route's first lane only (an actor
        starts there, and routes run for hundreds of metres, so a later piece could be nearer)."""
        end = len(self.xy)
        if first_lane:
            first = np.flatnonzero(self.lane != self.lane[0])
            end = int(first[0]) + 2 if len(first) else end
        s = np.minimum(locate_on_line(self.xy[:max(end, 2)], x, y), self.length)
        k = np.minimum((s / ROUTE_DS).astype(np.int64), len(self.xy) - 2)
        u = s / ROUTE_DS - k
        p0, p1 = self.xy[k], self.xy[k + 1]
        foot = p0 + (p1 - p0) * u[..., None]
        tangent = p1 - p0
        norm = np.maximum(np.hypot(tangent[..., 0], tangent[..., 1]), 1e-12)
        d = (tangent[..., 0] * (y - foot[..., 1]) - tangent[..., 1] * (x - foot[..., 0])) / norm
        return s, d


class RoadMap:
    """Lanes, junctions and a lookup raster of one OpenDRIVE map."""

    _cache: dict[tuple[str, float], RoadMap] = {}

    def __init__(self, path: Path, lanes: list[Lane], junctions: list[Junction]):
        self.path = path
        self.lanes = lanes
        self.by_uid = {lane.uid: lane for lane in lanes}
        self.junctions = junctions
        self.junction_by_uid = {j.uid: j for j in junctions}
        self._routes: dict[tuple, Route] = {}
        self._build_grid()

    # ---------------------------------------------------------------- loading
    @classmethod
    def load(cls, path: str | Path) -> RoadMap:
        """Parse (and memoise per path and modification time) an OpenDRIVE map."""
        path = Path(path)
        if not path.exists():
            raise SimulationError(f"{path}: map file not found")
        key = (str(path.resolve()), path.stat().st_mtime)
        if key not in cls._cache:
            from crashscene.cache import pickled

            # parsed once per map content (and code): a later run skips Scenic's import and parse
            road_map = pickled("roadmaps", [path.read_bytes()], lambda: cls._parse(path))
            road_map.path = path
            cls._cache[key] = road_map
        return cls._cache[key]

    @classmethod
    def _parse(cls, path: Path) -> RoadMap:
        from scenic.domains.driving.roads import Network

        try:
            try:  # Scenic's .snet cache beside the map (keyed by the map's hash) saves seconds on big towns
                network = Network.fromFile(str(path))
            except OSError:  # read-only folder: parse without writing the cache
                network = Network.fromFile(str(path), useCache=False, writeCache=False)
        except Exception as exc:  # Scenic raises many types on a bad map
            raise SimulationError(f"{path}: Scenic cannot parse this OpenDRIVE map: {exc}") from exc
        markers = _center_markers(path)
        junction_of_road: dict[str, str] = {}
        junctions: list[Junction] = []
        for k, inter in enumerate(network.intersections):
            for man in inter.maneuvers:
                if man.connectingLane is not None:
                    junction_of_road[man.connectingLane.road.uid] = inter.uid
            incoming = sorted({lane.road.uid for lane in inter.incomingLanes})
            junctions.append(Junction(k, inter.uid, inter.polygon, bool(inter.signals), incoming))
        lanes: list[Lane] = []
        for k, lane in enumerate(network.lanes):
            pts = np.asarray(lane.centerline.points, dtype=float)[:, :2]
            pts = _dedupe(pts)
            poly_area = float(lane.polygon.area)
            length = float(np.sum(np.hypot(*np.diff(pts, axis=0).T))) if len(pts) > 1 else 0.0
            width = poly_area / length if length > 0 else LANE_WIDTH
            succ = lane._successor.uid if lane._successor is not None else None
            mans = [(MANEUVER_TOKENS.get(m.type.name, "straight"), m.connectingLane.uid, m.endLane.uid,
                     m.intersection.uid) for m in lane.maneuvers if m.connectingLane is not None]
            sec = lane.sections[len(lane.sections) // 2]
            left = _same_direction(sec, sec._laneToLeft)
            right = _same_direction(sec, sec._laneToRight)
            opposite, offset = _opposite(lane, pts)
            speed = float(lane.speedLimit) if lane.speedLimit else math.nan
            road_id = lane.road.uid
            lanes.append(Lane(k, lane.uid, road_id, pts, min(max(width, 2.0), 6.0), speed, succ, mans,
                              junction_of_road.get(road_id), left, right, opposite, offset,
                              markers.get(road_id, "not_mentioned"), bool(sec.isForward)))
        return cls(path, lanes, junctions)

    # ---------------------------------------------------------------- lookup raster
    def _build_grid(self) -> None:
        all_pts = np.concatenate([lane.points for lane in self.lanes])
        pad = 10.0
        self.origin = all_pts.min(axis=0) - pad
        extent = all_pts.max(axis=0) + pad - self.origin
        self.shape = (int(extent[0] / GRID_RES) + 1, int(extent[1] / GRID_RES) + 1)
        lane_grid = np.full(self.shape, -1, dtype=np.int32)
        junction_grid = np.full(self.shape, -1, dtype=np.int16)
        # connecting lanes first, so that ordinary lanes win where they overlap a junction's edge
        order = sorted(self.lanes, key=lambda lane: lane.junction is None)
        for lane in order:
            poly = _lane_polygon(lane)
            self._paint(lane_grid, poly, lane.index)
        for j in self.junctions:
            self._paint(junction_grid, j.polygon, j.index)
        self.lane_grid = lane_grid
        self.junction_grid = junction_grid

    def _paint(self, grid: np.ndarray, poly: shapely.Geometry, value: int) -> None:
        x0, y0, x1, y1 = poly.bounds
        i0, j0 = self._cell(np.array([x0, y0]))
        i1, j1 = self._cell(np.array([x1, y1]))
        i0, j0 = max(i0, 0), max(j0, 0)
        i1, j1 = min(i1 + 1, self.shape[0] - 1), min(j1 + 1, self.shape[1] - 1)
        ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
        cx = self.origin[0] + (ii + 0.5) * GRID_RES
        cy = self.origin[1] + (jj + 0.5) * GRID_RES
        inside = shapely.contains_xy(poly, cx, cy)
        grid[ii[inside], jj[inside]] = value

    def _cell(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ij = np.floor((xy - self.origin) / GRID_RES).astype(np.int64)
        return ij[..., 0], ij[..., 1]

    def lookup(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lane index (-1 off-road) and junction index (-1 outside junctions) under each point."""
        # per axis, as _cell computes it (no (N, 2) stack of the points)
        i = np.floor((np.asarray(x) - self.origin[0]) / GRID_RES).astype(np.int64)
        j = np.floor((np.asarray(y) - self.origin[1]) / GRID_RES).astype(np.int64)
        ok = (i >= 0) & (j >= 0) & (i < self.shape[0]) & (j < self.shape[1])
        flat = np.where(ok, i * self.shape[1] + j, 0)
        lane = np.where(ok, self.lane_grid.ravel()[flat], -1)
        junction = np.where(ok, self.junction_grid.ravel()[flat], -1)
        return lane, junction

    def side_lanes(self, lane: Lane, side: str) -> list[Lane]:
        """The same-direction lanes on `side` ("left" or "right") of `lane`, nearest first (its neighbours' chain,
        Lane.left / Lane.right, to the first lane the map does not hold or one already passed)."""
        out, seen, uid = [], {lane.uid}, getattr(lane, side)
        while uid and uid in self.by_uid and uid not in seen:
            seen.add(uid)
            out.append(self.by_uid[uid])
            uid = getattr(out[-1], side)
        return out

    def lane_at(self, x: float, y: float, yaw: float | None = None) -> Lane | None:
        """The lane under a point; with `yaw`, prefer a lane whose direction matches it."""
        lane_idx, _ = self.lookup(np.array([x]), np.array([y]))
        candidates = [self.lanes[int(lane_idx[0])]] if lane_idx[0] >= 0 else []
        point = shapely.Point(x, y)
        if yaw is not None or not candidates:
            near = [lane for lane in self.lanes if _lane_polygon(lane).distance(point) < 0.5]
            candidates = near or candidates
        if not candidates:
            return None
        if yaw is None:
            return candidates[0]
        return max(candidates, key=lambda lane: math.cos(heading_near(lane, x, y) - yaw)
                   - 0.05 * _lateral_distance(lane, x, y))

    # ---------------------------------------------------------------- routes
    def route(self, lane_uid: str, intent: str = "straight", min_length: float = 400.0) -> Route:
        """The route from the start of lane `lane_uid`, taking `intent` at its first junction.

        Later junctions go straight when they can. The route stops where the map ends.
        `intent` "u_turn" uses a U-turn manoeuvre when the map has one, else a
        synthetic half circle into the opposite lane.
        """
        key = (lane_uid, intent, round(min_length))
        if key in self._routes:
            return self._routes[key]
        if lane_uid not in self.by_uid:
            raise SimulationError(f"{self.path}: no lane {lane_uid!r} in the map")
        pieces: list[tuple[np.ndarray, int]] = []
        entries: list[JunctionEntry] = []
        lane = self.by_uid[lane_uid]
        length = 0.0
        first_junction = True
        seen = set()
        while lane is not None and length < min_length and lane.uid not in seen:
            seen.add(lane.uid)
            pieces.append((lane.points, lane.index))
            length += lane.length
            nxt = None
            if lane.maneuvers and lane.junction is None:
                want = intent if first_junction else "straight"
                choice = _choose_maneuver(lane.maneuvers, want)
                if choice is not None:
                    token, connecting, end, junction_uid = choice
                    entries.append(JunctionEntry(length, self.junction_by_uid[junction_uid].index, token,
                                                 lane.road, lane.uid))
                    conn = self.by_uid[connecting]
                    pieces.append((conn.points, conn.index))
                    length += conn.length
                    seen.add(conn.uid)
                    nxt = self.by_uid.get(end)
                first_junction = False
            elif intent == "u_turn" and first_junction and lane.opposite is not None:
                pieces.append((_half_circle(lane, self.by_uid[lane.opposite]), -1))
                length += math.pi * abs(lane.centerline_offset)
                first_junction = False
                opp = self.by_uid[lane.opposite]
                pieces.append((_from_point(opp, pieces[-1][0][-1]), opp.index))
                length += opp.length
                nxt = self.by_uid.get(opp.successor) if opp.successor else None
                if nxt is None:
                    nxt = self._straight_next(opp)
                seen.add(opp.uid)
                lane = nxt
                continue
            else:
                nxt = self.by_uid.get(lane.successor) if lane.successor else None
            lane = nxt
        route = self._assemble(key, pieces, entries)
        self._routes[key] = route
        return route

    def _straight_next(self, lane: Lane) -> Lane | None:
        if lane.maneuvers:
            choice = _choose_maneuver(lane.maneuvers, "straight")
            return self.by_uid.get(choice[1]) if choice else None
        return None

    def _assemble(self, key: tuple, pieces: list[tuple[np.ndarray, int]], entries: list[JunctionEntry]) -> Route:
        pts: list[np.ndarray] = []
        owner: list[np.ndarray] = []
        for arr, idx in pieces:
            if pts and np.hypot(*(arr[0] - pts[-1][-1])) < 0.05:
                arr = arr[1:]
            if len(arr) == 0:
                continue
            pts.append(arr)
            owner.append(np.full(len(arr), idx))
        xy = np.concatenate(pts)
        own = np.concatenate(owner)
        keep = np.concatenate([[True], np.hypot(*np.diff(xy, axis=0).T) > 1e-6])
        xy, own = xy[keep], own[keep]
        cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        # junction entries were measured on raw lane lengths; re-measure on the stitched polyline
        raw_len = 0.0
        lane_starts = {}
        for arr, idx in pieces:
            lane_starts.setdefault(idx, raw_len)
            raw_len += float(np.sum(np.hypot(*np.diff(arr, axis=0).T)))
        scale = cum[-1] / raw_len if raw_len > 0 else 1.0
        for entry in entries:
            entry.s *= scale
        s = np.arange(0.0, cum[-1] + 1e-9, ROUTE_DS)
        rx = np.interp(s, cum, xy[:, 0])
        ry = np.interp(s, cum, xy[:, 1])
        # a segment belongs to the piece of its end point (each piece's first point was dropped when shared)
        seg_idx = np.clip(np.searchsorted(cum, s, side="right"), 1, len(own) - 1)
        lane_idx = own[seg_idx]
        rxy = np.stack([rx, ry], axis=1)
        yaw = _smooth_yaw(rxy)
        curv = np.gradient(np.unwrap(yaw), ROUTE_DS) if len(yaw) > 2 else np.zeros_like(yaw)
        chords = _chords(cum)[seg_idx - 1]
        if chords.any():
            curv = np.where(chords, _polyline_curvature(xy, cum, s), curv)
        junction = np.array([self.junction_by_uid[self.lanes[i].junction].index
                             if i >= 0 and self.lanes[i].junction else -1 for i in lane_idx], dtype=np.int32)
        offset = np.array([self.lanes[i].centerline_offset if i >= 0 else math.nan for i in lane_idx])
        speed = np.array([self.lanes[i].speed_limit if i >= 0 else math.nan for i in lane_idx])
        return Route(key, rxy, yaw, curv, lane_idx.astype(np.int32), junction, offset, speed, entries)


# -------------------------------------------------------------------- helpers
def _same_direction(section, neighbour) -> str | None:
    """The neighbour's lane uid when it runs in the same direction (Scenic's laneToLeft may be oncoming)."""
    if neighbour is None or neighbour.isForward != section.isForward:
        return None
    return neighbour.lane.uid


def _dedupe(pts: np.ndarray) -> np.ndarray:
    keep = np.concatenate([[True], np.hypot(*np.diff(pts, axis=0).T) > 1e-6])
    return pts[keep]


def _centre_line(lane: Lane) -> tuple[shapely.LineString, np.ndarray]:
    """The lane's centre line as a shapely line and the distance along it of each of its points [m] (cached)."""
    cached = getattr(lane, "_line", None)
    if cached is None:
        along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(lane.points, axis=0).T))])
        cached = (shapely.LineString(lane.points), along)
        object.__setattr__(lane, "_line", cached)
    return cached


def _lane_polygon(lane: Lane) -> shapely.Geometry:
    cached = getattr(lane, "_poly", None)
    if cached is None:
        cached = shapely.LineString(lane.points).buffer(lane.width / 2, cap_style="flat")
        object.__setattr__(lane, "_poly", cached)
    return cached


def heading_near(lane: Lane, x: float, y: float) -> float:
    """[rad] direction of travel of `lane` at the point of its centre line nearest to (x, y), read from
    HEADING_SPAN behind that point to HEADING_SPAN ahead of it: Scenic's centre lines carry tiny backward kinks (a
    few cm) at geometry joints, and the one segment nearest such a joint points backwards."""
    pts = lane.points
    line, along = _centre_line(lane)
    s = float(shapely.line_locate_point(line, shapely.Point(x, y)))  # locate_on_line's floats, for one point
    a, b = max(s - HEADING_SPAN, 0.0), min(s + HEADING_SPAN, along[-1])
    if b <= a:
        return math.atan2(pts[-1, 1] - pts[0, 1], pts[-1, 0] - pts[0, 0])
    ax_, ay_, bx_, by_ = (np.interp(a, along, pts[:, 0]), np.interp(a, along, pts[:, 1]),
                          np.interp(b, along, pts[:, 0]), np.interp(b, along, pts[:, 1]))
    return math.atan2(by_ - ay_, bx_ - ax_)


def _lateral_distance(lane: Lane, x: float, y: float) -> float:
    return float(shapely.LineString(lane.points).distance(shapely.Point(x, y)))


CENTRE_LINE_TOLERANCE = 0.05  # [m] a group's left edge is the centre line when it lies on the way from a lane to its
# nearest opposite lane and along that lane's edge, within this (a few cm: the polylines' sampling)


def _opposite(lane, pts: np.ndarray) -> tuple[str | None, float]:
    """The nearest opposite-direction lane and the offset [m] to the centre line between them: the lane group's left
    edge when it lies between the two along that lane's edge, else the opposite group's (Scenic 3.1 builds a backward
    group's edges from its lanes in the wrong order: with three lanes or more its left edge runs through the group,
    not along the centre line), else half the opposite lane's width short of its centre."""
    group = lane.group
    if group is None or group._opposite is None:
        return None, math.nan
    opp_lanes = group._opposite.lanes
    if not opp_lanes:
        return None, math.nan
    mid = shapely.Point(*pts[len(pts) // 2])
    lines = {other.uid: shapely.LineString(np.asarray(other.centerline.points)[:, :2]) for other in opp_lanes}
    nearest = min(opp_lanes, key=lambda other: lines[other.uid].distance(mid))
    across = float(lines[nearest.uid].distance(mid))  # [m] to the nearest opposite lane's centre
    half = float(nearest.polygon.area / lines[nearest.uid].length) / 2.0  # [m] half its width
    for group_edge in (group.leftEdge, group._opposite.leftEdge):
        edge = shapely.LineString(np.asarray(group_edge.points)[:, :2])
        offset = float(edge.distance(mid))
        beyond = float(lines[nearest.uid].distance(edge.interpolate(edge.project(mid))))
        if abs(offset + beyond - across) < CENTRE_LINE_TOLERANCE and abs(beyond - half) < CENTRE_LINE_TOLERANCE:
            return nearest.uid, offset
    return nearest.uid, across - half


_FALLBACK = {"u_turn": ("u_turn", "left", "straight", "right"), "left": ("left", "straight", "right"),
             "right": ("right", "straight", "left")}


def _choose_maneuver(maneuvers: list[tuple[str, str, str, str]], want: str) -> tuple[str, str, str, str] | None:
    """The manoeuvre matching `want`, else the closest one the junction offers."""
    for pref in _FALLBACK.get(want, ("straight", "right", "left", "u_turn")):
        for m in maneuvers:
            if m[0] == pref:
                return m
    return None


def _half_circle(lane: Lane, opposite: Lane) -> np.ndarray:
    """A U-turn arc from the end of `lane` into `opposite` (synthetic, for roads without a U-turn manoeuvre)."""
    end = lane.points[-1]
    yaw = math.atan2(*(lane.points[-1] - lane.points[-2])[::-1])
    dist = float(shapely.LineString(opposite.points).distance(shapely.Point(*end)))
    radius = max(dist / 2, 2.0)
    centre = end + radius * np.array([-math.sin(yaw), math.cos(yaw)])
    angles = yaw - math.pi / 2 + np.linspace(0, math.pi, 24)
    return centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def _from_point(lane: Lane, point: np.ndarray) -> np.ndarray:
    """The part of `lane` downstream of its point nearest to `point`."""
    d = np.hypot(lane.points[:, 0] - point[0], lane.points[:, 1] - point[1])
    k = int(np.argmin(d))
    return lane.points[k:] if k < len(lane.points) - 1 else lane.points[-2:]


def _smooth_yaw(xy: np.ndarray) -> np.ndarray:
    if len(xy) < 2:
        return np.zeros(len(xy))
    fwd = np.empty_like(xy)
    fwd[1:-1] = xy[2:] - xy[:-2]
    fwd[0] = xy[1] - xy[0]
    fwd[-1] = xy[-1] - xy[-2]
    return np.arctan2(fwd[:, 1], fwd[:, 0])


def _chords(cum: np.ndarray) -> np.ndarray:
    """Which segments of a polyline whose vertices lie at stations cum (N,) are chords longer than the samples
    that read its heading resolve (CHORD_RESOLVED), or a short step between two such chords (a joint of two
    geometries): (N - 1,) bool."""
    long = np.diff(cum) > CHORD_RESOLVED
    between = np.zeros_like(long)
    between[1:-1] = long[:-2] & long[2:]
    return long | between


def _polyline_curvature(xy: np.ndarray, cum: np.ndarray, s: np.ndarray) -> np.ndarray:
    """[1/m] signed curvature (left positive) at stations s of the polyline xy (N, 2), whose vertices lie at
    stations cum: at each inner vertex that of the circle through it and its two neighbours (2 sin(turn) over
    the chord between the neighbours, 1/R at every vertex of a polyline inscribed in a circle of radius R,
    however far apart its vertices are), linear between vertices, 0 at the ends. Scenic's centre lines of
    long bends are chords of their arcs (a 400 m radius in 28 m chords, each vertex turning 0.07 rad), and the
    heading read off samples every ROUTE_DS holds still along a chord and jumps at a vertex: its derivative
    read 0 along a chord and 30 times the bend's curvature at its vertices. A vertex where the line steps back
    a few cm (a joint between a straight and an arc) turns by almost half a turn and adds no curvature."""
    if len(xy) < 3:
        return np.zeros(len(s))
    step = np.diff(xy, axis=0)
    heading = np.arctan2(step[:, 1], step[:, 0])
    turn = np.remainder(np.diff(heading) + math.pi, math.tau) - math.pi
    chord = np.hypot(*(xy[2:] - xy[:-2]).T)
    inner = 2.0 * np.sin(turn) / np.maximum(chord, 1e-9)
    return np.interp(s, cum, np.concatenate([[0.0], inner, [0.0]]))


def _center_markers(path: Path) -> dict[str, str]:
    """Road uid -> centre-line marker token, read from the OpenDRIVE file (Scenic drops road marks)."""
    markers: dict[str, str] = {}
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise SimulationError(f"{path}: not valid XML: {exc}") from exc
    for road in root.iter("road"):
        mark = road.find("./lanes/laneSection/center/lane/roadMark")
        if mark is not None:
            token = _MARK_TYPES.get((mark.get("type") or "").strip().lower(), "not_mentioned")
            markers[f"road{road.get('id')}"] = token
    return markers
