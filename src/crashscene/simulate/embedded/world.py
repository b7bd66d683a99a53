"""The static world of one batch: every actor's route packed into arrays, and route-pair conflicts.

Routes are deduplicated (most variations of a scenario start on the same lanes
with the same intent), padded into (R, K) arrays, and each (variation, actor)
points at one route by index, so that any per-step geometric query is a numpy
gather over (V, A).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from crashscene.geometry import wrap_angle
from crashscene.simulate.roads import MANEUVER_CODES, ROUTE_DS, Route

CONTROL_CODES = {"none": 0, "signal": 1, "stop": 2, "yield": 3}
LOOKAHEAD_FRACTIONS = np.linspace(0.0, 1.0, 12)  # [-] where curve_lookahead samples the road ahead (every step)


@dataclass
class RouteArrays:
    """R routes padded to K samples; samples past a route's end repeat its last sample."""

    routes: list[Route]
    xy: np.ndarray  # (R, K, 2)
    yaw: np.ndarray  # (R, K)
    curvature: np.ndarray  # (R, K)
    lane: np.ndarray  # (R, K)
    junction: np.ndarray  # (R, K)
    centerline_offset: np.ndarray  # (R, K)
    speed_limit: np.ndarray  # (R, K)
    length: np.ndarray  # (R,) [m]
    entry_s: np.ndarray  # (R, J) [m] junction entries along the route, inf padded
    entry_junction: np.ndarray  # (R, J) junction index, -1 padded
    entry_maneuver: np.ndarray  # (R, J) MANEUVER code
    entry_exit: np.ndarray  # (R, J) [m] station where the route leaves that junction, inf padded
    entry_road: list[list[str]]  # approach road uid per entry
    conflict_s: np.ndarray  # (R, R) [m] station on route i where it first meets route j, NaN if never
    conflict_angle: np.ndarray  # (R, R) [rad] heading of j minus heading of i at that point

    @classmethod
    def pack(cls, routes: list[Route]) -> RouteArrays:
        k_max = max(len(r.xy) for r in routes)
        n = len(routes)

        def pad(values: list[np.ndarray], dtype) -> np.ndarray:
            out = np.empty((n, k_max) + values[0].shape[1:], dtype=dtype)
            for i, v in enumerate(values):
                out[i, : len(v)] = v
                out[i, len(v):] = v[-1]
            return out

        j_max = max(1, max(len(r.entries) for r in routes))
        entry_s = np.full((n, j_max), np.inf)
        entry_j = np.full((n, j_max), -1, dtype=np.int32)
        entry_m = np.zeros((n, j_max), dtype=np.int8)
        entry_x = np.full((n, j_max), np.inf)
        entry_road: list[list[str]] = []
        for i, r in enumerate(routes):
            entry_road.append([e.approach_road for e in r.entries])
            for j, e in enumerate(r.entries):
                entry_s[i, j] = e.s
                entry_j[i, j] = e.junction
                entry_m[i, j] = MANEUVER_CODES.index(e.maneuver)
                k = int(e.s / ROUTE_DS) + 1
                outside = np.flatnonzero(r.junction[k:] < 0)
                inside = np.flatnonzero(r.junction[k:] >= 0)
                start = inside[0] if len(inside) else 0
                after = outside[outside > start]
                entry_x[i, j] = (k + after[0]) * ROUTE_DS if len(after) else r.length
        conflict_s, conflict_angle = _conflicts(routes)
        return cls(routes, pad([r.xy for r in routes], float), pad([r.yaw for r in routes], float),
                   pad([r.curvature for r in routes], float), pad([r.lane for r in routes], np.int32),
                   pad([r.junction for r in routes], np.int32), pad([r.centerline_offset for r in routes], float),
                   pad([r.speed_limit for r in routes], float), np.array([r.length for r in routes]),
                   entry_s, entry_j, entry_m, entry_x, entry_road, conflict_s, conflict_angle)

    # ------------------------------------------------------------------ gathers
    def index(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sample index and interpolation fraction for stations s (any shape)."""
        f = np.clip(s / ROUTE_DS, 0.0, self.xy.shape[1] - 1.000001)
        k = f.astype(np.int64)
        return k, f - k

    @cached_property
    def _flat_samples(self) -> tuple[np.ndarray, ...]:
        """(x, dx, y, dy, yaw) of the centre line flat, row after row (route r's sample k at r * K + k), dx and dy
        the step to the next sample (`point` interpolates x + dx u: the same floats as x + (x_next - x) u)."""
        x, y, yaw = (np.ascontiguousarray(q).ravel() for q in (self.xy[..., 0], self.xy[..., 1], self.yaw))
        dx, dy = np.zeros_like(x), np.zeros_like(y)
        dx[:-1], dy[:-1] = x[1:] - x[:-1], y[1:] - y[:-1]  # (a row's last step is never read: k <= K - 2)
        return x, dx, y, dy, yaw

    def _flat_index(self, r: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(flat sample index, interpolation fraction) of stations s [m] on routes r (broadcast together)."""
        n_k = self.xy.shape[1]
        f = np.minimum(np.maximum(s * (1.0 / ROUTE_DS), 0.0), n_k - 1.000001)  # np.clip's floats, less overhead
        k = f.astype(np.int64)
        return np.asarray(r) * n_k + k, f - k

    def point(self, r: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, yaw) of the route centre line at station s; r and s broadcast together."""
        x, dx, y, dy, yaw = self._flat_samples
        flat, u = self._flat_index(r, s)
        return x[flat] + dx[flat] * u, y[flat] + dy[flat] * u, yaw[flat]

    def yaw_at(self, r: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The route's heading [rad] at station s (`point`'s yaw alone)."""
        return self._flat_samples[4][self._flat_index(r, s)[0]]

    def local_coordinates(self, r: np.ndarray, x: np.ndarray, y: np.ndarray, s: np.ndarray,
                          iterations: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, d, yaw): station [m], lateral offset [m] (left > 0) and route heading [rad] of the world
        point (x, y) on route r; the inverse of `point` (`point(r, s)` offset by d across it is (x, y)).

        Local: starting from a station guess `s` near the answer (the last station, moved by the
        distance travelled), each iteration corrects it along the route's tangent; the station is then
        clipped to the route and d measured across it.
        """
        for _ in range(iterations):
            qx, qy, qyaw = self.point(r, s)
            s = s + (x - qx) * np.cos(qyaw) + (y - qy) * np.sin(qyaw)
        s = np.minimum(np.maximum(s, 0.0), self.length[r])  # np.clip's floats
        qx, qy, qyaw = self.point(r, s)
        return s, -(x - qx) * np.sin(qyaw) + (y - qy) * np.cos(qyaw), qyaw

    def sample(self, table: np.ndarray, r: np.ndarray, s: np.ndarray) -> np.ndarray:
        k, _ = self.index(s)
        return table[r, k]

    def travel_time(self, r: int, s0: float, s1: float, speed: float, lat_accel: float, v0: float | None = None,
                    accel: float = 2.5, decel: float = 2.0) -> float:
        """Nominal time [s] from s0 to s1 on route r cruising at `speed` [m/s]: slows to sqrt(lat_accel/curvature)
        in curves, braking at `decel` before them and accelerating at `accel` after (and from `v0` at s0)."""
        if s1 <= s0:
            return 0.0
        k0, k1 = int(s0 / ROUTE_DS), min(math.ceil(s1 / ROUTE_DS), self.curvature.shape[1] - 1)
        if k1 <= k0:
            return (s1 - s0) / max(speed, 0.5)
        speed = max(speed, 0.5)
        if (v0 is None or v0 >= speed - 1e-9) and speed ** 2 * self._abs_curvature_max(r, k0, k1) <= lat_accel:
            return (s1 - s0) / speed  # no curve to slow down for, already at speed
        step = 4  # every 2 m is enough for a speed profile
        kappa = self._abs_curvature_levels[0][r, k0:k1 + 1]
        if len(kappa) > step:
            pad = (-len(kappa)) % step
            kappa = np.concatenate([kappa, np.full(pad, kappa[-1])]).reshape(-1, step).max(axis=1)
            ds = ROUTE_DS * step
        else:
            ds = ROUTE_DS
        v_lim2 = np.minimum(max(speed, 0.5) ** 2, lat_accel / np.maximum(kappa, 1e-4))
        dist = np.arange(len(kappa)) * ds
        if accel >= 0 and decel >= 0 and bool((v_lim2 == speed ** 2).all()):
            v2 = v_lim2  # no limit below the cruise speed: the profile below is that speed throughout
        else:
            gap = dist[None, :] - dist[:, None]  # s_j - s_i
            # brake ahead of every later limit, and accelerate out of every earlier one (and from v0)
            ahead = np.where(gap >= 0, v_lim2[None, :] + 2 * decel * gap, np.inf).min(axis=1)
            behind = np.where(gap <= 0, ahead[None, :] - 2 * accel * gap, np.inf).min(axis=1)
            v2 = np.minimum(ahead, behind)
        if v0 is not None:
            v2 = np.minimum(v2, max(v0, 0.0) ** 2 + 2 * accel * dist)
        v = np.maximum(np.sqrt(v2), 1.0)
        if len(v) < 2:
            return (s1 - s0) / float(v[0])
        return float(np.sum(ds / (0.5 * (v[1:] + v[:-1])))) * (s1 - s0) / (dist[-1] if dist[-1] > 0 else 1.0)

    @cached_property
    def _abs_curvature(self) -> np.ndarray:
        """|curvature| [1/m] (R, K)."""
        return np.abs(self.curvature)

    @cached_property
    def _flat_abs_curvature(self) -> np.ndarray:
        """|curvature| [1/m] flat, row after row (route r's sample k at r * K + k: `curve_lookahead`'s gather)."""
        return np.ascontiguousarray(self._abs_curvature).ravel()

    @cached_property
    def _abs_curvature_levels(self) -> list[np.ndarray]:
        """|curvature| (R, K) and its sparse table: level j holds the largest value of samples [k, k + 2^j)."""
        levels = [self._abs_curvature]
        while 2 ** len(levels) <= levels[0].shape[1]:
            half = 2 ** (len(levels) - 1)
            levels.append(np.maximum(levels[-1][:, :-half], levels[-1][:, half:]))
        return levels

    def _abs_curvature_max(self, r: int, k0: int, k1: int) -> float:
        """Largest |curvature| [1/m] of samples k0..k1 of route r: two lookups in the sparse table."""
        j = (k1 - k0 + 1).bit_length() - 1
        row = self._abs_curvature_levels[j][r]
        return float(np.maximum(row[k0], row[k1 + 1 - 2 ** j]))

    def curve_speed(self, r: np.ndarray, s: np.ndarray, ahead: np.ndarray, lat_accel: float, decel: float,
                    n: int = 12) -> np.ndarray:
        """Highest speed [m/s] from which the curves within `ahead` [m] can be taken at `lat_accel` [m/s2],
        braking at `decel` [m/s2] before each: min over samples of sqrt(v_curve^2 + 2 decel distance)."""
        dist = ahead[..., None] * np.linspace(0.0, 1.0, n)
        k, _ = self.index(s[..., None] + dist)
        kappa = np.abs(self.curvature[r[..., None], k])
        v_curve2 = lat_accel / np.maximum(kappa, 1e-4)
        return np.sqrt(np.min(v_curve2 + 2.0 * decel * dist, axis=-1))

    @cached_property
    def _curved(self) -> bool:
        """Whether any route of the batch curves (curve_lookahead's answer is a constant on straight roads)."""
        return bool(self._flat_abs_curvature.any())

    @cached_property
    def _flat_curve_speed2(self) -> np.ndarray:
        """[m2/s2] the squared speed each sample's curve allows at 2.5 m/s2 lateral, flat as `_flat_abs_curvature`."""
        return 2.5 / np.maximum(self._flat_abs_curvature, 1e-4)

    def curve_lookahead(self, r: np.ndarray, s: np.ndarray, v: np.ndarray, n: int = 12
                        ) -> tuple[np.ndarray, np.ndarray]:
        """(largest |curvature| [1/m] on the next max(20 m, 3 s), curve speed [m/s] as `curve_speed` with
        2.5 m/s2 lateral and 2 m/s2 braking over that distance plus the braking distance), one gather."""
        r, s, v = np.asarray(r), np.asarray(s), np.asarray(v)
        if not self._curved:  # every sample straight: no curvature, and the speed of the nearest sample (dist 0)
            shape = np.broadcast(r, s, v).shape
            return np.zeros(shape)[()], np.full(shape, np.sqrt(self._flat_curve_speed2[0] + 4.0 * 0.0))[()]
        near = np.maximum(20.0, 3.0 * v)
        reach = near + v * v / 4.0
        fractions = LOOKAHEAD_FRACTIONS if n == len(LOOKAHEAD_FRACTIONS) else np.linspace(0.0, 1.0, n)
        # the samples along the first axis: the reductions over them are elementwise over contiguous rows
        dist = fractions.reshape((-1,) + (1,) * reach.ndim) * reach
        f = np.minimum(np.maximum((s + dist) * (1.0 / ROUTE_DS), 0.0), self.curvature.shape[1] - 1)
        flat = r * self.curvature.shape[1] + f.astype(np.int64)
        curvature = np.where(dist <= near, self._flat_abs_curvature[flat], 0.0).max(axis=0)
        speed = np.sqrt((self._flat_curve_speed2[flat] + 4.0 * dist).min(axis=0))
        return curvature, speed

    def max_abs_curvature(self, r: np.ndarray, s: np.ndarray, ahead: np.ndarray, n: int = 8) -> np.ndarray:
        """Largest |curvature| [1/m] on [s, s + ahead], sampled at n points."""
        frac = np.linspace(0.0, 1.0, n)
        ss = s[..., None] + ahead[..., None] * frac
        k, _ = self.index(ss)
        return np.abs(self.curvature[r[..., None], k]).max(axis=-1)


MERGE_TOLERANCE = 0.5  # [m] two routes closer than this share a lane: a vehicle on one is in the way of the other


def _conflicts(routes: list[Route]) -> tuple[np.ndarray, np.ndarray]:
    """First meeting point of every ordered pair of routes (stations on the first route)."""
    n = len(routes)
    conflict_s = np.full((n, n), np.nan)
    angle = np.full((n, n), np.nan)
    lines = [shapely.LineString(r.xy) for r in routes]
    shapely.prepare(lines)  # indexed: dwithin below is ~100x faster than a full distance on long routes
    points: list = [None] * n
    for i in range(n):
        for j in range(n):
            if i == j or routes[i].key[0] == routes[j].key[0]:
                continue  # the same start lane: following, not crossing
            meet = lines[i].intersection(lines[j])
            if meet.is_empty:
                if not shapely.dwithin(lines[i], lines[j], MERGE_TOLERANCE):  # distance <= MERGE_TOLERANCE
                    continue
                # merging paths (a turn into a lane, a lane drop) join without crossing: the first point of
                # route i that comes within MERGE_TOLERANCE of route j is their meeting point
                if points[i] is None:
                    points[i] = shapely.points(routes[i].xy)
                near = np.flatnonzero(shapely.distance(points[i], lines[j]) < MERGE_TOLERANCE)
                if not len(near):
                    continue
                meet = points[i][near[0]]
            pts = shapely.get_coordinates(meet)
            s_i = np.array([lines[i].project(shapely.Point(p)) for p in pts])
            k = int(np.argmin(s_i))
            s_j = lines[j].project(shapely.Point(pts[k]))
            conflict_s[i, j] = s_i[k]
            yi = routes[i].yaw[min(int(s_i[k] / ROUTE_DS), len(routes[i].yaw) - 1)]
            yj = routes[j].yaw[min(int(s_j / ROUTE_DS), len(routes[j].yaw) - 1)]
            angle[i, j] = wrap_angle(yj - yi)
    return conflict_s, angle


def conflict_pair_s(arrays: RouteArrays, ra: np.ndarray, rb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stations of the meeting point on a's route and on b's route, NaN where they never meet."""
    return arrays.conflict_s[ra, rb], arrays.conflict_s[rb, ra]
