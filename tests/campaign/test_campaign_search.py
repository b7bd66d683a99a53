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
    args = ["campaign", str(cases), "--dsl", "golden.yaml", "--search", "random", "--budget", "16",
            "--workers", "1", "--out", str(out), "--no-report", "--json"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    con = duckdb.connect(str(out / "campaign.duckdb"), read_only=True)
    assert con.execute("SELECT count(*) FROM runs").fetchone()[0] == 0   # -n not given: searches only
    rows = con.execute("SELECT case_id, sampler, evaluated, failures FROM searches").fetchall()
    assert [(r[0], r[1], r[2]) for r in rows] == [("100237", "random", 16)]
    evaluations = con.execute("SELECT count(*), count(DISTINCT variation) FROM search_evaluations").fetchone()
    assert evaluations == (16, 16)
    failures = con.execute("SELECT count(*) FILTER (WHERE failure) FROM search_evaluations").fetchone()[0]
    assert failures == rows[0][3]
    con.close()
    result = CliRunner().invoke(app, args + ["--resume"])
    assert result.exit_code == 0, result.output
    con = duckdb.connect(str(out / "campaign.duckdb"), read_only=True)
    assert con.execute("SELECT count(*) FROM search_evaluations").fetchone()[0] == 16   # nothing run twice
    con.close()
