"""A campaign killed with SIGKILL mid-way resumes without losing or redoing a finished chunk."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from crashscene.campaign import CampaignConfig, Store, run_campaign
from tests.campaign.fakes import fake_chunk

REPO = Path(__file__).resolve().parents[2]
DRIVER = """
import sys
from crashscene.campaign import CampaignConfig, run_campaign
from tests.campaign.fakes import fake_chunk
cases, out = sys.argv[1:3], sys.argv[3]
run_campaign(cases, out, CampaignConfig(n=40, chunk_size=4, workers=2, dsl_name="golden.yaml"), worker=fake_chunk,
             live=False)
"""


def _kill_after_chunks(cmd: list[str], env: dict, chunks: int, timeout: float = 90.0) -> list[str]:
    """Run `cmd` in its own process group, SIGKILL the group once `chunks` chunks are reported done."""
    proc = subprocess.Popen(cmd, cwd=REPO, env=env, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            start_new_session=True)
    seen: list[str] = []
    deadline = time.monotonic() + timeout
    try:
        for line in proc.stderr:
            if " done in " in line:
                seen.append(line)
            if len(seen) >= chunks or time.monotonic() > deadline:
                break
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL, "the campaign ended before it could be killed"
    return seen


def test_sigkill_then_resume_completes_with_one_row_per_variation(tmp_path, two_cases):
    env = {**os.environ, "CRASHSCENE_FAKE_SLEEP": "0.15", "PYTHONPATH": os.pathsep.join([str(REPO / "src"), str(REPO)])}
    out = tmp_path / "killed"
    seen = _kill_after_chunks([sys.executable, "-c", DRIVER, *map(str, two_cases), str(out)], env, chunks=5)
    assert len(seen) >= 5
    with Store(out) as store:
        before = store.query("SELECT scenario_hash, mode, first, session FROM chunks ORDER BY ALL")
    assert 5 <= len(before) < 40, "killed too late to test anything"

    config = CampaignConfig(n=40, chunk_size=4, workers=2, dsl_name="golden.yaml", resume=True)
    summary = run_campaign(two_cases, out, config, worker=fake_chunk, quiet=True)
    assert summary.complete and summary.chunks_skipped == len(before) and summary.chunks_run == 40 - len(before)
    with Store(out, read_only=True) as store:
        counts = store.query("SELECT scenario_hash, mode, variation, count(*) AS c FROM variations GROUP BY ALL")
        after = store.query("SELECT scenario_hash, mode, first, session FROM chunks ORDER BY ALL")
        resumed = store.query("SELECT * FROM variations ORDER BY ALL")
    assert len(counts) == 2 * 2 * 40 and all(r["c"] == 1 for r in counts)
    assert [r for r in after if r["session"] == 1] == before  # finished chunks kept, none redone

    fresh = tmp_path / "fresh"
    run_campaign(two_cases, fresh, config.model_copy(update={"resume": False}), worker=fake_chunk, quiet=True)
    with Store(fresh, read_only=True) as store:
        assert store.query("SELECT * FROM variations ORDER BY ALL") == resumed


@pytest.mark.slow
def test_cli_campaign_killed_then_resumed_with_the_real_pipeline(tmp_path, two_cases):
    """`crashscene campaign` (real extract/render/simulate/monitor) SIGKILLed mid-way, then `--resume`."""
    out, cases_dir = tmp_path / "cli", tmp_path / "cases"
    cases_dir.mkdir()
    (cases_dir / two_cases[0].name).symlink_to(two_cases[0])
    cli = [str(Path(sys.executable).with_name("crashscene")), "campaign", str(cases_dir), "-n", "8",
           "--chunk-size", "2", "--workers", "1", "--mode", "test", "--dsl", "golden.yaml", "--no-report",
           "--out", str(out)]
    seen = _kill_after_chunks(cli, dict(os.environ), chunks=1, timeout=300)
    assert len(seen) >= 1
    with Store(out) as store:
        before = store.query("SELECT scenario_hash, mode, first, session FROM chunks ORDER BY ALL")
    assert 1 <= len(before) < 4
    done = subprocess.run([*cli, "--resume", "--json"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout)
    assert summary["complete"] and summary["chunks_skipped"] == len(before)
    assert summary["chunks_run"] == 4 - len(before)
    with Store(out, read_only=True) as store:
        counts = store.query("SELECT scenario_hash, variation, count(*) AS c FROM variations GROUP BY ALL")
        after = store.query("SELECT scenario_hash, mode, first, session FROM chunks ORDER BY ALL")
    assert len(counts) == 8 and all(r["c"] == 1 for r in counts)
    assert [r for r in after if r["session"] == 1] == before
