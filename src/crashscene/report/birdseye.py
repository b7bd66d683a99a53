"""Bird's-eye pictures of a simulated variation on its map, in the report's language: a still and an animated GIF.

Vehicles carry their report labels (V1, V2, ...; the role in small type) in the
colours crash sketches use (`palette`), with a legend, a scale bar and, when
the map is georeferenced, a north arrow. The frame (`framing`) is centred on
the first contact, else on the closest approach (its gap written on the
picture), else on the lone vehicle with the road beside it.

Drawn with Pillow (no plotting library): the map is drawn supersampled once
per picture; a GIF draws its vehicles on a palette copy of that background per
frame, so a 40-frame animation costs tens of milliseconds.
"""
from __future__ import annotations

import io
import math
from functools import lru_cache
from importlib.util import find_spec
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from crashscene.geometry import footprint_corners
from crashscene.report.framing import Focus, Frame
from crashscene.report.palette import color_of, rgb
from crashscene.report.roadmap import MapGeometry
from crashscene.report.tracks import ActorTrack

GROUND, ASPHALT, ROAD_EDGE, LANE_LINE, CENTER_LINE = "#e6ecdf", "#c9c9c9", "#4a4a4a", "#ffffff", "#e0a800"
TEXT, MUTED, STAR, APPROACH_LINE = "#222222", "#555555", "#ffd400", "#000000"
SUPERSAMPLE = 2  # map and vehicles are drawn at this multiple, then scaled down (anti-aliasing)
TITLE_PX, LEGEND_PX = 22, 24  # [px] strips above and below the map
TRAIL = 6.0  # [s] of path drawn behind each vehicle
TRAIL_DOT = 0.5  # [s] between trail dots
GIF_FRAME_DT = 0.2  # [s] of simulated time per GIF frame
GIF_MAX_FRAMES = 50
DASH = (3.0, 6.0)  # [m] lane-line dash and gap (US broken line: 3 m painted, 9 m gap, shortened to read)


@lru_cache(maxsize=8)
def _font(size: int, bold: bool = False) -> ImageFont.FreeTypeFont:
    """DejaVu Sans from matplotlib's data (always installed here): the same glyphs on every machine."""
    spec = find_spec("matplotlib")
    if spec is not None and spec.submodule_search_locations:
        name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
        path = Path(spec.submodule_search_locations[0]) / "mpl-data" / "fonts" / "ttf" / name
        if path.exists():
            return ImageFont.truetype(str(path), size)
    return ImageFont.load_default(size)


class Canvas:
    """World [m] to pixel transform of a frame drawn `width` px wide (the map area only)."""

    def __init__(self, frame: Frame, width: int, scale: int = 1):
        self.frame = frame
        self.scale = scale
        self.px_per_m = width / (2 * frame.hx) * scale
        self.size = (width * scale, int(round(width * frame.hy / frame.hx)) * scale)

    def px(self, pts: np.ndarray) -> np.ndarray:
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        f = self.frame
        return np.column_stack(((pts[:, 0] - (f.cx - f.hx)) * self.px_per_m, ((f.cy + f.hy) - pts[:, 1]) * self.px_per_m))

    def visible(self, pts: np.ndarray, pad: float = 10.0) -> bool:
        f = self.frame
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return not (hi[0] < f.cx - f.hx - pad or lo[0] > f.cx + f.hx + pad or hi[1] < f.cy - f.hy - pad
                    or lo[1] > f.cy + f.hy + pad)


def _flat(pts: np.ndarray) -> list[float]:
    return [float(v) for v in pts.ravel()]


def _dashes(line: np.ndarray, dash: float, gap: float) -> np.ndarray:
    """Dashes of a polyline [m] as straight segments (n, 2, 2): `dash` metres drawn, `gap` metres left out."""
    seg = np.hypot(*np.diff(line, axis=0).T)
    s = np.concatenate(([0.0], np.cumsum(seg)))
    if s[-1] <= 0:
        return np.zeros((0, 2, 2))
    starts = np.arange(0.0, s[-1], dash + gap)
    ends = np.minimum(starts + dash, s[-1])
    return np.stack([np.column_stack((np.interp(v, s, line[:, 0]), np.interp(v, s, line[:, 1])))
                     for v in (starts, ends)], axis=1)


def _draw_map(draw: ImageDraw.ImageDraw, canvas: Canvas, geometry: MapGeometry) -> None:
    k = canvas.scale
    for ring in geometry.drivable:
        if canvas.visible(ring):
            draw.polygon(_flat(canvas.px(ring)), fill=ASPHALT)
    for ring in geometry.holes:
        if canvas.visible(ring):
            draw.polygon(_flat(canvas.px(ring)), fill=GROUND)
    lane_w = max(1, int(round(0.15 * canvas.px_per_m)))
    w, h = canvas.size
    for edge in geometry.lane_edges:
        if canvas.visible(edge):
            pieces = canvas.px(_dashes(edge, *DASH).reshape(-1, 2)).reshape(-1, 4)
            inside = ((pieces[:, [0, 2]].max(axis=1) >= 0) & (pieces[:, [0, 2]].min(axis=1) <= w)
                      & (pieces[:, [1, 3]].max(axis=1) >= 0) & (pieces[:, [1, 3]].min(axis=1) <= h))
            for piece in pieces[inside]:
                draw.line(_flat(piece), fill=LANE_LINE, width=lane_w)
    for line in geometry.center_lines:
        if canvas.visible(line):
            draw.line(_flat(canvas.px(line)), fill=CENTER_LINE, width=max(k, int(round(0.3 * canvas.px_per_m))))
    for ring in [*geometry.drivable, *geometry.holes]:
        if canvas.visible(ring):
            draw.line(_flat(canvas.px(np.vstack((ring, ring[:1])))), fill=ROAD_EDGE, width=k + 1)


def _vehicle(draw: ImageDraw.ImageDraw, canvas: Canvas, tr: ActorTrack, time: float, fill, outline) -> None:
    x, y, yaw = tr.at(time)
    draw.polygon(_flat(canvas.px(footprint_corners(x, y, yaw, tr.length, tr.width))), fill=fill, outline=outline,
                 width=max(1, canvas.scale))
    # the sketches' white arrow-head: a triangle in the front half pointing the way the vehicle faces
    c, s = math.cos(yaw), math.sin(yaw)
    size = min(tr.width * 0.32, tr.length * 0.22)
    tip = (x + c * tr.length * 0.36, y + s * tr.length * 0.36)
    base = (x + c * (tr.length * 0.36 - 1.6 * size), y + s * (tr.length * 0.36 - 1.6 * size))
    tri = np.array([tip, (base[0] - s * size, base[1] + c * size), (base[0] + s * size, base[1] - c * size)])
    draw.polygon(_flat(canvas.px(tri)), fill=outline)


def _trail(draw: ImageDraw.ImageDraw, canvas: Canvas, tr: ActorTrack, t0: float, t1: float, fill) -> None:
    r = max(1.0, 0.35 * canvas.px_per_m)
    for t in np.arange(t1 - TRAIL_DOT, t0 - 1e-9, -TRAIL_DOT):
        px, py = canvas.px(np.array(tr.at(float(t))[:2]))[0]
        draw.ellipse((px - r, py - r, px + r, py + r), fill=fill)


def _star(cx: float, cy: float, r: float) -> list[float]:
    pts = []
    for k in range(10):
        a = math.pi / 2 + k * math.pi / 5
        rr = r if k % 2 == 0 else r * 0.45
        pts += [cx + rr * math.cos(a), cy - rr * math.sin(a)]
    return pts


def _tag(draw: ImageDraw.ImageDraw, canvas: Canvas, tr: ActorTrack, time: float, k: int, fill, text_fill,
         role_fill, halo) -> None:
    """The vehicle's report label in its colour, the role in small type, beside the vehicle."""
    box = canvas.px(footprint_corners(*tr.at(time), tr.length, tr.width))
    px = float(box[:, 0].mean())
    py = float(box[:, 1].min()) - 11 if k % 2 == 0 else float(box[:, 1].max()) + 11
    bold, small = _font(12, True), _font(9)
    w = draw.textlength(tr.label, font=bold)
    wr = draw.textlength(tr.role, font=small)
    left = px - (w + wr + 10) / 2
    draw.rectangle((left, py - 8, left + w + 6, py + 8), fill=fill)
    draw.text((left + 3, py), tr.label, font=bold, fill=text_fill, anchor="lm")
    draw.rectangle((left + w + 6, py - 6, left + w + wr + 10, py + 6), fill=halo)
    draw.text((left + w + 8, py), tr.role, font=small, fill=role_fill, anchor="lm")


def _legend(draw: ImageDraw.ImageDraw, tracks: list[ActorTrack], top: int, width: int, px_per_m: float) -> None:
    x = 6
    font, small = _font(11, True), _font(9)
    for tr in tracks:
        draw.rectangle((x, top + 7, x + 14, top + 17), fill=color_of(tr.label))
        x += 18
        draw.text((x, top + 12), tr.label, font=font, fill=TEXT, anchor="lm")
        x += draw.textlength(tr.label, font=font) + 3
        detail = f"{tr.role}, {tr.type}" + (", ADS" if tr.is_ads else "")
        draw.text((x, top + 12), detail, font=small, fill=MUTED, anchor="lm")
        x += draw.textlength(detail, font=small) + 12
    _scale_bar(draw, width, top, px_per_m)


def _scale_bar(draw: ImageDraw.ImageDraw, width: int, top: int, px_per_m: float) -> None:
    metres = next(m for m in (5, 10, 20, 25, 50, 100) if m * px_per_m >= 50)
    length = metres * px_per_m
    right = width - 8
    y = top + 14
    draw.line((right - length, y, right, y), fill=TEXT, width=2)
    for xx in (right - length, right):
        draw.line((xx, y - 4, xx, y + 1), fill=TEXT, width=1)
    draw.text((right - length / 2, y - 4), f"{metres} m", font=_font(9), fill=TEXT, anchor="mb")


def _north(draw: ImageDraw.ImageDraw, width: int) -> None:
    x, y = width - 22, TITLE_PX + 12
    draw.polygon((x, y, x - 7, y + 18, x, y + 13, x + 7, y + 18), fill=TEXT)
    draw.text((x, y + 20), "N", font=_font(11, True), fill=TEXT, anchor="mt")


def _compose(geometry: MapGeometry, frame: Frame, tracks: list[ActorTrack], width: int) -> tuple[Image.Image, Canvas]:
    """The background: map (supersampled), title strip, legend strip, north arrow; and the 1x canvas."""
    big = Canvas(frame, width, SUPERSAMPLE)
    layer = Image.new("RGB", big.size, GROUND)
    _draw_map(ImageDraw.Draw(layer), big, geometry)
    one = Canvas(frame, width)
    layer = layer.reduce(SUPERSAMPLE)
    image = Image.new("RGB", (one.size[0], one.size[1] + TITLE_PX + LEGEND_PX), "white")
    image.paste(layer, (0, TITLE_PX))
    draw = ImageDraw.Draw(image)
    _legend(draw, tracks, TITLE_PX + one.size[1], one.size[0], one.px_per_m)
    if geometry.north:
        _north(draw, one.size[0])
    return image, one


class _Shifted(Canvas):
    """A canvas whose map area starts `dy` px below the image top (under the title strip)."""

    def __init__(self, base: Canvas, dy: float, scale: int = 1):
        super().__init__(base.frame, base.size[0], scale)
        self.dy = dy * scale

    def px(self, pts: np.ndarray) -> np.ndarray:
        out = super().px(pts)
        out[:, 1] += self.dy
        return out


def still_png(geometry: MapGeometry, tracks: list[ActorTrack], frame: Frame, focus: Focus, title: str,
              width: int = 640) -> bytes:
    """PNG of every vehicle at the focus time with its path over the preceding TRAIL seconds.

    A contact is starred; a closest approach gets a line between the two nearest points and its gap."""
    image, one = _compose(geometry, frame, tracks, width)
    k = SUPERSAMPLE
    over = Image.new("RGBA", (image.size[0] * k, image.size[1] * k), (0, 0, 0, 0))
    big = _Shifted(one, TITLE_PX, k)
    draw = ImageDraw.Draw(over)
    for tr in tracks:
        _trail(draw, big, tr, max(0.0, focus.t - TRAIL), focus.t, color_of(tr.label) + "b0")
    for tr in tracks:
        _vehicle(draw, big, tr, focus.t, color_of(tr.label), "#ffffff")
    if focus.kind == "contact":
        px, py = big.px(np.array((focus.x, focus.y)))[0]
        draw.polygon(_star(px, py, 9 * k), fill=STAR, outline="#000000", width=k)
    elif focus.kind == "closest" and focus.points is not None:
        (ax, ay), (bx, by) = big.px(np.array(focus.points))
        draw.line((ax, ay, bx, by), fill=APPROACH_LINE, width=2 * k)
        for px, py in ((ax, ay), (bx, by)):
            draw.ellipse((px - 3 * k, py - 3 * k, px + 3 * k, py + 3 * k), fill=APPROACH_LINE)
    over = over.reduce(k)
    image.paste(over, (0, 0), over)
    draw = ImageDraw.Draw(image)
    shifted = _Shifted(one, TITLE_PX)
    for n, tr in enumerate(tracks):
        color = color_of(tr.label)
        _tag(draw, shifted, tr, focus.t, n, color, "#ffffff", MUTED, "#ffffff")
    if focus.kind == "closest" and focus.gap is not None and focus.pair is not None:
        labels = {tr.role: tr.label for tr in tracks}
        note = f"closest approach {labels.get(focus.pair[0])}-{labels.get(focus.pair[1])}: {focus.gap:.1f} m"
        draw.rectangle((4, TITLE_PX + 4, 10 + draw.textlength(note, font=_font(11, True)), TITLE_PX + 20), fill="white")
        draw.text((7, TITLE_PX + 12), note, font=_font(11, True), fill=TEXT, anchor="lm")
    draw.text((6, TITLE_PX // 2), title, font=_font(11), fill=TEXT, anchor="lm")
    buf = io.BytesIO()
    image.save(buf, format="PNG", optimize=False, compress_level=6)
    return buf.getvalue()


def animation_gif(geometry: MapGeometry, tracks: list[ActorTrack], frame: Frame, t0: float, t1: float, title: str,
                  width: int = 480, impact: Focus | None = None) -> bytes:
    """Animated GIF of the vehicles between t0 and t1 [s] (one frame per GIF_FRAME_DT, at most GIF_MAX_FRAMES).

    Vehicles are drawn on a palette copy of the background: the label colours, white and black sit at fixed
    palette indices after the background's own colours."""
    image, one = _compose(geometry, frame, tracks, width)
    fixed = ["#ffffff", "#000000", STAR, TEXT, MUTED] + [color_of(tr.label) for tr in tracks]
    base = image.quantize(colors=256 - len(fixed), method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    palette = base.getpalette()[: 3 * (256 - len(fixed))]
    palette += [0] * (3 * (256 - len(fixed)) - len(palette))
    index = {}
    for n, color in enumerate(fixed):
        index[color] = 256 - len(fixed) + n
        palette += list(rgb(color))
    base.putpalette(palette)
    step = max(GIF_FRAME_DT, (t1 - t0) / GIF_MAX_FRAMES)
    times = np.arange(t0, t1 + 1e-9, step)
    canvas = _Shifted(one, TITLE_PX)
    frames = []
    for time in times:
        frame_img = base.copy()
        draw = ImageDraw.Draw(frame_img)
        for tr in tracks:
            _trail(draw, canvas, tr, t0, float(time), index[color_of(tr.label)])
        for tr in tracks:
            _vehicle(draw, canvas, tr, float(time), index[color_of(tr.label)], index["#ffffff"])
        if impact is not None and impact.kind == "contact" and time >= impact.t:
            px, py = canvas.px(np.array((impact.x, impact.y)))[0]
            draw.polygon(_star(px, py, 8), fill=index[STAR], outline=index["#000000"])
        for n, tr in enumerate(tracks):
            color = index[color_of(tr.label)]
            _tag(draw, canvas, tr, float(time), n, color, index["#ffffff"], index[MUTED], index["#ffffff"])
        draw.rectangle((0, 0, frame_img.size[0], TITLE_PX - 1), fill=index["#ffffff"])
        draw.text((6, TITLE_PX // 2), f"{title}   t = {time:4.1f} s", font=_font(11), fill=index[TEXT], anchor="lm")
        frames.append(frame_img)
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=int(round(step * 1000)),
                   loop=0, optimize=False)
    return buf.getvalue()
