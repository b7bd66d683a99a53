"""Bad input to `crashscene export`: clear errors (file, field, value, allowed), and nothing exported is lost."""
from __future__ import annotations

import json
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.export import ExportError
from crashscene.export.pipeline import RUN_FILES, export_scenario, parse_variations
from crashscene.export.xosc_common import write_atomic
from crashscene.traces import VARIATION_SCHEMA

from tests.conftest import EXAMPLES

CASE = EXAMPLES / "100237" / "golden.yaml"


def fake_run(tmp_path: Path, scenario_hash: str = "0" * 16, map_mode: str = "generated") -> Path:
    run = tmp_path / "run"
    run.mkdir()
    for name in RUN_FILES:
        (run / name).write_text("")
    (run / "render.json").write_text(json.dumps({"map_mode": map_mode}))
    table = pa.table({"variation": [0, 1], "seed": [0, 0], "scenario_hash": [scenario_hash] * 2,
                      "valid": [True, False], "invalid_reason": [None, "no route"], "dt": [0.1, 0.1],
                      "steps": [10, 0], "params": ["{}", "{}"]}, schema=VARIATION_SCHEMA)
    pq.write_table(table, run / "variations.parquet")
    return run


def real_hash() -> str:
    from crashscene.dsl import load_file
    from crashscene.render.plan import scenario_hash

    return scenario_hash(load_file(CASE), map_mode="generated", town="")


def test_corrupt_scenario_names_the_file_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(CASE.read_text(encoding="utf-8").replace("road_type:", "road_type: spiral\n  old_road_type:", 1))
    with pytest.raises(ExportError) as err:
        export_scenario(bad, tmp_path / "out")
    assert str(bad) in str(err.value) and "road_type" in str(err.value)
    assert not (tmp_path / "out").exists()


def test_missing_run_files_are_listed(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "scenario.scenic").write_text("")
    with pytest.raises(ExportError, match=r"missing map\.xodr, render\.json, scenes\.jsonl, traces\.parquet"):
        export_scenario(CASE, tmp_path / "out", run_dir=run)
    with pytest.raises(ExportError, match="not a directory"):
        export_scenario(CASE, tmp_path / "out", run_dir=tmp_path / "nowhere")


def test_run_of_another_scenario_is_refused(tmp_path):
    run = fake_run(tmp_path)
    with pytest.raises(ExportError, match=r"scenario_hash = 0{16}, but .*golden\.yaml hashes to [0-9a-f]{16}"):
        export_scenario(CASE, tmp_path / "out", run_dir=run)


def test_carla_town_runs_are_unsupported(tmp_path):
    run = fake_run(tmp_path, map_mode="carla")
    with pytest.raises(ExportError, match=r"map_mode = 'carla' is not supported; allowed: 'generated'"):
        export_scenario(CASE, tmp_path / "out", run_dir=run)


def test_corrupt_scene_line_names_file_and_line(tmp_path):
    run = fake_run(tmp_path, real_hash())
    (run / "scenes.jsonl").write_text('{"index": 0}\n')
    with pytest.raises(ExportError, match=r"scenes\.jsonl: line 1: not a sampled scene"):
        export_scenario(CASE, tmp_path / "out", run_dir=run)


def test_variation_choice_is_checked():
    assert parse_variations("17,3,3") == [3, 17]
    for bad in ("3,x", "", "-1"):
        with pytest.raises(ExportError, match="allowed: comma-separated"):
            parse_variations(bad)
    with pytest.raises(ExportError, match="need --from"):
        export_scenario(CASE, Path("unused"), variations=[3])
    with pytest.raises(ExportError, match="exclude each other"):
        export_scenario(CASE, Path("unused"), run_dir=Path("unused"), variations=[3], failing=True)


class _Exploding:
    """A document whose writer dies half-way."""

    def write_xml(self, filename: str) -> None:
        Path(filename).write_text("<OpenSCENARIO><partial")
        raise OSError("disk full")


def test_a_failed_write_keeps_the_previous_file(tmp_path):
    target = tmp_path / "scenario.xosc"
    target.write_text("previous export")
    with pytest.raises(OSError, match="disk full"):
        write_atomic(_Exploding(), target)
    assert target.read_text() == "previous export"
    assert [p.name for p in tmp_path.iterdir()] == ["scenario.xosc"]  # no temporary left behind


def test_a_failed_export_leaves_the_previous_export_intact(tmp_path):
    out = tmp_path / "out"
    (out / "variations").mkdir(parents=True)
    before = {"scenario.xosc": "s", "distribution.xosc": "d", "map.xodr": "m", "variations/3.xosc": "v"}
    for name, text in before.items():
        (out / name).write_text(text)
    run = fake_run(tmp_path)
    with pytest.raises(ExportError):
        export_scenario(CASE, out, run_dir=run)
    assert {str(p.relative_to(out)): p.read_text() for p in out.rglob("*") if p.is_file()} == before


def test_cli_reports_the_error_and_exits_1(tmp_path):
    result = CliRunner().invoke(app, ["export", str(tmp_path / "absent.yaml"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert "export failed" in result.output and "absent.yaml" in result.output
