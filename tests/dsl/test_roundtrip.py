"""Every golden file validates and round-trips byte for byte through load -> dump."""
from __future__ import annotations

import pytest

from crashscene.dsl import dumps, loads, load_file, validate_file
from tests.conftest import CASES, EXAMPLES


@pytest.mark.parametrize("case", CASES)
def test_golden_validates(case: str) -> None:
    scenario, warnings = validate_file(EXAMPLES / case / "golden.yaml")
    assert scenario.actors["ego"].label == "V1"
    assert all(w.severity == "warning" for w in warnings)


@pytest.mark.parametrize("case", CASES)
def test_golden_roundtrips_byte_for_byte(case: str) -> None:
    path = EXAMPLES / case / "golden.yaml"
    text = path.read_text(encoding="utf-8")
    scenario = load_file(path)
    assert dumps(scenario) == text
    assert loads(dumps(scenario)) == scenario


def test_dump_is_stable_for_reordered_input() -> None:
    text = (EXAMPLES / CASES[0] / "golden.yaml").read_text(encoding="utf-8")
    scenario = loads(text)
    # Same content, keys in another order and signs unsorted: canonical text is the same.
    shuffled = scenario.model_dump(mode="json")
    shuffled = {key: shuffled[key] for key in reversed(list(shuffled))}
    shuffled["road_network"]["traffic_signs"] = list(reversed(shuffled["road_network"]["traffic_signs"]))
    from crashscene.dsl import from_raw

    assert dumps(from_raw(shuffled)) == text
