"""A small finished campaign (stand-in worker) to report on."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.campaign import CampaignConfig, run_campaign
from tests.report.fakes import fake_chunk_with_traces

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "ciren"


@pytest.fixture(scope="module")
def fake_campaign(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("fake-campaign")
    cases = [EXAMPLES / "120013", EXAMPLES / "100237"]
    run_campaign(cases, out, CampaignConfig(n=40, chunk_size=20, workers=1, dsl_name="golden.yaml"),
                 worker=fake_chunk_with_traces, quiet=True)
    return out
