"""simulate writes criticality.parquet and puts min, p5 and median per metric in its JSON summary."""
from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest

from crashscene.dsl import load_file
from crashscene.monitor.criticality import CRITICALITY_SCHEMA, METRICS
from crashscene.pipeline.simulate import simulate_scenario

CASE = Path(__file__).resolve().parents[2] / "examples" / "ciren" / "100237" / "golden.yaml"


@pytest.mark.slow
def test_simulate_summary_has_criticality(tmp_path):
    summary = simulate_scenario(load_file(CASE), tmp_path, n=8, seed=0, mode="reproduce")
    table = pq.read_table(tmp_path / "criticality.parquet")
    assert table.schema == CRITICALITY_SCHEMA and table.num_rows == 8   # one pair per variation
    assert set(summary["criticality"]) == set(METRICS)
    ttc = summary["criticality"]["min_ttc"]
    assert set(ttc) == {"n", "min", "p5", "median"}
    assert ttc["n"] >= 1 and ttc["min"] <= ttc["p5"] <= ttc["median"]
