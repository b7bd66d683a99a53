"""campaign --search: one search per case and sampler, stored in the database, skipped when resumed."""
from __future__ import annotations

import shutil
from pathlib import Path

import duckdb
import pytest
from typer.testing import CliRunner

from crashscene.cli import app

CASE = Path(__file__).resolve().parents[2] / "examples" / "ciren" / "100237"


def test_campaign_search_bad_sampler_fails_before_work(tmp_path):
    result = CliRunner().invoke(app, ["campaign", str(tmp_path), "--search", "grid", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "--sampler 'grid' is not allowed; allowed: random, halton, ce, bo" in result.output


@pytest.mark.slow
def test_campaign_search_rows_and_resume(tmp_path):
    cases = tmp_path / "cases"
    shutil.copytree(CASE, cases / CASE.name)
    out = tmp_path / "out"
    args = ["campaign", str(cases), "--dsl", "golden.yaml", "--search", "random", "--search", "ce", "--budget", "16",
            "-n", "8", "--mode", "test", "--workers", "1", "--out", str(out), "--no-report", "--json"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    con = duckdb.connect(str(out / "campaign.duckdb"), read_only=True)
    assert con.execute("SELECT count(*) FROM runs").fetchone()[0] == 1
    assert con.execute("SELECT count(*), count(DISTINCT variation) FROM criticality").fetchone() == (8, 8)
    rows = con.execute("SELECT case_id, sampler, evaluated, failures FROM searches ORDER BY sampler").fetchall()
    assert [(r[0], r[1], r[2]) for r in rows] == [("100237", "ce", 16), ("100237", "random", 16)]
    evaluations = con.execute("SELECT count(*), count(DISTINCT variation) FROM search_evaluations "
                              "WHERE sampler = 'random'").fetchone()
    assert evaluations == (16, 16)
    failures = con.execute("SELECT count(*) FILTER (WHERE failure) FROM search_evaluations "
                           "WHERE sampler = 'random'").fetchone()[0]
    assert failures == rows[1][3]
    con.close()
    result = CliRunner().invoke(app, args + ["--resume"])
    assert result.exit_code == 0, result.output
    con = duckdb.connect(str(out / "campaign.duckdb"), read_only=True)
    assert con.execute("SELECT count(*) FROM search_evaluations").fetchone()[0] == 32   # nothing run twice
    con.close()
    from crashscene.report import write_report

    html = write_report(out, gifs=False).html.read_text()
    assert "<h3>Criticality</h3>" in html and "criticality histograms" in html
    assert "<h3>Search</h3>" in html and "search convergence" in html
    assert "<td>ce</td><td>robustness</td><td>16</td>" in html
