"""Rulebook YAML overrides and their errors; a user rule registered by code."""
from __future__ import annotations

import sys
import textwrap

import numpy as np
import pytest

from crashscene.monitor import (
    Rule,
    Rulebook,
    RulebookError,
    RuleOutcome,
    RuleParams,
    evaluate,
    load_rulebook,
    register_rule,
    registered_rules,
    unregister_rule,
)
from crashscene.monitor.errors import RegistryError
from tests.monitor.builders import tables, track
from tests.monitor.conftest import rule_row

FOLLOWING = {"ego": track(50, speed=15.0, lane_id="L"), "npc1": track(50, x0=1.8 * 15 + 4.5, speed=15.0, lane_id="L")}


def write(tmp_path, text: str):
    path = tmp_path / "rules.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def test_twelve_rules_registered_with_rules_md_defaults():
    codes = [r.code for r in Rulebook().rules()]
    assert codes[:12] == ["CVC_21453", "CVC_22450", "CVC_21800", "CVC_21801", "CVC_21802", "CVC_22350",
                          "CVC_22349", "CVC_21460", "CVC_21650", "CVC_22107", "CVC_21703", "CVC_21803"]
    defaults = Rulebook().defaults()
    assert defaults["CVC_21703"]["min_headway"] == 2.0 and defaults["CVC_22350"]["factor_fog"] == 0.70


def test_override_changes_the_verdict(tmp_path):
    assert rule_row(evaluate(tables(FOLLOWING), None), "CVC_21703", "ego")["verdict"] == "violated"
    book = load_rulebook(write(tmp_path, "rules:\n  CVC_21703: {min_headway: 1.5}\n"))
    row = rule_row(evaluate(tables(FOLLOWING), None, book), "CVC_21703", "ego")
    assert row["verdict"] == "satisfied" and row["threshold"] == 1.5


def test_disabled_rule_is_not_evaluated(tmp_path):
    book = load_rulebook(write(tmp_path, "rules:\n  CVC_21703: {enabled: false}\n"))
    result = evaluate(tables(FOLLOWING), None, book)
    assert "CVC_21703" not in set(result.rule_results.column("code").to_pylist())


@pytest.mark.parametrize("text, expected", [
    ("rules:\n  CVC_99999: {}\n", ["rules.CVC_99999", "unknown rule code", "CVC_21453"]),
    ("rules:\n  CVC_21703: {min_headwy: 1}\n", ["rules.CVC_21703.min_headwy", "unknown parameter", "min_headway"]),
    ("rules:\n  CVC_21703: {min_headway: -1}\n", ["rules.CVC_21703.min_headway", "-1", "> 0"]),
    ("rules:\n  CVC_21703: {min_headway: fast}\n", ["rules.CVC_21703.min_headway", "'fast'", "float"]),
    ("rules:\n  CVC_21703: 2\n", ["rules.CVC_21703", "expected a mapping", "min_headway"]),
    ("rulez: {}\n", ["unknown key 'rulez'", "imports, rules"]),
    ("rules: [a\n", ["rules.yaml:", "not valid YAML"]),
    ("imports: [no_such_module_xyz]\n", ["imports", "no_such_module_xyz", "--allow-imports"]),
    ("rules:\n  CVC_21703: {min_headway: 1}\n  CVC_21703: {enabled: false}\n",
     ["CVC_21703", "written twice", "lines 2 and 3"]),
    ("rules:\n  CVC_21703: {min_headway: 1, min_headway: 2}\n", ["min_headway", "written twice"]),
])
def test_rulebook_errors_name_file_code_parameter_value_and_allowed(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(RulebookError) as err:
        load_rulebook(path)
    message = str(err.value)
    assert str(path) in message
    for part in expected:
        assert part in message


def test_binary_rulebook_names_the_file(tmp_path):
    path = tmp_path / "rules.yaml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe")
    with pytest.raises(RulebookError, match="not UTF-8") as err:
        load_rulebook(path)
    assert str(path) in str(err.value)
    path.write_bytes(b"rules: {}\x00\x01")
    with pytest.raises(RulebookError, match="binary") as err:
        load_rulebook(path)
    assert str(path) in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(RulebookError, match="cannot read rulebook"):
        load_rulebook(tmp_path / "none.yaml")


class HeadlightParams(RuleParams):
    max_dark_speed: float = 5.0  # [m/s]


class Headlights(Rule):
    """A toy user rule: CVC 24400 headlights, here 'never faster than max_dark_speed'."""

    code = "CVC_24400"
    violation = "headlights"
    unit = "m/s"
    Params = HeadlightParams

    def evaluate(self, ctx):
        speed = np.nan_to_num(ctx.arrays.floats["speed"], nan=0.0).max(axis=2)
        out = RuleOutcome.empty(ctx.shape, self.params.max_dark_speed)
        out.applicable = ctx.arrays.present.copy()
        out.violated = speed > self.params.max_dark_speed
        out.first_t = np.zeros(ctx.shape)
        out.measured = speed
        out.robustness = self.params.max_dark_speed - speed
        return out


@pytest.fixture
def user_rule():
    register_rule(Headlights)
    yield Headlights
    unregister_rule("CVC_24400")


def test_user_rule_registered_by_code_runs_with_overrides(tmp_path, user_rule):
    assert "CVC_24400" in registered_rules()
    result = evaluate(tables({"ego": track(20, speed=6.0)}), None)
    assert rule_row(result, "CVC_24400", "ego")["verdict"] == "violated"
    book = load_rulebook(write(tmp_path, "rules:\n  CVC_24400: {max_dark_speed: 7}\n"))
    assert rule_row(evaluate(tables({"ego": track(20, speed=6.0)}), None, book), "CVC_24400", "ego")["verdict"] \
        == "satisfied"


def test_rulebook_imports_a_module_that_registers_rules(tmp_path, monkeypatch):
    (tmp_path / "my_rules_mod.py").write_text(textwrap.dedent("""
        from crashscene.monitor import Rule, RuleOutcome, register_rule
        @register_rule
        class Cvc22108(Rule):
            code = "CVC_22108"
            violation = "signal_before_turn"
            unit = "s"
            def evaluate(self, ctx):
                out = RuleOutcome.empty(ctx.shape, 3.0)
                out.applicable[:] = True
                return out
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        path = write(tmp_path, "imports: [my_rules_mod]\nrules:\n  CVC_22108: {}\n")
        with pytest.raises(RulebookError, match="--allow-imports"):
            load_rulebook(path)
        assert "my_rules_mod" not in sys.modules
        book = load_rulebook(path, allow_imports=True)
        result = evaluate(tables({"ego": track(20)}), None, book)
        assert rule_row(result, "CVC_22108", "ego")["verdict"] == "satisfied"
    finally:
        unregister_rule("CVC_22108")
        sys.modules.pop("my_rules_mod", None)


def test_registering_a_clashing_code_needs_replace():
    class Other(Rule):
        code = "CVC_21703"
        violation = "other"
        unit = "s"

        def evaluate(self, ctx):
            raise NotImplementedError

    with pytest.raises(RegistryError, match="already registered"):
        register_rule(Other)
    with pytest.raises(RegistryError, match="CVC_<digits>"):
        register_rule(type("Bad", (Headlights,), {"code": "22108"}))
