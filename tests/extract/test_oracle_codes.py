"""The rules extractor's oracle codes are the monitor's: every code `rules_oracle` can write is a registered
rule, and its violation token is the one that rule declares (issue 14 point 1: no list retyped)."""
from __future__ import annotations

import ast
import inspect

import pytest

from crashscene.extract import rules_oracle
from crashscene.monitor.errors import RegistryError
from crashscene.monitor.rules import registered_rules


def written_codes() -> list[str]:
    """The code of every `oracle.add(...)` call in the module's source."""
    tree = ast.parse(inspect.getsource(rules_oracle))
    return [node.args[0].value for node in ast.walk(tree)
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "add"
            and node.args and isinstance(node.args[0], ast.Constant)]


def test_every_code_the_extractor_writes_is_a_registered_rule():
    codes = written_codes()
    assert len(set(codes)) >= 13  # every built-in rule has a rule deciding it
    assert set(codes) <= set(registered_rules())
    assert {code: rules_oracle.violation_of(code) for code in codes} == {
        code: registered_rules()[code].violation for code in codes}


def test_an_unregistered_code_is_refused():
    with pytest.raises(RegistryError, match="CVC_99999"):
        rules_oracle.violation_of("CVC_99999")
