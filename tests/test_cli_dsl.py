"""`crashscene validate` and `crashscene schema` through the real CLI app."""
from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import yaml
from typer.testing import CliRunner

from crashscene.cli import app
from tests.conftest import CASES, EXAMPLES

runner = CliRunner()


def test_validate_all_goldens_exit_zero() -> None:
    files = [str(EXAMPLES / case / "golden.yaml") for case in CASES]
    result = runner.invoke(app, ["validate", *files])
    assert result.exit_code == 0, result.output


def test_validate_json_reports_each_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text((EXAMPLES / "120013" / "golden.yaml").read_text().replace("weather: clear", "weather: purple"))
    good = EXAMPLES / "120013" / "golden.yaml"
    result = runner.invoke(app, ["validate", "--json", str(good), str(bad)])
    assert result.exit_code == 1
    report = json.loads(result.stdout)
    assert report["valid"] is False
    assert [f["valid"] for f in report["files"]] == [True, False]
    [diag] = report["files"][1]["diagnostics"]
    assert diag["path"] == "environment.weather" and diag["line"] == 5 and "clear" in diag["allowed"]


def test_validate_missing_file_is_an_error_not_a_traceback(tmp_path: Path) -> None:
    result = runner.invoke(app, ["validate", str(tmp_path / "nope.yaml")])
    assert result.exit_code == 1
    assert "nope.yaml" in result.output and "Traceback" not in result.output


def test_schema_is_valid_json_schema_and_accepts_goldens() -> None:
    result = runner.invoke(app, ["schema"])
    assert result.exit_code == 0
    schema = json.loads(result.stdout)
    jsonschema.Draft202012Validator.check_schema(schema)
    for case in CASES:
        doc = yaml.safe_load((EXAMPLES / case / "golden.yaml").read_text())
        jsonschema.validate(doc, schema)
