"""Report input: case folders, single text files, and clear errors on bad input."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.extract.errors import CaseInputError, ExtractError
from crashscene.extract.case_input import MAX_TEXT_BYTES, load_report

CIREN = Path(__file__).resolve().parents[2] / "examples" / "ciren"
CASES = sorted(p.name for p in CIREN.iterdir() if p.is_dir())
NARRATIVE = "Vehicle one (V1) was traveling east in the eastbound lane of a two-lane, two-way road."


@pytest.mark.parametrize("case", CASES)
def test_every_bundled_case_loads(case):
    report = load_report(CIREN / case)
    assert report.case_id == case
    assert "V1" in report.narrative or "Vehicle 1" in report.narrative or "Vehicle one" in report.narrative
    assert report.sketch is not None and report.sketch.name.startswith("sketch.")
    assert report.source == CIREN / case


def test_xml_is_found_when_present():
    assert load_report(CIREN / "100237").nhtsa_xml.name == "nhtsa_case.xml"
    assert load_report(CIREN / "103341").nhtsa_xml is None


def test_single_text_file(tmp_path):
    path = tmp_path / "crash-42.txt"
    path.write_text(NARRATIVE + "\r\n\r\n\r\nIt was daylight.  ", encoding="utf-8")
    report = load_report(path)
    assert report.case_id == "crash-42" and report.sketch is None and report.source == path
    assert report.narrative == NARRATIVE + "\n\nIt was daylight."


def test_narrative_file_inside_a_case_folder_brings_its_sketch():
    report = load_report(CIREN / "100237" / "narrative.txt")
    assert report.case_id == "100237" and report.sketch is not None


def test_markdown_and_windows_1252(tmp_path):
    (tmp_path / "narrative.md").write_bytes(NARRATIVE.encode("cp1252") + b" the driver\x92s seat")
    report = load_report(tmp_path)
    assert report.narrative.endswith("the driver's seat")


@pytest.mark.parametrize("content, message", [
    (b"", "empty or too short"),
    (b"   \n\n  ", "empty or too short"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), "NUL bytes"),
    (bytes(range(1, 32)) * 20 + NARRATIVE.encode(), "control characters"),
])
def test_bad_text_is_a_clear_error(tmp_path, content, message):
    path = tmp_path / "narrative.txt"
    path.write_bytes(content)
    with pytest.raises(CaseInputError, match=message) as info:
        load_report(tmp_path)
    assert str(path) in str(info.value)


def test_huge_file_is_refused(tmp_path):
    path = tmp_path / "big.txt"
    path.write_bytes(b"a" * (MAX_TEXT_BYTES + 1))
    with pytest.raises(CaseInputError, match="at most"):
        load_report(path)


def test_missing_inputs(tmp_path):
    with pytest.raises(CaseInputError, match="no such file"):
        load_report(tmp_path / "nope")
    (tmp_path / "sketch.jpg").write_bytes(b"\xff\xd8\xff\xe0")
    with pytest.raises(CaseInputError, match="narrative.txt, narrative.md, narrative.pdf"):
        load_report(tmp_path)


def test_sketch_that_is_not_an_image(tmp_path):
    (tmp_path / "narrative.txt").write_text(NARRATIVE, encoding="utf-8")
    (tmp_path / "sketch.png").write_text("not an image", encoding="utf-8")
    with pytest.raises(CaseInputError, match="not a JPEG or PNG"):
        load_report(tmp_path)


def test_pdf_without_library_or_damaged_is_clear(tmp_path):
    (tmp_path / "narrative.pdf").write_bytes(b"%PDF-1.4 broken")
    with pytest.raises(ExtractError, match="pdf|PDF"):
        load_report(tmp_path)
