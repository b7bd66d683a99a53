"""ASAM's checker bundles on every bundled case's export: OpenDRIVE map, logical scenario, distribution, replays.

Pass = no error-level issue and no checker skipped because a prerequisite failed. The
only skips allowed are rules not applicable to the declared version (the OpenDRIVE rule
defined up to 1.7 only, checked on the maps in tests/render/test_maps.py) and, for
distribution.xosc and parameter_sets.xosc, the reference checks that need a scenario
definition (those files are ParameterValueDistributions; the checks run on scenario.xosc).
"""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import CASES

pytestmark = pytest.mark.slow

# reference checks that need RoadNetwork, Entities or a Storyboard: absent from a ParameterValueDistribution
DISTRIBUTION_NOT_APPLICABLE = {
    "check_asam_xosc_reference_control_resolvable_signal_id_in_traffic_signal_state_action",
    "check_asam_xosc_reference_control_resolvable_traffic_signal_controller_by_traffic_signal_controller_ref",
    "check_asam_xosc_reference_control_resolvable_entity_references",
    "check_asam_xosc_reference_control_resolvable_variable_reference",
    "check_asam_xosc_reference_control_resolvable_storyboard_element_reference",
}


def problems(path: Path, allowed_skips: set[str] = frozenset()) -> list[str]:
    from crashscene.export.check import check_file

    report = check_file(path)
    out = [f"error [{i.checker}] {i.description} {'; '.join(i.locations)}" for i in report.errors]
    out += [f"{c.status} [{c.checker_id}] {c.summary}" for c in report.failed if c.checker_id not in allowed_skips]
    assert report.checkers, f"{path}: the bundle ran no checker"
    return out


@pytest.mark.parametrize("case", CASES)
def test_export_passes_asam_checkers(case_export, case):
    exported = case_export(case).result
    found = {"map.xodr": problems(exported.map),
             "scenario.xosc": problems(exported.scenario),
             "distribution.xosc": problems(exported.distribution, DISTRIBUTION_NOT_APPLICABLE),
             "parameter_sets.xosc": problems(exported.parameter_sets, DISTRIBUTION_NOT_APPLICABLE)}
    assert exported.variations, f"{case}: no valid simulated variation to export"
    for v, path in exported.variations.items():
        found[f"variations/{v}.xosc"] = problems(path)
    bad = {name: issues for name, issues in found.items() if issues}
    assert not bad, "\n".join(f"{name}:\n  " + "\n  ".join(issues) for name, issues in bad.items())


def test_checker_flags_a_broken_scenario(case_export, tmp_path):
    """The check can fail: a replay whose event acts on an entity that does not exist is an error."""
    exported = case_export("100237").result
    source = next(iter(exported.variations.values()))
    broken = tmp_path / "variations" / "broken.xosc"  # beside ../map.xodr, as exported
    broken.parent.mkdir()
    text = source.read_text(encoding="utf-8")
    broken.write_text(text.replace('EntityRef entityRef="ego"', 'EntityRef entityRef="ghost"', 1), encoding="utf-8")
    (tmp_path / "map.xodr").write_bytes(exported.map.read_bytes())
    assert any("ghost" in p or "entity" in p.lower() for p in problems(broken)), problems(broken)
