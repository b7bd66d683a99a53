"""The report's "criticality" and "search" sections of one case: data from the campaign database, charts as PNG.

- criticality: histograms of the per-pair metrics (monitor.criticality) of the
  case's runs, and the two parameters most influential on the minimum TTC
  (largest absolute Spearman rank correlation with it) plotted against each
  other, coloured by minimum TTC;
- search: per stored search (campaign --search), evaluated variations,
  failures (and the difference to a random search of the same budget when
  both ran), best objective, the objective per round (convergence) and the
  failure-region rules.
"""
from __future__ import annotations

import base64
import json
import math

import numpy as np

from crashscene.report import charts

HISTOGRAMS = (("min_ttc", "minimum TTC [s]"), ("pet", "post-encroachment time [s]"),
              ("min_thw", "minimum time headway [s]"), ("max_drac", "max. DRAC [m/s2]"))
TTC_COLOR_CAP = 10.0  # [s] colour scale of the influence plot; larger TTCs (and none) share the top colour


def _uri(png: bytes | None) -> str | None:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii") if png else None


def search_rows(store, scenario_hash: str | None) -> list[dict]:
    """The case's stored searches (summary JSON included), random first."""
    if not scenario_hash:
        return []
    rows = store.query("SELECT sampler, objective, budget, evaluated, failures, min_objective, summary FROM searches "
                       "WHERE scenario_hash=? ORDER BY sampler <> 'random', sampler, objective, budget",
                       [scenario_hash])
    out = []
    for row in rows:
        summary = json.loads(row.pop("summary") or "{}")
        row["rounds"] = summary.get("rounds", [])
        row["rules"] = [r["rule"] for r in summary.get("rules", [])]
        random = next((r for r in rows if r["sampler"] == "random" and r["objective"] == row["objective"]
                       and r["budget"] == row["budget"]), None)
        row["failures_vs_random"] = (row["failures"] - random["failures"]
                                     if random is not None and row["sampler"] != "random" else None)
        out.append(row)
    return out


def case_figures(store, case: dict) -> dict:
    """`crit_hist`, `crit_influence` (data URIs or None), `search` (rows) and `search_convergence` for a case."""
    key = case.get("scenario_hash")
    fig: dict = {"crit_hist": None, "crit_influence": None, "search": search_rows(store, key),
                 "search_convergence": None}
    if not key:
        return fig
    crit = store.query("SELECT mode, variation, involves_ads, min_ttc, pet, min_thw, max_drac FROM criticality "
                       "WHERE scenario_hash=? ORDER BY mode, variation", [key])
    if crit:
        fig["crit_hist"] = _uri(histograms(crit))
        params = store.query("SELECT mode, variation, params FROM variations WHERE scenario_hash=?", [key])
        fig["crit_influence"] = _uri(influence(crit, params))
    if fig["search"]:
        fig["search_convergence"] = _uri(convergence(fig["search"]))
    return fig


def histograms(rows: list[dict]) -> bytes | None:
    """One histogram per metric, a series per mode (finite values only)."""
    plt = charts.plt
    modes = sorted({r["mode"] for r in rows})
    fig, axes = plt.subplots(1, len(HISTOGRAMS), figsize=(12, 2.8))
    drawn = False
    for ax, (metric, label) in zip(axes, HISTOGRAMS):
        for mode in modes:
            values = np.array([r[metric] for r in rows if r["mode"] == mode and r[metric] is not None], dtype=float)
            values = values[np.isfinite(values)]
            if len(values):
                ax.hist(values, bins=30, alpha=0.6, label=f"{mode} (n={len(values)})")
                drawn = True
        ax.set_xlabel(label, fontsize=8)
        ax.set_ylabel("actor pairs", fontsize=8)
        ax.tick_params(labelsize=7)
        if ax.has_data():
            ax.legend(fontsize=6)
    if not drawn:
        plt.close(fig)
        return None
    return charts._png(fig)


def _min_ttc_by_variation(rows: list[dict], mode: str) -> dict[int, float]:
    """Per variation of `mode`: min TTC over the pairs with an actor under test (all pairs when none is)."""
    mine = [r for r in rows if r["mode"] == mode]
    use_ads = any(r["involves_ads"] for r in mine)
    out: dict[int, float] = {}
    for r in mine:
        if use_ads and not r["involves_ads"]:
            continue
        value = r["min_ttc"] if r["min_ttc"] is not None and math.isfinite(r["min_ttc"]) else math.inf
        out[r["variation"]] = min(out.get(r["variation"], math.inf), value)
    return out


def influence(crit: list[dict], params: list[dict]) -> bytes | None:
    """The two parameters with the largest |Spearman rho| against min TTC, scattered and coloured by min TTC."""
    from scipy.stats import spearmanr

    plt = charts.plt
    modes = sorted({r["mode"] for r in crit})
    mode = "test" if "test" in modes else modes[0]
    ttc = _min_ttc_by_variation(crit, mode)
    rows = [(json.loads(p["params"] or "{}"), ttc[p["variation"]]) for p in params
            if p["mode"] == mode and p["variation"] in ttc]
    if len(rows) < 5:
        return None
    names = sorted({k for values, _ in rows for k, v in values.items() if isinstance(v, (int, float))})
    y = np.minimum(np.array([t for _, t in rows]), TTC_COLOR_CAP)
    scores = []
    for name in names:
        x = np.array([values.get(name, np.nan) for values, _ in rows], dtype=float)
        ok = np.isfinite(x)
        if ok.sum() < 5 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
            continue
        rho = spearmanr(x[ok], y[ok]).statistic
        if np.isfinite(rho):
            scores.append((abs(float(rho)), name))
    if len(scores) < 2:
        return None
    (r1, p1), (r2, p2) = sorted(scores, reverse=True)[:2]
    x1 = np.array([values.get(p1, np.nan) for values, _ in rows], dtype=float)
    x2 = np.array([values.get(p2, np.nan) for values, _ in rows], dtype=float)
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    points = ax.scatter(x1, x2, c=y, cmap="viridis_r", s=10, vmin=0, vmax=TTC_COLOR_CAP)
    fig.colorbar(points, ax=ax, label=f"min TTC [s] (>= {TTC_COLOR_CAP:g}: none or far)")
    ax.set_xlabel(f"{p1} (|rho| {r1:.2f})", fontsize=8)
    ax.set_ylabel(f"{p2} (|rho| {r2:.2f})", fontsize=8)
    ax.set_title(f"most influential parameters on min TTC ({mode})", fontsize=9)
    return charts._png(fig)


def convergence(searches: list[dict]) -> bytes | None:
    """Best objective so far after each round, one line per search."""
    plt = charts.plt
    fig, ax = plt.subplots(figsize=(5.2, 3.2))
    for s in searches:
        rounds = [r for r in s["rounds"] if r.get("best") is not None]
        if rounds:
            ax.plot([r["evaluated"] for r in rounds], [r["best"] for r in rounds], marker="o", ms=3,
                    label=f"{s['sampler']} ({s['objective']})")
    if not ax.has_data():
        plt.close(fig)
        return None
    ax.set_xlabel("variations evaluated", fontsize=8)
    ax.set_ylabel("best objective so far", fontsize=8)
    ax.set_title("search convergence (lower: closer to failure)", fontsize=9)
    ax.legend(fontsize=7)
    return charts._png(fig)
