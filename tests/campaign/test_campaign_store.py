"""Scheduler, store and resume with the real DuckDB and a deterministic stand-in worker."""
from __future__ import annotations

import pytest

from crashscene.campaign import CampaignConfig, CampaignError, Store, plan_chunks, run_campaign
from tests.campaign.fakes import fake_chunk
from tests.campaign.rows import table_rows


def _rows(out, table="variations"):
    return table_rows(out, table)


@pytest.mark.parametrize("n,size", [(1, 1), (10, 3), (10, 10), (10, 250), (2000, 250)])
def test_plan_chunks_covers_range_exactly_once(n, size):
    chunks = plan_chunks(n, size)
    covered = [i for first, count in chunks for i in range(first, first + count)]
    assert covered == list(range(n))
    assert all(0 < count <= size for _, count in chunks)


def test_campaign_stores_one_row_per_variation(tmp_path, two_cases):
    config = CampaignConfig(n=23, chunk_size=5, workers=1, dsl_name="golden.yaml")
    summary = run_campaign(two_cases, tmp_path, config, worker=fake_chunk, quiet=True)
    assert summary.complete and summary.chunks_run == 2 * 2 * 5 and summary.variations_run == 92
    with Store(tmp_path, read_only=True) as store:
        per_key = store.query("SELECT scenario_hash, mode, count(*) AS c, count(DISTINCT variation) AS d, "
                              "min(variation) AS lo, max(variation) AS hi FROM variations GROUP BY ALL")
        assert len(per_key) == 4
        assert all((r["c"], r["d"], r["lo"], r["hi"]) == (23, 23, 0, 22) for r in per_key)
        cases = store.query("SELECT case_id, status FROM cases ORDER BY case_id")
    assert cases == [{"case_id": "100237", "status": "ok"}, {"case_id": "120013", "status": "ok"}]
    run = next(r for r in summary.runs if r.case_id == "120013" and r.mode == "test")
    assert sum(run.verdicts.values()) == 23 and run.valid == 23 - run.verdicts.get("invalid", 0)


def test_rows_do_not_depend_on_chunking_or_workers(tmp_path, two_cases):
    a = run_campaign(two_cases, tmp_path / "a", CampaignConfig(n=17, chunk_size=4, workers=2, dsl_name="golden.yaml"),
                     worker=fake_chunk, quiet=True)
    b = run_campaign(two_cases, tmp_path / "b", CampaignConfig(n=17, chunk_size=17, workers=1, dsl_name="golden.yaml"),
                     worker=fake_chunk, quiet=True)
    assert a.complete and b.complete
    for table in ("variations", "violations", "collisions"):
        assert _rows(tmp_path / "a", table) == _rows(tmp_path / "b", table)


def test_existing_campaign_needs_resume(tmp_path, two_cases):
    config = CampaignConfig(n=4, chunk_size=2, workers=1, dsl_name="golden.yaml")
    run_campaign(two_cases, tmp_path, config, worker=fake_chunk, quiet=True)
    with pytest.raises(CampaignError, match="--resume"):
        run_campaign(two_cases, tmp_path, config, worker=fake_chunk, quiet=True)
    again = run_campaign(two_cases, tmp_path, config.model_copy(update={"resume": True}), worker=fake_chunk, quiet=True)
    assert again.chunks_run == 0 and again.chunks_skipped == 8 and again.complete
    with pytest.raises(CampaignError, match="-n 4"):
        run_campaign(two_cases, tmp_path, config.model_copy(update={"resume": True, "n": 6}), worker=fake_chunk,
                     quiet=True)


def test_failed_chunk_is_recorded_and_retried_on_resume(tmp_path, two_cases, monkeypatch):
    config = CampaignConfig(n=9, chunk_size=3, workers=1, dsl_name="golden.yaml", modes=("test",))
    monkeypatch.setenv("CRASHSCENE_FAKE_FAIL", "3")
    first = run_campaign(two_cases, tmp_path, config, worker=fake_chunk, quiet=True)
    assert not first.complete and first.chunks_failed == 2 and first.chunks_run == 4
    with Store(tmp_path, read_only=True) as store:
        errors = store.query("SELECT first, error FROM chunk_errors")
    assert len(errors) == 2 and all(e["first"] == 3 and "injected failure" in e["error"] for e in errors)
    monkeypatch.delenv("CRASHSCENE_FAKE_FAIL")
    second = run_campaign(two_cases, tmp_path, config.model_copy(update={"resume": True}), worker=fake_chunk, quiet=True)
    assert second.complete and second.chunks_run == 2 and second.chunks_skipped == 4
    assert all(r.variations == 9 for r in second.runs)


def test_bad_case_is_reported_and_others_run(tmp_path, two_cases):
    bad = tmp_path / "cases" / "broken"
    bad.mkdir(parents=True)
    (bad / "golden.yaml").write_text("environment: {weather: sunny_with_lasers}\n", encoding="utf-8")
    third = two_cases[0].parent / "3-C1-2017-001"
    # four cases: prepared in the process pool
    summary = run_campaign([*two_cases, third, bad], tmp_path / "out",
                           CampaignConfig(n=2, workers=2, dsl_name="golden.yaml"), worker=fake_chunk, quiet=True)
    assert not summary.complete
    assert [c["case_id"] for c in summary.cases] == ["120013", "100237", "3-C1-2017-001", "broken"]
    broken = summary.cases[-1]
    assert broken["status"] == "error" and "golden.yaml" in broken["error"] and "weather" in broken["error"]
    assert {r.case_id for r in summary.runs} == {"120013", "100237", "3-C1-2017-001"}


def test_worker_rows_outside_its_chunk_fail_that_chunk(tmp_path, two_cases):
    summary = run_campaign(two_cases[:1], tmp_path, CampaignConfig(n=4, chunk_size=2, workers=1, modes=("test",),
                                                                     dsl_name="golden.yaml"),
                           worker=shifted_chunk, quiet=True)
    assert summary.chunks_failed == 2 and summary.chunks_run == 0
    with Store(tmp_path, read_only=True) as store:
        assert store.query("SELECT count(*) AS c FROM variations")[0]["c"] == 0
        assert "outside" in store.query("SELECT error FROM chunk_errors LIMIT 1")[0]["error"]


def shifted_chunk(task):
    """A broken worker: returns the rows of the next chunk."""
    return fake_chunk(task.model_copy(update={"first": task.first + task.count}))


def test_a_database_from_before_the_crash_sequence_gains_its_columns(tmp_path):
    import duckdb

    from crashscene.campaign.store import DB_NAME

    old = duckdb.connect(str(tmp_path / DB_NAME))
    old.execute("CREATE TABLE variations (scenario_hash VARCHAR, seed BIGINT, mode VARCHAR, variation INTEGER, "
                "valid BOOLEAN, invalid_reason VARCHAR, verdict VARCHAR, reproduced BOOLEAN, collided BOOLEAN, "
                "params VARCHAR, PRIMARY KEY (scenario_hash, seed, mode, variation))")
    old.execute("INSERT INTO variations VALUES ('h', 1, 'reproduce', 0, true, null, 'pass', true, false, '{}')")
    old.close()
    with Store(tmp_path) as store:
        [row] = store.query("SELECT * FROM variations")
    assert row["reproduced"] is True and (row["first_contact"], row["sequence"], row["area_match"]) == (None,) * 3
