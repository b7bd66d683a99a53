"""The report: files written, self-contained HTML, results.json and JUnit shape, and images in Chromium."""
from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET

import pytest
from PIL import Image

from crashscene.report import ReportError, write_report
from tests.report import chromium


@pytest.fixture(scope="module")
def written(fake_campaign):
    return write_report(fake_campaign, gifs=False)


def test_report_writes_html_results_and_junit(written):
    assert written.html.stat().st_size > 10_000
    results = json.loads(written.results.read_text())
    assert [c["case_id"] for c in results["cases"]] == ["100237", "120013"]
    case = results["cases"][1]
    assert set(case["modes"]) == {"reproduce", "test"}
    test = case["modes"]["test"]
    assert test["variations"] == 40 and sum(test["verdicts"].values()) == 40
    assert results["totals"]["modes"]["test"]["variations"] == 80
    suite = ET.parse(written.junit).getroot()
    cases = suite.findall("testcase")
    assert suite.get("tests") == "2" and len(cases) == 2
    assert {c.get("classname") for c in cases} == {"crashscene.100237", "crashscene.120013"}
    failing = [c for c in cases if c.find("failure") is not None]
    assert len(failing) == int(suite.get("failures"))


def test_html_is_self_contained(written):
    html = written.html.read_text()
    assert not re.search(r'(src|href)="(https?:)?//', html), "the report must not load anything from a network"
    assert "<script" not in html and "<link" not in html
    assert html.count('src="data:image/') >= 4  # sketch, verdicts, violations, scatter per case
    assert html.count('class="contacts"') == 2 and html.count('class="birdseye"') == 2
    narrative = (chromium.Path(__file__).resolve().parents[2] / "examples/ciren/120013/narrative.txt").read_text()
    assert narrative.split()[0] in html


def test_kept_traces_are_drawn_without_simulating(written):
    results = json.loads(written.results.read_text())
    for case in results["cases"]:
        assert case["modes"]["reproduce"]["shown"]["first_reproducing"]["variation"] == \
            case["modes"]["reproduce"]["first_reproducing"]
        assert case["contacts"]["variation"] == case["modes"]["reproduce"]["first_reproducing"]
        assert case["contacts"]["rows"], "the shown variation collided: its contact is listed"
    assert not list(written.html.parent.glob("cases/*/report")), "a variation was simulated again"
    html = written.html.read_text()
    assert "not drawn:" not in html
    assert html.count('class="closest"') == 2  # each case's closest call of the ADS (lowest robustness), drawn


def test_same_campaign_same_report_bytes(fake_campaign, written):
    """Apart from the generation time, the report is a function of the campaign."""
    write_report(fake_campaign, gifs=True)
    first = {p: (fake_campaign / p).read_bytes() for p in ("report.html", "results.json")}
    assert b"data:image/gif" in first["report.html"]
    again = write_report(fake_campaign, gifs=True)
    strip = re.compile(rb"generated[^<\n]*")
    for name, data in first.items():
        assert strip.sub(b"", data) == strip.sub(b"", (again.html.parent / name).read_bytes()), name


def test_missing_campaign_is_a_clear_error(tmp_path):
    with pytest.raises(ReportError, match="campaign.duckdb"):
        write_report(tmp_path)


@pytest.mark.slow
@pytest.mark.skipif(chromium.CHROMIUM is None, reason="Debian's chromium is not installed (see .ci/run)")
def test_chromium_shows_every_case_with_sketch_view_and_contacts(written, tmp_path):
    seen = chromium.probe(written.html, tmp_path)
    assert [c["id"] for c in seen["cases"]] == ["case-100237", "case-120013"]
    for case in seen["cases"]:
        assert case["sketch"] and case["view"] and case["contacts"] >= 1, case
    assert seen["resources"] == [], "the page fetched something (it must be self-contained)"
    images = seen["images"]
    assert len(images) >= 8
    broken = [i for i in images if not i["ok"]]
    assert not broken, f"images that did not decode: {broken}"
    assert any(i["alt"].startswith("crash sketch") and i["w"] > 100 for i in images)
    shot = chromium.screenshot(written.html, tmp_path / "shot.png", tmp_path)
    with Image.open(shot) as img:
        colors = img.convert("RGB").resize((320, 600)).getcolors(maxcolors=1 << 20)
    assert colors is not None and len(colors) > 200, "the page rendered as (almost) a single colour"


def test_incomplete_run_is_an_error_in_junit_and_the_report(tmp_path, monkeypatch):
    from crashscene.campaign import CampaignConfig, run_campaign
    from tests.campaign.fakes import fake_chunk
    from tests.report.conftest import EXAMPLES

    monkeypatch.setenv("CRASHSCENE_FAKE_FAIL", "4")
    run_campaign([EXAMPLES / "120013"], tmp_path, CampaignConfig(n=8, chunk_size=4, workers=1, modes=("test",),
                                                                 dsl_name="golden.yaml"),
                 worker=fake_chunk, quiet=True)
    written = write_report(tmp_path, gifs=False)
    case = json.loads(written.results.read_text())["cases"][0]
    assert case["status"] == "incomplete" and "test 4" in case["error"]
    error = ET.parse(written.junit).getroot().find("testcase/error")
    assert error is not None and error.get("type") == "IncompleteRun"
    assert "Incomplete:" in written.html.read_text()


def test_a_campaign_older_than_the_criticality_tables_still_reports(fake_campaign, tmp_path):
    import shutil

    import duckdb

    out = tmp_path / "old"
    shutil.copytree(fake_campaign, out, ignore=shutil.ignore_patterns("report.html", "results.json", "junit.xml"))
    con = duckdb.connect(str(out / "campaign.duckdb"))
    for table in ("criticality", "searches", "search_evaluations"):
        con.execute(f"DROP TABLE IF EXISTS {table}")
    con.close()
    assert write_report(out, gifs=False).html.stat().st_size > 10_000
