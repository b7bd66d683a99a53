"""Gather a run/campaign folder's results and write report.html, results.json and junit.xml.

The HTML is self-contained: every image (sketch, bird's-eye still, charts,
GIFs) is embedded as a data URI and the styles are inline, so the file opens
offline and can be mailed or archived as one file.
"""
from __future__ import annotations

import base64
import io
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import jinja2
from PIL import Image

from crashscene.campaign.errors import CampaignError
from crashscene.campaign.runner import summarize_runs
from crashscene.campaign.store import DB_NAME, Store
from crashscene.report import birdseye, charts, tracks
from crashscene.report.errors import ReportError
from crashscene.report.junit import junit_xml

SKETCH_MAX_PX = 900  # longest side of the embedded sketch
GIF_BEFORE, GIF_AFTER = 6.0, 1.5  # [s] around the impact
NARRATIVES = ("narrative.txt", "narrative.md", "narrative.pdf")
SKETCHES = ("sketch.jpg", "sketch.jpeg", "sketch.png")


@dataclass
class WrittenReport:
    html: Path
    results: Path
    junit: Path


def data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def write_report(out_dir: str | Path, gifs: bool = True, progress: Callable[[str], None] | None = None
                 ) -> WrittenReport:
    """Write OUT/report.html, OUT/results.json and OUT/junit.xml from OUT/campaign.duckdb.

    `progress` is called with a line per case (figures may need a variation re-simulated)."""
    from crashscene.campaign.engines import quiet_scenic_warnings

    quiet_scenic_warnings()
    start = time.perf_counter()
    out = Path(out_dir)
    if not (out / DB_NAME).exists():
        raise ReportError(f"{out}: no {DB_NAME}; give the --out folder of `crashscene run` or `crashscene campaign`")
    try:
        with Store(out, read_only=True) as store:
            cases, figures = _gather(store, out, gifs, progress)
    except CampaignError as exc:
        raise ReportError(str(exc)) from exc
    generated = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    results = {"generated": generated, "out_dir": str(out), "cases": cases, "totals": _totals(cases)}
    written = WrittenReport(out / "report.html", out / "results.json", out / "junit.xml")
    written.results.write_text(json.dumps(results, indent=2, default=str), encoding="utf-8")
    written.junit.write_text(junit_xml(cases, time.perf_counter() - start), encoding="utf-8")
    env = jinja2.Environment(loader=jinja2.PackageLoader("crashscene.report", "templates"),
                             autoescape=jinja2.select_autoescape(default=True))
    html = env.get_template("report.html.j2").render(results=results, cases=cases, figures=figures,
                                                       generated=generated)
    written.html.write_text(html, encoding="utf-8")
    return written


def _totals(cases: list[dict]) -> dict:
    totals: dict = {"cases": len(cases), "cases_ok": sum(c["status"] == "ok" for c in cases), "modes": {}}
    for case in cases:
        for mode, run in case["modes"].items():
            t = totals["modes"].setdefault(mode, {"variations": 0, "valid": 0, "reproduced": 0, "verdicts": {}})
            t["variations"] += run["variations"]
            t["valid"] += run["valid"]
            t["reproduced"] += run["reproduced"]
            for verdict, count in run["verdicts"].items():
                t["verdicts"][verdict] = t["verdicts"].get(verdict, 0) + count
    for t in totals["modes"].values():
        t["reproduction_rate"] = round(t["reproduced"] / t["valid"], 4) if t["valid"] else None
    return totals


def _gather(store: Store, out: Path, gifs: bool, progress: Callable[[str], None] | None = None
            ) -> tuple[list[dict], dict[str, dict]]:
    runs_by_case: dict[str, list] = {}
    for run in summarize_runs(store):
        runs_by_case.setdefault(run.case_id, []).append(run)
    case_rows = store.query("SELECT * FROM cases ORDER BY case_id")
    cases, figures = [], {}
    for k, row in enumerate(case_rows, 1):
        if progress is not None:
            progress(f"report: case {row['case_id']} ({k}/{len(case_rows)})")
        case_id = row["case_id"]
        work = out / "cases" / case_id
        scenario_text = _read(work / "scenario.yaml")
        case = {"case_id": case_id, "case_dir": row["case_dir"], "status": row["status"], "error": row["error"],
                "scenario_hash": row["scenario_hash"], "extract_backend": row["extract_backend"],
                "warnings": json.loads(row["warnings"] or "[]"), "modes": {}}
        case.update(_scenario_fields(scenario_text))
        runs = {r.mode: r for r in runs_by_case.get(case_id, [])}
        if not runs and row["scenario_hash"]:  # a case sharing another case's scenario shares its rows
            runs = {r.mode: r for rs in runs_by_case.values() for r in rs if r.scenario_hash == row["scenario_hash"]}
        for mode, run in runs.items():
            entry = run.model_dump(exclude={"case_id", "mode", "scenario_hash"})
            entry.update(_firsts(store, run))
            case["modes"][mode] = entry
        cases.append(case)
        figures[case_id] = _case_figures(store, out, case, scenario_text, gifs)
    return cases, figures


def _scenario_fields(text: str | None) -> dict:
    if not text:
        return {"scenario_id": None, "summary": None, "oracle": []}
    import yaml

    raw = yaml.safe_load(text) or {}
    return {"scenario_id": raw.get("scenario_id"), "summary": raw.get("summary"),
            "oracle": [{k: e.get(k) for k in ("code", "violation", "actor")} for e in raw.get("oracle") or []]}


def _firsts(store: Store, run) -> dict:
    """The first reproducing variation, first ADS violation and first collision of a run (None when absent)."""
    where = "scenario_hash=? AND mode=?"
    key = [run.scenario_hash, run.mode]
    first_rep = store.query(f"SELECT min(variation) AS v FROM variations WHERE {where} AND reproduced", key)[0]["v"]
    ads = store.query(f"SELECT variation AS v, min(t_first) AS t, string_agg(DISTINCT code, ', ') AS codes "
                      f"FROM violations WHERE {where} AND is_ads GROUP BY variation ORDER BY variation LIMIT 1", key)
    coll = store.query(f"SELECT variation AS v, min(t) AS t FROM collisions WHERE {where} GROUP BY variation "
                       "ORDER BY variation LIMIT 1", key)
    return {"first_reproducing": first_rep,
            "first_ads_violation": ads[0] if ads else None,
            "first_collision": coll[0] if coll else None}


def _read(path: Path) -> str | None:
    try:
        return path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None


def _narrative(case_dir: Path) -> str | None:
    if not case_dir.is_dir():
        return None
    for name in NARRATIVES:
        path = case_dir / name
        if path.is_file():
            if path.suffix == ".pdf":
                try:
                    from crashscene.extract.report import read_narrative

                    return read_narrative(path)
                except Exception as exc:  # noqa: BLE001  (a report still renders without the narrative)
                    return f"(narrative.pdf could not be read: {exc})"
            return _read(path)
    return None


def _sketch(case_dir: Path) -> str | None:
    if not case_dir.is_dir():
        return None
    for name in SKETCHES:
        path = case_dir / name
        if path.is_file():
            try:
                with Image.open(path) as img:
                    img = img.convert("RGB")
                    img.thumbnail((SKETCH_MAX_PX, SKETCH_MAX_PX))
                    buf = io.BytesIO()
                    img.save(buf, format="JPEG", quality=85)
                return data_uri(buf.getvalue(), "image/jpeg")
            except OSError:
                return None
    return None


def _run_row(store: Store, scenario_hash: str, mode: str) -> dict:
    return store.query("SELECT * FROM runs WHERE scenario_hash=? AND mode=? ORDER BY seed LIMIT 1",
                       [scenario_hash, mode])[0]


def _case_figures(store: Store, out: Path, case: dict, scenario_text: str | None, gifs: bool) -> dict:
    """Every image of one case as data URIs, plus notes on what could not be drawn."""
    fig: dict = {"narrative": _narrative(Path(case["case_dir"] or "")), "sketch": _sketch(Path(case["case_dir"] or "")),
                 "dsl": scenario_text, "notes": []}
    modes = case["modes"]
    if not modes:
        return fig
    png = charts.violations_bar({m: r["violations"] for m, r in modes.items()},
                                {m: r["variations"] for m, r in modes.items()})
    fig["violations"] = data_uri(png, "image/png") if png else None
    png = charts.verdict_bar({m: r["verdicts"] for m, r in modes.items()})
    fig["verdicts"] = data_uri(png, "image/png") if png else None
    fig["scatter"] = {}
    for mode in modes:
        rows = store.query("SELECT verdict, params FROM variations WHERE scenario_hash=? AND mode=? ORDER BY variation",
                           [case["scenario_hash"], mode])
        rows = [{"verdict": r["verdict"], "params": json.loads(r["params"] or "{}")} for r in rows]
        png = charts.failing_scatter(rows, f"failing variations ({mode})")
        if png:
            fig["scatter"][mode] = data_uri(png, "image/png")
    _impact_and_gifs(store, out, case, fig, gifs)
    return fig


def _impact_and_gifs(store: Store, out: Path, case: dict, fig: dict, gifs: bool) -> None:
    work = out / "cases" / case["case_id"]
    modes = case["modes"]
    # the still: the first reproducing variation at impact, else the first collision, else variation 0's end
    pick = None
    rep = modes.get("reproduce", {})
    if rep.get("first_reproducing") is not None:
        pick = ("reproduce", rep["first_reproducing"], "first reproducing variation")
    else:
        for mode, run in modes.items():
            if run.get("first_collision"):
                pick = (mode, run["first_collision"]["v"], "first variation with a collision")
                break
    if pick is None:
        mode = next(iter(modes))
        pick = (mode, 0, "no collision in any variation: variation 0")
    wanted = [("still", *pick)]
    if gifs and rep.get("first_reproducing") is not None:
        wanted.append(("gif_reproduce", "reproduce", rep["first_reproducing"], "first reproducing variation"))
    elif gifs and rep.get("first_collision"):  # nothing reproduced: show what the re-enactment did instead
        wanted.append(("gif_reproduce", "reproduce", rep["first_collision"]["v"],
                       "no variation reproduced the report; first variation with a collision"))
    ads = modes.get("test", {}).get("first_ads_violation")
    if gifs and ads:
        wanted.append(("gif_ads", "test", ads["v"], f"first ADS violation ({ads['codes']})"))
    for name, mode, variation, label in wanted:
        try:
            run = _run_row(store, case["scenario_hash"], mode)
            run_dir = tracks.ensure_run_dir(work, case["case_id"], run, variation)
            map_file = tracks.map_file_of(run_dir, work)
            if map_file is None:
                raise ReportError(f"{run_dir}: no map.xodr")
            actor_tracks = tracks.load_tracks(run_dir, variation)
            if not actor_tracks:
                raise ReportError(f"{run_dir}: no trace rows for variation {variation}")
            t_end = float(max(tr.t[-1] for tr in actor_tracks))
            t_impact = _impact_time(store, case["scenario_hash"], mode, variation)
            title = f"{case['case_id']} {mode} #{variation}: {label}"
            if name == "still":
                t = t_impact if t_impact is not None else t_end
                point = _impact_point(store, case["scenario_hash"], mode, variation)
                fig["still"] = data_uri(birdseye.still_png(map_file, actor_tracks, t, title, impact=point),
                                        "image/png")
                fig["still_caption"] = (f"{label} ({mode} mode, variation {variation}) at "
                                        f"{'impact' if t_impact is not None else 'the end'}, t = {t:.1f} s")
            else:
                t_key = t_impact if name == "gif_reproduce" else ads["t"]
                t_key = t_end if t_key is None else float(t_key)
                t0, t1 = max(0.0, t_key - GIF_BEFORE), min(t_end, t_key + GIF_AFTER + (0 if name == "gif_reproduce" else 1.5))
                fig[name] = data_uri(birdseye.animation_gif(map_file, actor_tracks, t0, t1, f"{mode} #{variation}"),
                                     "image/gif")
                fig[name + "_caption"] = f"{label}: {mode} mode, variation {variation}, t = {t0:.1f}-{t1:.1f} s"
        except Exception as exc:  # noqa: BLE001  (one missing picture must not sink the whole report)
            fig["notes"].append(f"{name} ({mode} #{variation}) not drawn: {type(exc).__name__}: {exc}")


def _impact_time(store: Store, scenario_hash: str, mode: str, variation: int) -> float | None:
    row = store.query("SELECT min(t) AS t FROM collisions WHERE scenario_hash=? AND mode=? AND variation=?",
                      [scenario_hash, mode, variation])
    return row[0]["t"] if row and row[0]["t"] is not None else None


def _impact_point(store: Store, scenario_hash: str, mode: str, variation: int) -> tuple[float, float] | None:
    rows = store.query("SELECT x, y FROM collisions WHERE scenario_hash=? AND mode=? AND variation=? ORDER BY t LIMIT 1",
                       [scenario_hash, mode, variation])
    return (rows[0]["x"], rows[0]["y"]) if rows else None
