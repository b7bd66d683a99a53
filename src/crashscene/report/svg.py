"""A small SVG plotting vocabulary for the report's charts: a plot area with linear axes, bars, dots and legends.

The report's charts are simple (bars, a scatter, histograms); written as SVG
text they cost microseconds instead of a plotting library's ~0.5 s per figure,
scale without blur, and are the same bytes for the same data. Embedded as
`data:image/svg+xml` images, they need nothing from the network.
"""
from __future__ import annotations

import math
from xml.sax.saxutils import escape

FONT = "font-family=\"DejaVu Sans, Verdana, sans-serif\""
AXIS, GRID, TEXT = "#444444", "#e4e4e4", "#222222"


def nice_ticks(lo: float, hi: float, count: int = 5) -> list[float]:
    """About `count` round tick values covering [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / max(1, count)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.floor(lo / step) * step
    ticks, v = [], first
    while v <= hi + step * 1e-9:
        ticks.append(round(v, 10))
        v += step
    if ticks[-1] < hi:
        ticks.append(round(ticks[-1] + step, 10))
    return ticks


def fmt(v: float) -> str:
    return f"{v:g}" if abs(v) < 1e5 else f"{v:.2e}"


class Plot:
    """One plot area of `width` x `height` px inside margins, with data ranges (x0, x1) and (y0, y1)."""

    def __init__(self, left: float, top: float, width: float, height: float, x: tuple[float, float],
                 y: tuple[float, float]):
        self.left, self.top, self.width, self.height = left, top, width, height
        self.x0, self.x1 = x if x[1] > x[0] else (x[0], x[0] + 1.0)
        self.y0, self.y1 = y if y[1] > y[0] else (y[0], y[0] + 1.0)
        self.parts: list[str] = []

    def px(self, x: float) -> float:
        return self.left + (x - self.x0) / (self.x1 - self.x0) * self.width

    def py(self, y: float) -> float:
        return self.top + self.height - (y - self.y0) / (self.y1 - self.y0) * self.height

    def axes(self, xlabel: str, ylabel: str, xticks: list[float] | None = None, yticks: list[float] | None = None,
             xticklabels: list[str] | None = None) -> None:
        b, l_ = self.top + self.height, self.left
        eps = 1e-9 * max(abs(self.x1 - self.x0), abs(self.y1 - self.y0))
        for v in [v for v in yticks or [] if self.y0 - eps <= v <= self.y1 + eps]:
            y = self.py(v)
            self.parts.append(f'<line x1="{l_:.1f}" y1="{y:.1f}" x2="{l_ + self.width:.1f}" y2="{y:.1f}" '
                              f'stroke="{GRID}"/>')
            self.parts.append(text(l_ - 4, y + 3, fmt(v), 9, anchor="end"))
        for k, v in enumerate(xticks or []):
            if not self.x0 - eps <= v <= self.x1 + eps:
                continue
            x = self.px(v)
            label = xticklabels[k] if xticklabels else fmt(v)
            self.parts.append(f'<line x1="{x:.1f}" y1="{b:.1f}" x2="{x:.1f}" y2="{b + 3:.1f}" stroke="{AXIS}"/>')
            self.parts.append(text(x, b + 13, label, 9))
        self.parts.append(f'<path d="M{l_:.1f},{self.top:.1f} V{b:.1f} H{l_ + self.width:.1f}" fill="none" '
                          f'stroke="{AXIS}"/>')
        self.parts.append(text(l_ + self.width / 2, b + 27, xlabel, 10))
        self.parts.append(text(l_ - 34, self.top + self.height / 2, ylabel, 10, rotate=True))

    def rect(self, x0: float, y0: float, x1: float, y1: float, color: str, opacity: float = 1.0) -> None:
        """A bar between data corners (x0, y0) and (x1, y1)."""
        a, b = sorted((self.px(x0), self.px(x1)))
        c, d = sorted((self.py(y0), self.py(y1)))
        self.parts.append(f'<rect x="{a:.1f}" y="{c:.1f}" width="{max(b - a, 0.5):.1f}" height="{d - c:.1f}" '
                          f'fill="{color}"' + (f' fill-opacity="{opacity}"' if opacity < 1 else "") + "/>")

    def dot(self, x: float, y: float, color: str, r: float = 2.5, opacity: float = 1.0) -> None:
        self.parts.append(f'<circle cx="{self.px(x):.1f}" cy="{self.py(y):.1f}" r="{r}" fill="{color}"'
                          + (f' fill-opacity="{opacity}"' if opacity < 1 else "") + "/>")


def text(x: float, y: float, s: str, size: int, anchor: str = "middle", rotate: bool = False,
         color: str = TEXT, weight: str = "normal") -> str:
    transform = f' transform="rotate(-90 {x:.1f} {y:.1f})"' if rotate else ""
    return (f'<text x="{x:.1f}" y="{y:.1f}" font-size="{size}" text-anchor="{anchor}" fill="{color}" '
            f'font-weight="{weight}"{transform}>{escape(s)}</text>')


def legend(x: float, y: float, items: list[tuple[str, str]], size: int = 9) -> list[str]:
    """Coloured squares and labels in a row starting at (x, y) [px]."""
    out = []
    for label, color in items:
        out.append(f'<rect x="{x:.1f}" y="{y - 8:.1f}" width="9" height="9" fill="{color}"/>')
        out.append(text(x + 12, y, label, size, anchor="start"))
        x += 18 + 0.6 * size * len(label)
    return out


def document(width: int, height: int, parts: list[str], title: str = "") -> bytes:
    head = text(width / 2, 14, title, 11, weight="bold") if title else ""
    body = "".join(parts)
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" {FONT}><rect width="100%" height="100%" fill="white"/>'
            f"{head}{body}</svg>").encode("utf-8")
