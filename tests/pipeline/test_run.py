"""`crashscene run`: one CIREN case through the real pipeline, every artefact kept, the report written."""
from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from crashscene.campaign import CampaignConfig, Store
from crashscene.cli import app
from crashscene.pipeline.run import run_case

from tests.campaign.rows import table_rows

CASE = Path(__file__).resolve().parents[2] / "examples" / "ciren" / "120013"


@pytest.fixture(scope="module")
def ran(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run")
    result = CliRunner().invoke(app, ["run", str(CASE), "-n", "4", "--chunk-size", "2", "--workers", "2",
                                      "--out", str(out)])
    assert result.exit_code in (0, 1), result.output
    assert "Traceback" not in result.output
    return out


@pytest.mark.slow
def test_run_keeps_every_stage_artefact(ran):
    work = ran / "cases" / "120013"
    assert (work / "scenario.yaml").read_text().startswith("dsl_version: 1")
    assert json.loads((work / "extraction.json").read_text())["backend"] == "rules"
    assert (work / "render" / "scenario.scenic").exists() and (work / "render" / "map.xodr").exists()
    for mode in ("reproduce", "test"):
        chunks = sorted((work / "runs" / mode).iterdir())
        assert [c.name for c in chunks] == ["000000-000001", "000002-000003"]
        for chunk in chunks:
            for name in ("scenes.jsonl", "traces.parquet", "actors.parquet", "variations.parquet",
                         "rule_results.parquet", "verdicts.parquet", "map.xodr"):
                assert (chunk / name).exists(), chunk / name
            assert len((chunk / "scenes.jsonl").read_text().splitlines()) == 2
        second = pq.read_table(chunks[1] / "variations.parquet").column("variation").to_pylist()
        assert second == [2, 3]


@pytest.mark.slow
def test_run_stores_one_row_per_variation_and_reports(ran):
    with Store(ran, read_only=True) as store:
        rows = store.query("SELECT mode, count(*) AS c, count(DISTINCT variation) AS d FROM variations GROUP BY mode "
                           "ORDER BY mode")
    assert rows == [{"mode": "reproduce", "c": 4, "d": 4}, {"mode": "test", "c": 4, "d": 4}]
    html = (ran / "report.html").read_text()
    assert 'alt="bird&#39;s-eye view of 120013"' in html or "bird's-eye view of 120013" in html
    assert html.count("data:image/") >= 3  # PNG pictures and SVG charts, embedded
    results = json.loads((ran / "results.json").read_text())
    assert results["cases"][0]["modes"]["test"]["variations"] == 4
    assert (ran / "junit.xml").read_text().count("<testcase") == 1


@pytest.mark.slow
def test_rows_do_not_depend_on_chunking(ran, tmp_path):
    """Variation i depends only on (scenario, seed, i): one chunk of 4 gives the rows of two chunks of 2."""
    config = CampaignConfig(n=4, chunk_size=4, workers=1, modes=("test",))
    run_case(CASE, tmp_path, config, report=False, quiet=True)
    for table in ("variations", "violations", "collisions"):
        chunked = table_rows(ran, table, "WHERE mode = 'test'")
        assert chunked == table_rows(tmp_path, table, "WHERE mode = 'test'"), table
