"""The report's charts of one case's results, as SVG (`svg`): verdicts, violations per actor, failing
parameters, criticality distributions. Vehicles are named and coloured by their report labels (`palette`)."""
from __future__ import annotations

import math

import numpy as np

from crashscene.report import svg
from crashscene.report.palette import color_of, label_of, label_sort_key

MIME = "image/svg+xml"
VERDICT_COLORS = {"pass": "#2ca02c", "violation": "#ff7f0e", "collision": "#d62728", "invalid": "#7f7f7f"}
VERDICTS = ("pass", "violation", "collision", "invalid")
PANEL_W, PANEL_H = 300, 210  # [px] one chart panel


def violations_bar(per_mode: dict[str, dict[str, dict[str, int]]], variations: dict[str, int],
                   labels: dict[str, str] | None = None) -> bytes | None:
    """Grouped bars: for each mode, the share of variations in which each actor violated each code.

    Actors are named and coloured by their report labels (V1 red, V2 blue, ... as in every picture)."""
    labels = labels or {}
    modes = [m for m in per_mode if per_mode[m]]
    if not modes:
        return None
    parts: list[str] = []
    for k, mode in enumerate(modes):
        codes = sorted(per_mode[mode])
        actors = sorted({a for c in codes for a in per_mode[mode][c]},
                        key=lambda a: (label_sort_key(labels.get(a, label_of(a, None))), a))
        plot = svg.Plot(50 + k * PANEL_W, 40, PANEL_W - 70, PANEL_H - 95, (-0.5, len(codes) - 0.5), (0.0, 100.0))
        width = 0.8 / max(1, len(actors))
        for j, actor in enumerate(actors):
            label = labels.get(actor, label_of(actor, None))
            for i, code in enumerate(codes):
                share = 100.0 * per_mode[mode][code].get(actor, 0) / max(1, variations.get(mode, 1))
                x = i + (j - (len(actors) - 1) / 2) * width
                plot.rect(x - width / 2, 0.0, x + width / 2, share, color_of(label))
        plot.axes("CVC section", "variations violating [%]", list(range(len(codes))), [0, 25, 50, 75, 100],
                  [c.replace("CVC_", "") for c in codes])
        parts += plot.parts
        parts.append(svg.text(plot.left + plot.width / 2, 32, f"rule violations per actor ({mode})", 10))
        parts += svg.legend(plot.left, PANEL_H - 12, [(f"{labels.get(a, label_of(a, None))} ({a})",
                                                       color_of(labels.get(a, label_of(a, None)))) for a in actors])
    return svg.document(PANEL_W * len(modes), PANEL_H, parts)


def verdict_bar(verdicts: dict[str, dict[str, int]]) -> bytes | None:
    """Stacked horizontal bar per mode: pass / violation / collision / invalid counts."""
    modes = [m for m in verdicts if sum(verdicts[m].values())]
    if not modes:
        return None
    most = max(sum(verdicts[m].values()) for m in modes)
    height = 70 + 26 * len(modes)
    plot = svg.Plot(80, 30, 400, 26 * len(modes), (0.0, float(most)), (-0.5, len(modes) - 0.5))
    for row, mode in enumerate(modes):
        left = 0
        for verdict in VERDICTS:
            count = verdicts[mode].get(verdict, 0)
            if count:
                plot.rect(left, row - 0.35, left + count, row + 0.35, VERDICT_COLORS[verdict])
                left += count
        plot.parts.append(svg.text(plot.left - 6, plot.py(row) + 3, mode, 10, anchor="end"))
    plot.axes("variations", "", svg.nice_ticks(0, most), None)
    parts = plot.parts + svg.legend(80, 20, [(v, VERDICT_COLORS[v]) for v in VERDICTS])
    return svg.document(500, height, parts)


def pick_axes(params: list[dict]) -> tuple[str, str] | None:
    """Two parameters that vary: preferably an NPC's speed and start distance, then the ego's speed, then the
    sampled scenario parameters with the largest spread."""
    keys = sorted({k for p in params for k, v in p.items() if isinstance(v, (int, float)) and math.isfinite(v)})
    spread = {k: float(np.nanstd([p.get(k, np.nan) for p in params])) for k in keys}
    varying = [k for k in keys if spread[k] > 1e-6]

    def rank(key: str) -> tuple[int, float]:
        if key.startswith("npc") and key.endswith(".speed"):
            return 0, 0.0
        if key.startswith("npc") and key.endswith(".distance"):
            return 1, 0.0
        if key.endswith(".speed"):
            return 2, 0.0
        return 3, -spread[key]

    ranked = sorted(varying, key=rank)
    return (ranked[0], ranked[1]) if len(ranked) >= 2 else None


def failing_scatter(rows: list[dict], title: str) -> bytes | None:
    """Parameter values of failing variations coloured by verdict (passing ones faint, for context)."""
    params = [r["params"] for r in rows]
    axes = pick_axes(params)
    if axes is None or not any(r["verdict"] in ("violation", "collision") for r in rows):
        return None
    kx, ky = axes
    pts = {v: [(r["params"].get(kx), r["params"].get(ky)) for r in rows if r["verdict"] == v] for v in VERDICTS}
    pts = {v: [(x, y) for x, y in p if isinstance(x, (int, float)) and isinstance(y, (int, float))]
           for v, p in pts.items()}
    xs = [x for p in pts.values() for x, _ in p]
    ys = [y for p in pts.values() for _, y in p]
    xt, yt = svg.nice_ticks(min(xs), max(xs)), svg.nice_ticks(min(ys), max(ys))
    plot = svg.Plot(60, 30, 330, 230, (xt[0], xt[-1]), (yt[0], yt[-1]))
    for verdict in VERDICTS:
        faint = verdict in ("pass", "invalid")
        for x, y in pts[verdict]:
            plot.dot(x, y, VERDICT_COLORS[verdict], r=2.0 if faint else 3.0, opacity=0.3 if faint else 0.85)
    plot.axes(_label(kx), _label(ky), xt, yt)
    parts = plot.parts + svg.legend(60, 322, [(f"{v} ({len(pts[v])})", VERDICT_COLORS[v]) for v in VERDICTS
                                              if pts[v]])
    return svg.document(420, 332, parts, title)


def _label(key: str) -> str:
    if key.endswith(".speed"):
        return f"{key.removesuffix('.speed')} initial speed [m/s]"
    if key.endswith(".distance"):
        return f"{key.removesuffix('.distance')} start distance to ego [m]"
    return key


def _png(fig) -> bytes:
    """PNG bytes of a matplotlib figure (for sections still drawn with matplotlib, e.g. `search_section`)."""
    import io

    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=100)
    fig.clf()
    __getattr__("plt").close(fig)
    return buf.getvalue()


def __getattr__(name: str):
    """`charts.plt`: matplotlib's pyplot (Agg), imported only by the sections that still plot with it."""
    if name == "plt":
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        return plt
    raise AttributeError(name)
