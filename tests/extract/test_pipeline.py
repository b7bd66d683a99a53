"""The extraction pipeline and `crashscene extract`: backend choice, single case, batch, summary, errors."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.dsl import loads, validate
from crashscene.extract.errors import ExtractError
from crashscene.extract.pipeline import ExtractOptions, extract_batch, extract_case

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "ciren"
runner = CliRunner()


@pytest.fixture(autouse=True)
def no_api_key(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)


def narrative_case(tmp_path: Path, case: str) -> Path:
    """A copy of a real case without its sketch (no OCR: fast)."""
    folder = tmp_path / case
    folder.mkdir(parents=True)
    shutil.copy(EXAMPLES / case / "narrative.txt", folder / "narrative.txt")
    return folder


def test_backend_choice(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    assert ExtractOptions().resolved_backend() == "rules"
    assert ExtractOptions(model_path=tmp_path / "m.gguf").resolved_backend() == "local"
    assert ExtractOptions(base_url="http://127.0.0.1:11434/v1").resolved_backend() == "openai"
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")
    assert ExtractOptions().resolved_backend() == "openai"
    assert ExtractOptions(backend="rules").resolved_backend() == "rules"


def test_rules_is_the_default_without_a_model(tmp_path: Path) -> None:
    result = extract_case(narrative_case(tmp_path, "103378"))
    assert result.backend == "rules" and result.status == "ok" and result.model is None
    assert result.tokens.total == 0 and result.cost_usd == 0.0
    validate(result.scenario)
    assert result.scenario.scenario_id == "CIREN-103378"
    assert result.scenario.actors["ego"].label == "V1"


def test_real_case_with_sketch(tmp_path: Path) -> None:
    result = extract_case(EXAMPLES / "100237", backend="rules")
    assert result.status == "ok" and result.seconds > 0
    validate(result.scenario)


def test_bad_input_is_an_extract_error(tmp_path: Path) -> None:
    with pytest.raises(ExtractError, match="no such file"):
        extract_case(tmp_path / "absent")


def test_batch_writes_yaml_and_summary_and_goes_on(tmp_path: Path) -> None:
    cases = [narrative_case(tmp_path, "103378"), tmp_path / "absent", narrative_case(tmp_path, "120013")]
    seen = []
    results = extract_batch(cases, tmp_path / "out", backend="rules", progress=seen.append)
    assert [r.status for r in results] == ["ok", "error", "ok"] and len(seen) == 3
    assert "no such file" in results[1].error
    for case in ("103378", "120013"):
        scenario = loads((tmp_path / "out" / f"{case}.yaml").read_text())
        validate(scenario)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert (summary["cases"], summary["ok"], summary["failed"]) == (3, 2, 1)
    row = summary["results"][0]
    assert {"case_id", "status", "backend", "tokens", "cost_usd", "seconds", "warnings", "output"} <= set(row)
    assert row["output"].endswith("103378.yaml")


def test_openai_without_key_fails_once_for_the_batch(tmp_path: Path) -> None:
    from crashscene.extract.openai_backend import BackendError

    with pytest.raises(BackendError, match="OPENAI_API_KEY"):
        extract_batch([narrative_case(tmp_path, "103378")], tmp_path / "out", backend="openai")


# ---------------------------------------------------------------- CLI


def test_cli_single_case_to_stdout(tmp_path: Path) -> None:
    result = runner.invoke(app, ["extract", str(narrative_case(tmp_path, "103378")), "--backend", "rules"])
    assert result.exit_code == 0, result.output
    assert "dsl_version: 1" in result.stdout
    validate(loads(result.stdout[result.stdout.index("dsl_version"):result.stdout.rindex("\n") + 1]
                   .split("\n103378: ok")[0]))


def test_cli_single_case_to_file_and_json(tmp_path: Path) -> None:
    target = tmp_path / "scenario.yaml"
    result = runner.invoke(app, ["extract", str(narrative_case(tmp_path, "103378")), "-o", str(target), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["backend"] == "rules" and data["status"] == "ok" and data["output"] == str(target)
    assert data["scenario"]["actors"]["ego"]["label"] == "V1"
    validate(loads(target.read_text()))


def test_cli_batch_with_summary(tmp_path: Path) -> None:
    out = tmp_path / "out"
    cases = [str(narrative_case(tmp_path, "103378")), str(narrative_case(tmp_path, "120013"))]
    result = runner.invoke(app, ["extract", *cases, "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["ok"] == 2
    assert sorted(p.name for p in out.iterdir()) == ["103378.yaml", "120013.yaml", "summary.json"]


def test_cli_batch_exit_code_when_a_case_fails(tmp_path: Path) -> None:
    result = runner.invoke(app, ["extract", str(narrative_case(tmp_path, "103378")), str(tmp_path / "nope"),
                                 "-o", str(tmp_path / "out")])
    assert result.exit_code == 1
    assert "nope: FAILED" in result.output and "1/2 cases extracted" in result.output


@pytest.mark.parametrize("args, message", [
    (["a", "b"], "several cases need -o DIR"),
    (["a", "--backend", "gpt"], "allowed: auto, rules, openai, local"),
])
def test_cli_usage_errors(args: list[str], message: str) -> None:
    result = runner.invoke(app, ["extract", *args])
    assert result.exit_code == 2 and message in result.output


def test_cli_bad_input_has_no_traceback(tmp_path: Path) -> None:
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    result = runner.invoke(app, ["extract", str(empty)])
    assert result.exit_code == 1
    assert "error:" in result.output and "empty" in result.output and "Traceback" not in result.output


def test_cli_openai_backend_through_base_url(tmp_path: Path) -> None:
    from crashscene.dsl import load_file
    from crashscene.extract.llm_schema import from_scenario
    from tests.extract.fake_openai import FakeOpenAI, reply

    good = from_scenario(load_file(EXAMPLES / "103378" / "golden.yaml")).model_dump(mode="json")
    case = narrative_case(tmp_path, "103378")
    shutil.copy(EXAMPLES / "103378" / "sketch.jpg", case / "sketch.jpg")
    with FakeOpenAI([reply(good)]) as server:
        result = runner.invoke(app, ["extract", str(case), "--base-url", server.base_url, "--model", "llama3:8b",
                                     "--no-image", "--no-revise", "--json"])
        request = server.requests[0]
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["backend"] == "openai" and data["model"] == "llama3:8b" and data["cost_usd"] is None
    assert data["scenario"]["actors"]["ego"]["behavior"] == "cross_centerline"
    assert request["model"] == "llama3:8b"
    user = request["messages"][-1]["content"]
    assert isinstance(user, str) and "speed limit 45 mph" in user  # no image part, the sketch facts instead
