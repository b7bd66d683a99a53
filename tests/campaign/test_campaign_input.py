"""A careless or hostile campaign user: options checked once before any work, resumes that would mix results
refused, a damaged database named as such, backends as plug-ins that reach the worker processes."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.campaign import CampaignConfig, CampaignError, Store, run_campaign
from crashscene.campaign.model import SimOptions
from crashscene.campaign.runner import _SIM_FLAGS
from crashscene.cli import app
from crashscene.cli.campaign_commands import build_config
from crashscene.simulate import register_backend

from tests.campaign.fakes import fake_chunk

runner = CliRunner()


def _config(**sim) -> CampaignConfig:
    return CampaignConfig(n=4, chunk_size=2, workers=1, dsl_name="golden.yaml", sim=SimOptions(**sim))


def _rules(tmp_path: Path, text: str, name: str = "rules.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_every_simulation_option_is_compared_on_resume():
    assert set(SimOptions.model_fields) == set(_SIM_FLAGS) | {"rules_file", "backend_target"}


@pytest.mark.parametrize("change, flag", [
    ({"backend": "newtonian"}, "--backend embedded (now newtonian)"),
    ({"ego_role": "npc1"}, "--ego ego (now npc1)"),
    ({"map_mode": "carla"}, "--map generated (now carla)"),
    ({"horizon": 10.0}, "--horizon 20.0 (now 10.0)"),
    ({"ads": "my.ads:Driver"}, "--ads (not set) (now my.ads:Driver)"),
])
def test_resume_with_other_options_is_refused_naming_what_differs(tmp_path, two_cases, change, flag):
    run_campaign(two_cases, tmp_path, _config(), worker=fake_chunk, quiet=True)
    resumed = _config(**change).model_copy(update={"resume": True})
    with pytest.raises(CampaignError) as err:
        run_campaign(two_cases, tmp_path, resumed, worker=fake_chunk, quiet=True)
    assert flag in str(err.value) and "new --out" in str(err.value)


def test_resume_with_a_rulebook_of_other_contents_is_refused(tmp_path, two_cases):
    rules = _rules(tmp_path, "rules:\n  CVC_21703: {min_headway: 1.5}\n")
    args = (4, 0, "both", "local", 1, None, False, 2, "rules", "golden.yaml", "embedded", "ego", "generated", None)
    first = build_config(*args, rules)
    run_campaign(two_cases, tmp_path / "out", first, worker=fake_chunk, quiet=True)
    same = build_config(*args, rules).model_copy(update={"resume": True})
    assert run_campaign(two_cases, tmp_path / "out", same, worker=fake_chunk, quiet=True).chunks_skipped == 8
    rules.write_text("rules:\n  CVC_21703: {min_headway: 3.0}\n", encoding="utf-8")  # same path, other contents
    with pytest.raises(CampaignError, match=r"--rules \(sha256 of its contents\)"):
        run_campaign(two_cases, tmp_path / "out", build_config(*args, rules).model_copy(update={"resume": True}),
                     worker=fake_chunk, quiet=True)
    with pytest.raises(CampaignError, match=r"--rules .* \(now \(not set\)\)"):
        run_campaign(two_cases, tmp_path / "out", build_config(*args).model_copy(update={"resume": True}),
                     worker=fake_chunk, quiet=True)


@pytest.mark.parametrize("damage", ["truncate", "overwrite", "header"])
def test_a_damaged_database_is_named_with_what_can_be_recovered(tmp_path, two_cases, damage):
    run_campaign(two_cases, tmp_path, _config(), worker=fake_chunk, quiet=True)
    db = tmp_path / "campaign.duckdb"
    size = db.stat().st_size
    with open(db, "r+b") as fh:
        if damage == "truncate":
            fh.truncate(size // 2)
        else:
            fh.seek(0 if damage == "header" else size // 3)
            fh.write(os.urandom(min(size // 2, 200_000)))
    for args in (["report", str(tmp_path)],
                 ["campaign", str(two_cases[0].parent), "-n", "4", "--chunk-size", "2", "--dsl", "golden.yaml",
                  "--out", str(tmp_path), "--resume", "--no-report"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 2, (args, result.output)
        assert "damaged" in result.output and str(db) in result.output, result.output
        assert "another campaign" not in result.output and "Traceback" not in result.output
        assert "move the damaged file aside" in result.output and str(tmp_path / "cases") in result.output


def test_a_bad_rules_file_is_refused_before_any_case_is_prepared(tmp_path, two_cases):
    cases = str(two_cases[0].parent)
    binary = tmp_path / "rules.bin"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe\x00")
    for rules, words in ((binary, ["not UTF-8"]),
                         (_rules(tmp_path, "rules:\n  CVC_99999: {}\n"), ["rules.CVC_99999", "unknown rule code"]),
                         (_rules(tmp_path, "imports: [os]\n", "imp.yaml"), ["--allow-imports"])):
        out = tmp_path / f"out-{rules.name}"
        result = runner.invoke(app, ["campaign", cases, "-n", "2", "--out", str(out), "--rules", str(rules)])
        assert result.exit_code == 2, result.output
        assert str(rules) in result.output and all(w in result.output for w in words), result.output
        assert not out.exists()  # nothing extracted, rendered or stored


def test_resume_after_a_case_changed_shows_only_its_current_run(tmp_path):
    cases = tmp_path / "cases"
    cases.mkdir()
    golden = Path(__file__).resolve().parents[2] / "examples" / "ciren"
    shutil.copy(golden / "120013" / "golden.yaml", cases / "a.yaml")
    shutil.copy(golden / "100237" / "golden.yaml", cases / "b.yaml")
    config = CampaignConfig(n=4, chunk_size=2, workers=1)
    first = run_campaign(cases, tmp_path / "out", config, worker=fake_chunk, quiet=True)
    assert sorted((r.case_id, r.mode) for r in first.runs) == [(c, m) for c in "ab" for m in ("reproduce", "test")]
    text = (cases / "a.yaml").read_text(encoding="utf-8")
    (cases / "a.yaml").write_text(text.replace("speed_limit_mph: 55", "speed_limit_mph: 50"), encoding="utf-8")
    resumed = run_campaign(cases, tmp_path / "out", config.model_copy(update={"resume": True}), worker=fake_chunk,
                           quiet=True)
    assert sorted((r.case_id, r.mode) for r in resumed.runs) == [(c, m) for c in "ab" for m in ("reproduce", "test")]
    assert resumed.chunks_run == 4 and resumed.chunks_skipped == 4  # a's new scenario runs, b's is kept
    with Store(tmp_path / "out", read_only=True) as store:
        hashes = {r["scenario_hash"] for r in store.query("SELECT scenario_hash FROM cases WHERE case_id = 'a'")}
    assert {r.scenario_hash for r in resumed.runs if r.case_id == "a"} == hashes


def test_run_and_campaign_accept_backend_and_keep_simulator(tmp_path, two_cases):
    for command in ("run", "campaign"):
        for flag in ("--backend", "--simulator"):
            result = runner.invoke(app, [command, str(two_cases[0]), "-n", "1", "--out", str(tmp_path / "o"),
                                         flag, "unity"])
            assert result.exit_code == 2 and "unknown backend 'unity'" in result.output, result.output


@pytest.mark.slow
def test_a_backend_registered_outside_the_package_runs_in_a_two_worker_campaign(tmp_path, two_cases, monkeypatch):
    marks = tmp_path / "marks.txt"
    monkeypatch.setenv("CRASHSCENE_PLUGIN_MARKS", str(marks))  # inherited by the spawned workers
    register_backend("marked", "tests.campaign.plugin_backend:MarkedSimulator")
    config = build_config(4, 7, "reproduce", "local", 2, None, False, 2, "rules", "golden.yaml", "marked", "ego",
                          "generated", None)
    assert config.sim.backend == "marked"
    summary = run_campaign([two_cases[0]], tmp_path / "out", config.model_copy(update={"keep_traces": True}),
                           quiet=True)
    assert summary.complete and summary.chunks_run == 2 and summary.workers == 2, summary.failures
    assert summary.runs[0].variations == 4
    lines = marks.read_text().split()
    pids = {int(pid) for pid in lines[::2]}
    assert os.getpid() not in pids and sum(int(n) for n in lines[1::2]) == 4  # the workers ran the plug-in
    # each chunk copied the case's render instead of rendering again
    runs = sorted((tmp_path / "out" / "cases" / two_cases[0].name / "runs" / "reproduce").iterdir())
    render = tmp_path / "out" / "cases" / two_cases[0].name / "render"
    assert len(runs) == 2
    for run in runs:
        assert (run / "scenario.scenic").read_bytes() == (render / "scenario.scenic").read_bytes()
        assert '"rendered_from"' in (run / "summary.json").read_text()


@pytest.mark.slow
def test_a_chunk_with_rules_is_monitored_once_with_that_rulebook(tmp_path, monkeypatch):
    import crashscene.monitor as monitor
    from crashscene.campaign.model import ChunkTask
    from crashscene.campaign.worker import simulate_chunk
    from crashscene.dsl import dumps, load_file

    calls = []
    real = monitor.evaluate

    def counting(tables, scenario, rulebook=None, **kw):
        calls.append(rulebook)
        return real(tables, scenario, rulebook, **kw)

    monkeypatch.setattr(monitor, "evaluate", counting)
    rules = _rules(tmp_path, "rules:\n  CVC_22350: {enabled: false}\n")
    golden = Path(__file__).resolve().parents[2] / "examples" / "ciren" / "120013" / "golden.yaml"
    task = ChunkTask(case_id="120013", scenario_yaml=dumps(load_file(golden)), scenario_hash="h", seed=0,
                     mode="reproduce", first=0, count=2, options=SimOptions(rules_file=str(rules)))
    result = simulate_chunk(task)
    assert len(calls) == 1 and calls[0] is not None and "CVC_22350" in calls[0].params
    assert "CVC_22350" not in result.violations.column("code").to_pylist()


def test_rulebook_condition_factors_reach_the_drivers():
    from crashscene.dsl import load_file
    from crashscene.monitor.rulebook import Rulebook
    from crashscene.pipeline.simulate import _conditions
    from crashscene.simulate.embedded.setup import condition_factor, friction

    night = load_file(Path(__file__).resolve().parents[2] / "examples" / "ciren" / "120013" / "golden.yaml")
    night = night.model_copy(update={"environment": night.environment.model_copy(
        update={"time_of_day": "nighttime", "road_surface": "wet"})})
    assert condition_factor(night) == pytest.approx(0.85 * 0.90)  # rules.md defaults
    book = Rulebook.from_mapping({"rules": {"CVC_22350": {"factor_night": 0.5, "friction_wet": 0.4}}})
    conditions = _conditions(book)
    assert conditions["factor_night"] == 0.5 and conditions["friction_wet"] == 0.4
    assert condition_factor(night, conditions) == pytest.approx(0.85 * 0.5)
    assert friction(night, conditions) == pytest.approx(0.4)
