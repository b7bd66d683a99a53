"""`crashscene campaign` / `report`: clear errors and exit codes, never a traceback."""
from __future__ import annotations

from typer.testing import CliRunner

from crashscene.cli import app

runner = CliRunner()


def test_missing_cases_dir_is_a_clear_error(tmp_path):
    result = runner.invoke(app, ["campaign", str(tmp_path / "nope"), "-n", "2", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "no such folder" in result.output and "Traceback" not in result.output


def test_folder_without_cases_names_what_it_expected(tmp_path):
    (tmp_path / "cases" / "x").mkdir(parents=True)
    result = runner.invoke(app, ["campaign", str(tmp_path / "cases"), "-n", "2", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "narrative.txt" in result.output


def test_bad_option_values_are_named(tmp_path, two_cases):
    cases = str(two_cases[0].parent)
    for args, expected in ((["--mode", "fast"], "--mode"), (["--map", "osm"], "--map"), (["-n", "0"], "-n 0"),
                           (["--engine", "spark"], "spark"), (["--address", "1.2.3.4:6379"], "--address"),
                           (["--rules", str(tmp_path / "none.yaml")], "--rules"),
                           (["--extractor", "gpt5"], "--extractor"), (["--simulator", "unity"], "--simulator")):
        result = runner.invoke(app, ["campaign", cases, "--out", str(tmp_path / "o"), *args])
        assert result.exit_code == 2, args
        assert expected in result.output, (args, result.output)


def test_report_of_an_empty_folder_is_a_clear_error(tmp_path):
    result = runner.invoke(app, ["report", str(tmp_path)])
    assert result.exit_code == 2 and "campaign.duckdb" in result.output


def test_run_refuses_a_folder_of_cases(tmp_path, two_cases):
    result = runner.invoke(app, ["run", str(two_cases[0].parent), "-n", "2", "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "crashscene campaign" in result.output
