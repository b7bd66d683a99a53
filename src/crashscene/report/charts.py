"""Small matplotlib charts of one case's results, returned as PNG bytes."""
from __future__ import annotations

import io
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from crashscene.report.palette import color_of, label_of, label_sort_key  # noqa: E402

VERDICT_COLORS = {"pass": "#2ca02c", "violation": "#ff7f0e", "collision": "#d62728", "invalid": "#7f7f7f"}
VERDICTS = ("pass", "violation", "collision", "invalid")


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def violations_bar(per_mode: dict[str, dict[str, dict[str, int]]], variations: dict[str, int],
                   labels: dict[str, str] | None = None) -> bytes | None:
    """Grouped bars: for each mode, the share of variations in which each actor violated each code.

    Actors are named and coloured by their report labels (V1 red, V2 blue, ... as in every picture)."""
    labels = labels or {}
    modes = [m for m in per_mode if per_mode[m]]
    if not modes:
        return None
    fig, axes = plt.subplots(1, len(modes), figsize=(4.6 * len(modes), 3.2), squeeze=False)
    for ax, mode in zip(axes[0], modes):
        codes = sorted(per_mode[mode])
        actors = sorted({a for c in codes for a in per_mode[mode][c]},
                        key=lambda a: (label_sort_key(labels.get(a, label_of(a, None))), a))
        width = 0.8 / max(1, len(actors))
        xs = np.arange(len(codes))
        for k, actor in enumerate(actors):
            vals = [100.0 * per_mode[mode][c].get(actor, 0) / max(1, variations.get(mode, 1)) for c in codes]
            label = labels.get(actor, label_of(actor, None))
            ax.bar(xs + (k - (len(actors) - 1) / 2) * width, vals, width, label=f"{label} ({actor})",
                   color=color_of(label))
        ax.set_xticks(xs, [c.replace("CVC_", "") for c in codes], rotation=30, fontsize=8)
        ax.set_ylabel("variations violating [%]")
        ax.set_xlabel("CVC section")
        ax.set_title(f"rule violations per actor ({mode})", fontsize=9)
        ax.legend(fontsize=7)
    return _png(fig)


def verdict_bar(verdicts: dict[str, dict[str, int]]) -> bytes | None:
    """Stacked horizontal bar per mode: pass / violation / collision / invalid counts."""
    modes = [m for m in verdicts if sum(verdicts[m].values())]
    if not modes:
        return None
    fig, ax = plt.subplots(figsize=(5.2, 0.7 + 0.55 * len(modes)))
    for row, mode in enumerate(modes):
        left = 0
        for verdict in VERDICTS:
            count = verdicts[mode].get(verdict, 0)
            if count:
                ax.barh(row, count, left=left, color=VERDICT_COLORS[verdict], label=verdict if row == 0 else None)
                left += count
    ax.set_yticks(range(len(modes)), modes)
    ax.set_xlabel("variations")
    handles, labels = [], []
    for verdict in VERDICTS:
        handles.append(plt.Rectangle((0, 0), 1, 1, color=VERDICT_COLORS[verdict]))
        labels.append(verdict)
    ax.legend(handles, labels, fontsize=7, ncol=4, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    return _png(fig)


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
    fig, ax = plt.subplots(figsize=(4.6, 3.6))
    for verdict in VERDICTS:
        pts = [(r["params"].get(kx), r["params"].get(ky)) for r in rows if r["verdict"] == verdict]
        pts = [(x, y) for x, y in pts if isinstance(x, (int, float)) and isinstance(y, (int, float))]
        if not pts:
            continue
        xs, ys = zip(*pts)
        faint = verdict in ("pass", "invalid")
        ax.scatter(xs, ys, s=6 if faint else 12, alpha=0.25 if faint else 0.85, color=VERDICT_COLORS[verdict],
                   label=f"{verdict} ({len(pts)})", edgecolors="none")
    ax.set_xlabel(_label(kx))
    ax.set_ylabel(_label(ky))
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, markerscale=1.5)
    return _png(fig)


def _label(key: str) -> str:
    if key.endswith(".speed"):
        return f"{key.removesuffix('.speed')} initial speed [m/s]"
    if key.endswith(".distance"):
        return f"{key.removesuffix('.distance')} start distance to ego [m]"
    return key
