"""Gather a run/campaign folder's results and write report.html, results.json and junit.xml.

The HTML is self-contained: every image (sketch, bird's-eye still, charts,
GIFs) is embedded as a data URI and the styles are inline, so the file opens
offline and can be mailed or archived as one file.
"""
from __future__ import annotations

import base64
import io
import json
import multiprocessing as mp
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import jinja2
from PIL import Image
from pydantic import BaseModel

from crashscene.campaign.errors import CampaignError
from crashscene.campaign.runner import summarize_runs
from crashscene.campaign.store import DB_NAME, Store
from crashscene.report import charts, contacts, search_section
from crashscene.report.errors import ReportError
from crashscene.report.shots import Shot, draw_shots, pick_still, plan_shots, shown_variations
from crashscene.report.junit import junit_xml

SKETCH_MAX_PX = 900  # longest side of the embedded sketch
PARALLEL_DRAW_MIN = 3  # cases from which pictures are drawn in a process pool (each pays ~3 s of imports)
DRAW_WORKERS = 2
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
    cases, figures, shots, jobs = [], {}, {}, {}
    for row in case_rows:
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
        missing = {m: r["n"] - r["variations"] for m, r in case["modes"].items() if r["variations"] < r["n"]}
        if case["status"] == "ok" and missing:
            case["status"] = "incomplete"
            case["error"] = ("variations not stored (failed or unfinished chunks; see table chunk_errors, rerun with "
                             "--resume): " + ", ".join(f"{m} {k}" for m, k in missing.items()))
        cases.append(case)
        figures[case_id], jobs[case_id] = _case_figures(store, case, scenario_text)
        shots[case_id] = plan_shots(store, out, case, gifs)
        case["contacts"] = _contacts(store, case, scenario_text)
    for case_id, drawn in _draw_all(shots, jobs, progress):
        notes = figures[case_id]["notes"] + drawn.pop("notes")
        figures[case_id].update(drawn, notes=notes)
    return cases, figures


def _draw_all(shots: dict[str, list[Shot]], jobs: dict[str, CaseCharts], progress: Callable[[str], None] | None):
    """(case_id, figures) per case, drawn in a process pool when there are several cases."""
    todo = list(jobs)
    total = len(todo)
    if total < PARALLEL_DRAW_MIN:
        for k, case_id in enumerate(todo, 1):
            if progress is not None:
                progress(f"report: drawing case {case_id} ({k}/{total})")
            yield case_id, draw_case(shots[case_id], jobs[case_id])
        return
    workers = min(DRAW_WORKERS, os.cpu_count() or 1)
    with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                             initializer=_quiet_worker) as pool:
        futures = {pool.submit(draw_case, shots[case_id], jobs[case_id]): case_id for case_id in todo}
        for k, fut in enumerate(as_completed(futures), 1):
            case_id = futures[fut]
            if progress is not None:
                progress(f"report: drew case {case_id} ({k}/{total})")
            try:
                yield case_id, fut.result()
            except Exception as exc:  # noqa: BLE001  (a dead drawing process costs pictures, not the report)
                yield case_id, {"notes": [f"pictures not drawn: {type(exc).__name__}: {exc}"]}


def _quiet_worker() -> None:
    from crashscene.campaign.engines import quiet_scenic_warnings

    quiet_scenic_warnings()


def _scenario_fields(text: str | None) -> dict:
    if not text:
        return {"scenario_id": None, "summary": None, "oracle": []}
    import yaml

    raw = yaml.safe_load(text) or {}
    return {"scenario_id": raw.get("scenario_id"), "summary": raw.get("summary"),
            "oracle": [{k: e.get(k) for k in ("code", "violation", "actor")} for e in raw.get("oracle") or []]}


def _columns(store: Store, table: str) -> set[str]:
    return {r["column_name"] for r in store.query(
        "SELECT column_name FROM information_schema.columns WHERE table_name=?", [table])}


def _contacts(store: Store, case: dict, scenario_text: str | None) -> dict:
    """The contact table of the case's main variation (the one its still shows)."""
    import yaml

    raw = (yaml.safe_load(scenario_text) or {}) if scenario_text else {}
    reported = contacts.reported_contacts(raw)
    still = pick_still(case["modes"])
    if still is None:
        return {"reported": reported, "rows": contacts.contact_table(reported, [], {}), "mode": None,
                "variation": None}
    mode, variation, why = still
    cols = _columns(store, "collisions")
    extra = [c for c in ("area_a", "area_b", "delta_v_a", "delta_v_b", "contact_index") if c in cols]
    order = "contact_index, t" if "contact_index" in cols else "t"
    sim = store.query(f"SELECT t, actor_a, actor_b, collision_class AS class{''.join(', ' + c for c in extra)} "
                      f"FROM collisions WHERE scenario_hash=? AND mode=? AND variation=? "
                      f"ORDER BY {order}, actor_a, actor_b", [case["scenario_hash"], mode, variation])
    return {"reported": reported, "rows": contacts.contact_table(reported, sim, contacts.labels_of(raw)),
            "mode": mode, "variation": variation, "why": why}


def _firsts(store: Store, run) -> dict:
    """The first reproducing variation, first ADS violation and first collision among a run's valid variations
    (None when absent; the same choices as `campaign.keep`, whose traces are kept), and the kept `shown` ones."""
    where = "scenario_hash=? AND mode=?"
    key = [run.scenario_hash, run.mode]
    valid = f"AND variation IN (SELECT variation FROM variations WHERE {where} AND valid)"
    first_rep = store.query(f"SELECT min(variation) AS v FROM variations WHERE {where} AND valid AND reproduced",
                            key)[0]["v"]
    ads = store.query(f"SELECT variation AS v, min(t_first) AS t, string_agg(DISTINCT code, ', ' ORDER BY code) "
                      f"AS codes FROM violations WHERE {where} AND is_ads {valid} GROUP BY variation "
                      "ORDER BY variation LIMIT 1", key + key)
    coll = store.query(f"SELECT variation AS v, min(t) AS t FROM collisions WHERE {where} {valid} GROUP BY variation "
                       "ORDER BY variation LIMIT 1", key + key)
    seed = store.query(f"SELECT min(seed) AS s FROM runs WHERE {where}", key)[0]["s"]
    first = store.query(f"SELECT min(variation) AS v FROM variations WHERE {where} AND valid", key)[0]["v"]
    return {"first_reproducing": first_rep,
            "first_ads_violation": ads[0] if ads else None,
            "first_collision": coll[0] if coll else None,
            "first_variation": first,
            "shown": shown_variations(store, run.scenario_hash, seed, run.mode)}


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
                    from crashscene.extract.case_input import read_narrative

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


class CaseCharts(BaseModel):
    """What one case's charts and sketch are drawn from (gathered from the database by the driver)."""

    case_dir: str
    violations: dict[str, dict[str, dict[str, int]]] = {}
    variations: dict[str, int] = {}
    verdicts: dict[str, dict[str, int]] = {}
    labels: dict[str, str] = {}
    scatter_rows: dict[str, list[dict]] = {}


def _case_figures(store: Store, case: dict, scenario_text: str | None) -> tuple[dict, CaseCharts]:
    """The case's text figures (narrative, DSL) and the inputs of its charts."""
    fig: dict = {"narrative": _narrative(Path(case["case_dir"] or "")), "dsl": scenario_text, "notes": []}
    if {"criticality", "searches"} <= {r["table_name"] for r in store.query(
            "SELECT table_name FROM information_schema.tables")}:  # a campaign older than them has neither
        fig.update(search_section.case_figures(store, case))   # criticality and search sections
    modes = case["modes"]
    job = CaseCharts(case_dir=case["case_dir"] or "")
    if not modes:
        return fig, job
    import yaml

    raw = (yaml.safe_load(scenario_text) or {}) if scenario_text else {}
    job.violations = {m: r["violations"] for m, r in modes.items()}
    job.variations = {m: r["variations"] for m, r in modes.items()}
    job.verdicts = {m: r["verdicts"] for m, r in modes.items()}
    job.labels = contacts.labels_of(raw)
    for mode in modes:
        rows = store.query("SELECT verdict, params FROM variations WHERE scenario_hash=? AND mode=? ORDER BY variation",
                           [case["scenario_hash"], mode])
        job.scatter_rows[mode] = [{"verdict": r["verdict"], "params": json.loads(r["params"] or "{}")} for r in rows]
    return fig, job


def draw_case(shots: list[Shot], job: CaseCharts) -> dict:
    """Every image of one case as data URIs (sketch, charts, bird's-eye pictures), plus notes on what failed."""
    fig = draw_shots(shots)
    fig["sketch"] = _sketch(Path(job.case_dir))
    if not job.verdicts:
        return fig
    png = charts.violations_bar(job.violations, job.variations, job.labels)
    fig["violations"] = data_uri(png, charts.MIME) if png else None
    png = charts.verdict_bar(job.verdicts)
    fig["verdicts"] = data_uri(png, charts.MIME) if png else None
    fig["scatter"] = {}
    for mode, rows in job.scatter_rows.items():
        png = charts.failing_scatter(rows, f"failing variations ({mode})")
        if png:
            fig["scatter"][mode] = data_uri(png, charts.MIME)
    return fig
