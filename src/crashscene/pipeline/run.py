"""`crashscene run`: one case through the whole pipeline, offline by default, every artefact kept.

report -> extract -> validate -> render -> sample -> simulate -> monitor -> report.
It is a one-case campaign that keeps its traces, so its output folder has the
same layout as a campaign's and `crashscene report DIR` works on both:

    DIR/campaign.duckdb                      runs, variations, violations, collisions, chunks
    DIR/cases/<case>/scenario.yaml           the extracted (or given) DSL
    DIR/cases/<case>/extraction.json         extraction backend, timing, tokens
    DIR/cases/<case>/render/                 scenario.scenic, map.xodr
    DIR/cases/<case>/runs/<mode>/<chunk>/    scenes.jsonl, traces/actors/collisions/variations .parquet,
                                             monitor tables, summary.json
    DIR/report.html, results.json, junit.xml
"""
from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel

from crashscene.campaign.cases import discover_cases
from crashscene.campaign.errors import CampaignError
from crashscene.campaign.runner import CampaignConfig, CampaignSummary, run_campaign


class RunResult(BaseModel):
    summary: CampaignSummary
    report: str | None = None  # path of report.html


def run_case(case: str | Path, out_dir: str | Path, config: CampaignConfig, report: bool = True,
             live: bool | None = None, quiet: bool = False) -> RunResult:
    """Run one case (a report folder or a DSL file) end to end into `out_dir`."""
    paths = discover_cases(case, config.dsl_name)
    if len(paths) != 1:
        raise CampaignError(f"{case}: holds {len(paths)} cases; `run` takes one case folder or scenario file "
                            "(use `crashscene campaign` for a folder of cases)")
    config = config.model_copy(update={"keep_traces": True})
    summary = run_campaign(paths, out_dir, config, live=live, quiet=quiet)
    html = None
    if report and any(r.variations for r in summary.runs):
        from crashscene.report import write_report

        html = str(write_report(out_dir).html)
    return RunResult(summary=summary, report=html)
