"""monitor_run on a run directory and the `crashscene monitor` command."""
from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.monitor import MonitorError, monitor_run
from crashscene.traces import write_table
from tests.monitor.builders import tables, track
from tests.monitor.test_verdicts import REAR_END

runner = CliRunner()


@pytest.fixture
def run_dir(tmp_path):
    from crashscene.dsl import dumps

    (tmp_path / "scenario.yaml").write_text(dumps(REAR_END))
    tabs = tables({"ego": track(60, speed=15.0, lane_id="L"), "npc1": track(60, x0=25.0, speed=7.0, lane_id="L")},
                  variations=4, valid=[True, True, True, False])
    for name, table in tabs.items():
        write_table(tmp_path, name, table)
    return tmp_path


def test_monitor_run_writes_tables_and_summary(run_dir):
    result = monitor_run(run_dir)
    for name in ("rule_results.parquet", "collisions_classified.parquet", "verdicts.parquet", "monitor.json"):
        assert (run_dir / name).exists(), name
    summary = json.loads((run_dir / "monitor.json").read_text())
    assert summary["verdicts"] == {"violation": 3, "collision": 0, "pass": 0, "invalid": 1}
    assert summary["reproduced"] == 3 and summary["violations"]["CVC_21703"] == {"ego": 3}
    assert pq.read_table(run_dir / "verdicts.parquet").num_rows == 4
    assert result.summary() == {k: v for k, v in summary.items() if k != "rule_parameters"}


def test_same_input_same_bytes(run_dir):
    monitor_run(run_dir)
    names = ("monitor.json", "rule_results.parquet", "collisions_classified.parquet", "verdicts.parquet")
    first = [(run_dir / name).read_bytes() for name in names]
    monitor_run(run_dir)
    assert [(run_dir / name).read_bytes() for name in names] == first


def test_cli_json_and_rules(run_dir, tmp_path_factory):
    out = runner.invoke(app, ["monitor", str(run_dir), "--json"])
    assert out.exit_code == 0, out.output
    assert json.loads(out.stdout)["violations"]["CVC_21703"]["ego"] == 3
    rules = tmp_path_factory.mktemp("rb") / "rules.yaml"
    rules.write_text("rules:\n  CVC_21703: {enabled: false}\n")
    out = runner.invoke(app, ["monitor", str(run_dir), "--rules", str(rules), "--json"])
    assert out.exit_code == 0 and "CVC_21703" not in json.loads(out.stdout)["violations"]
    out = runner.invoke(app, ["monitor", str(run_dir)])
    assert out.exit_code == 0 and "verdicts: violation 3" in out.stdout


def test_cli_errors_are_one_line_not_tracebacks(run_dir, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("rules:\n  CVC_21703: {min_headway: -2}\n")
    out = runner.invoke(app, ["monitor", str(run_dir), "--rules", str(bad)])
    assert out.exit_code == 2 and "rules.CVC_21703.min_headway" in out.stderr and "Traceback" not in out.output
    out = runner.invoke(app, ["monitor", str(tmp_path / "missing")])
    assert out.exit_code == 2 and "not a run directory" in out.stderr


def test_missing_traces_table(run_dir):
    (run_dir / "traces.parquet").unlink()
    with pytest.raises(MonitorError, match="traces"):
        monitor_run(run_dir)


def test_rules_command_prints_an_editable_rulebook_that_loads_back(tmp_path):
    from crashscene.monitor import Rulebook, load_rulebook

    out = runner.invoke(app, ["rules"])
    assert out.exit_code == 0 and "CVC_21703:" in out.stdout and "min_headway: 2.0" in out.stdout
    path = tmp_path / "rules.yaml"
    path.write_text(out.stdout.replace("min_headway: 2.0", "min_headway: 1.2"))
    book = load_rulebook(path)
    assert book.defaults()["CVC_21703"]["min_headway"] == 1.2
    assert book.defaults()["CVC_22350"] == Rulebook().defaults()["CVC_22350"]
    out = runner.invoke(app, ["rules", "--rules", str(path)])
    assert "min_headway: 1.2" in out.stdout
