"""Facts from the NHTSA case XML: posted limit (km/h -> mph) and coded conditions."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from crashscene.extract.errors import CaseInputError
from crashscene.extract.nhtsa_xml import nhtsa_facts
from crashscene.extract.case_input import load_report
from crashscene.extract.rules import extract_rules

CIREN = Path(__file__).resolve().parents[2] / "examples" / "ciren"
XML_CASES = sorted(p.name for p in CIREN.iterdir() if (p / "nhtsa_case.xml").exists())


def test_speed_limit_and_conditions_of_a_real_case():
    facts = nhtsa_facts(CIREN / "100237" / "nhtsa_case.xml")
    assert [f.text for f in facts] == [
        "speed limit 25 mph",  # 40 km/h
        "conditions: Daylight, No adverse atmospheric-related driving conditions, Dry"]
    assert {f.source for f in facts} == {"nhtsa:xml"}


@pytest.mark.parametrize("case", XML_CASES)
def test_every_bundled_xml_reads(case):
    facts = nhtsa_facts(CIREN / case / "nhtsa_case.xml")
    limit = next(f.text for f in facts if f.text.startswith("speed limit"))
    assert int(limit.split()[2]) % 5 == 0


def test_no_statutory_limit_is_skipped(tmp_path):
    path = tmp_path / "case.xml"
    path.write_text("<Case><PostedSpeedLimit UOM='kmph'>No Statutory Limit</PostedSpeedLimit>"
                    "<PostedSpeedLimit UOM='kmph' value='72'>72</PostedSpeedLimit><Light>Dark</Light></Case>")
    assert [f.text for f in nhtsa_facts(path)] == ["speed limit 45 mph", "conditions: Dark"]


def test_damaged_xml_is_a_report_error_and_does_not_stop_the_rules(tmp_path):
    case = tmp_path / "case"
    case.mkdir()
    shutil.copy(CIREN / "100237" / "narrative.txt", case / "narrative.txt")
    (case / "nhtsa_case.xml").write_text("<Case><Light>Dark</Case>")
    with pytest.raises(CaseInputError, match="not well-formed"):
        nhtsa_facts(case / "nhtsa_case.xml")
    scenario = extract_rules(load_report(case), [])
    assert scenario.environment.time_of_day.value == "daytime"  # the narrative says daylight


def test_the_xml_limit_fills_in_when_text_and_sketch_are_silent(tmp_path):
    case = tmp_path / "case"
    case.mkdir()
    (case / "narrative.txt").write_text("V1 was traveling east on a two-lane road. V1 departed the right side of the "
                                        "road and struck a tree.")
    shutil.copy(CIREN / "100343" / "nhtsa_case.xml", case / "nhtsa_case.xml")
    scenario = extract_rules(load_report(case), [])
    assert scenario.road_network.speed_limit_mph == 70  # 113 km/h
    assert scenario.evidence["road_network.speed_limit_mph"] == "case XML: speed limit 70 mph"
    assert scenario.environment.weather.value == "not_mentioned"  # coded conditions are not the report's text
