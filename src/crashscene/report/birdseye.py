"""Bird's-eye views of a simulated variation on its map: a still at a given time and an animated GIF.

Lanes come from the scenario's OpenDRIVE map through Scenic's parser
(`Network.fromFile`); actors are drawn as oriented rectangles from the trace
columns of `crashscene.traces` (x, y, yaw [rad], length, width [m]).
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Polygon as PolygonPatch  # noqa: E402
from PIL import Image  # noqa: E402

from crashscene.geometry import footprint_corners  # noqa: E402

ROLE_COLORS = ("#1f77b4", "#d62728", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b")  # ego, npc1, npc2, ...
ASPHALT, LANE_LINE, CENTER_LINE = "#4d4d4d", "#f2f2f2", "#f2c200"
VIEW_MARGIN = 12.0  # [m] around the actors' paths
MIN_VIEW = 40.0  # [m] smallest side of the view
MAX_ASPECT = 2.5  # longest side / shortest side of the view
GIF_FRAME_DT = 0.2  # [s] of simulated time per GIF frame
GIF_MAX_FRAMES = 60


@dataclass
class ActorTrack:
    """One actor's trace in one variation."""

    role: str
    t: np.ndarray  # [s]
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    length: float  # [m]
    width: float  # [m]

    def at(self, time: float) -> tuple[float, float, float]:
        """Pose at `time` [s] (the last sample at or before it)."""
        k = int(np.clip(np.searchsorted(self.t, time, side="right") - 1, 0, len(self.t) - 1))
        return float(self.x[k]), float(self.y[k]), float(self.yaw[k])


@dataclass
class MapGeometry:
    drivable: list[np.ndarray]  # exterior rings [m]
    holes: list[np.ndarray]
    lane_edges: list[np.ndarray]
    center_lines: list[np.ndarray]


@lru_cache(maxsize=8)
def load_map(path: str) -> MapGeometry:
    """Drivable area, lane edges and centre lines of an OpenDRIVE file (parsed by Scenic)."""
    from scenic.domains.driving.roads import Network

    network = Network.fromFile(path)
    polys = network.drivableRegion.polygons
    polys = list(getattr(polys, "geoms", [polys]))
    drivable = [np.asarray(p.exterior.coords)[:, :2] for p in polys]
    holes = [np.asarray(r.coords)[:, :2] for p in polys for r in p.interiors]
    edges = []
    for lane in network.lanes:
        for edge in (lane.leftEdge, lane.rightEdge):
            edges.append(np.asarray(edge.points, dtype=float)[:, :2])
    centers = []
    for road in network.roads:
        if road.forwardLanes is not None and road.backwardLanes is not None:
            centers.append(np.asarray(road.forwardLanes.leftEdge.points, dtype=float)[:, :2])
    return MapGeometry(drivable, holes, edges, centers)


def _view(tracks: list[ActorTrack], t0: float, t1: float) -> tuple[float, float, float, float]:
    """Centre and half-extents [m] of a view holding every actor between t0 and t1 (aspect at most MAX_ASPECT)."""
    xs, ys = [], []
    for tr in tracks:
        mask = (tr.t >= t0) & (tr.t <= t1)
        xs.append(tr.x[mask] if mask.any() else tr.x[:1])
        ys.append(tr.y[mask] if mask.any() else tr.y[:1])
    x, y = np.concatenate(xs), np.concatenate(ys)
    hx = max(MIN_VIEW / 2, np.ptp(x) / 2 + VIEW_MARGIN)
    hy = max(MIN_VIEW / 2, np.ptp(y) / 2 + VIEW_MARGIN)
    hx, hy = max(hx, hy / MAX_ASPECT), max(hy, hx / MAX_ASPECT)
    return float((x.min() + x.max()) / 2), float((y.min() + y.max()) / 2), float(hx), float(hy)


def _draw_map(ax, geometry: MapGeometry) -> None:
    ax.set_facecolor("#b7c9a8")
    for ring in geometry.drivable:
        ax.add_patch(PolygonPatch(ring, closed=True, facecolor=ASPHALT, edgecolor=LANE_LINE, lw=0.8, zorder=1))
    for ring in geometry.holes:
        ax.add_patch(PolygonPatch(ring, closed=True, facecolor="#b7c9a8", edgecolor="none", zorder=1))
    for edge in geometry.lane_edges:
        ax.plot(edge[:, 0], edge[:, 1], color=LANE_LINE, lw=0.5, ls=(0, (5, 5)), alpha=0.5, zorder=2)
    for line in geometry.center_lines:
        ax.plot(line[:, 0], line[:, 1], color=CENTER_LINE, lw=1.2, zorder=3)


def _figure(geometry: MapGeometry, view: tuple[float, float, float, float], size: float, dpi: int):
    cx, cy, hx, hy = view
    width, height = (size, max(size / MAX_ASPECT, size * hy / hx) + 0.6) if hx >= hy else (size * hx / hy + 0.8, size)
    fig, ax = plt.subplots(figsize=(width, height), dpi=dpi)
    _draw_map(ax, geometry)
    ax.set_xlim(cx - hx, cx + hx)
    ax.set_ylim(cy - hy, cy + hy)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.tick_params(labelsize=7)
    fig.tight_layout()
    return fig, ax


def _draw_actors(ax, tracks: list[ActorTrack], time: float, trail_from: float) -> list:
    artists = []
    for k, tr in enumerate(tracks):
        color = ROLE_COLORS[k % len(ROLE_COLORS)]
        mask = (tr.t >= trail_from) & (tr.t <= time)
        if mask.any():
            artists += ax.plot(tr.x[mask], tr.y[mask], color=color, lw=1.6, ls=":", zorder=4)
        x, y, yaw = tr.at(time)
        box = footprint_corners(x, y, yaw, tr.length, tr.width)
        artists.append(ax.add_patch(PolygonPatch(box, closed=True, facecolor=color, edgecolor="white", lw=0.8,
                                                 zorder=5)))
        nose = box[:2].mean(axis=0)
        artists += ax.plot([x, nose[0]], [y, nose[1]], color="white", lw=1.0, zorder=6)
        side = 1 if k % 2 == 0 else -1  # alternate label sides so close actors stay readable
        artists.append(ax.text(x, y + side * (tr.length / 2 + 2.0), tr.role, color="white", fontsize=7, ha="center",
                               va="center", zorder=7, bbox=dict(facecolor=color, edgecolor="none", pad=1.0, alpha=0.85)))
    return artists


def still_png(map_file: str | Path, tracks: list[ActorTrack], time: float, title: str, size: float = 6.0,
              dpi: int = 100, impact: tuple[float, float] | None = None) -> bytes:
    """PNG of every actor at `time` [s] with its path over the preceding seconds; `impact` [m] is starred."""
    geometry = load_map(str(map_file))
    fig, ax = _figure(geometry, _view(tracks, max(0.0, time - 2.0), time + 0.3), size, dpi)
    _draw_actors(ax, tracks, time, trail_from=max(0.0, time - 6.0))
    if impact is not None and all(v is not None and math.isfinite(v) for v in impact):
        ax.plot(*impact, marker="*", markersize=14, color="#ffe000", markeredgecolor="black", zorder=8)
    ax.set_title(title, fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def animation_gif(map_file: str | Path, tracks: list[ActorTrack], t0: float, t1: float, title: str,
                  size: float = 5.5, dpi: int = 80) -> bytes:
    """Animated GIF of the actors between t0 and t1 [s] (one frame per GIF_FRAME_DT, at most GIF_MAX_FRAMES)."""
    geometry = load_map(str(map_file))
    step = max(GIF_FRAME_DT, (t1 - t0) / GIF_MAX_FRAMES)
    times = np.arange(t0, t1 + 1e-9, step)
    fig, ax = _figure(geometry, _view(tracks, t0, t1), size, dpi)
    frames = []
    for time in times:
        artists = _draw_actors(ax, tracks, float(time), trail_from=t0)
        ax.set_title(f"{title}  t = {time:4.1f} s", fontsize=8)
        fig.canvas.draw()
        rgb = Image.frombuffer("RGBA", fig.canvas.get_width_height(), fig.canvas.buffer_rgba()).convert("RGB")
        frames.append(rgb.quantize(colors=64, method=Image.Quantize.MEDIANCUT))
        for artist in artists:
            artist.remove()
    plt.close(fig)
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=int(step * 1000), loop=0,
                   optimize=False)
    return buf.getvalue()
