"""Sketch facts: OCR line classification, the hash-keyed cache, and real OCR on bundled sketches (slow)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from crashscene.extract.errors import SketchError
from crashscene.extract.sketch import (
    CURVED_DOUBLE,
    EDGE_ONLY,
    OcrLine,
    cache_dir,
    facts_from_ocr,
    line_facts,
    ocr_lines,
    sketch_facts,
    speed_limit_mph,
)

CIREN = Path(__file__).resolve().parents[2] / "examples" / "ciren"


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CRASHSCENE_CACHE_DIR", str(tmp_path / "cache"))


def _line(text: str, score: float = 0.95) -> OcrLine:
    return OcrLine(text=text, score=score, bbox=(0, 0, 10, 10))


@pytest.mark.parametrize("text, fact", [
    ("V1", "vehicle label V1"),
    ("[V2]", "vehicle label V2"),
    ("Speed Limit - 72 kmph (45 mph)", "speed limit 45 mph"),
    ("Speed limit 89 kmph", "speed limit 55 mph"),
    ("SpeedLimt: 40 km/h (25 MPH)", "speed 25 mph"),
    ("STOP", "stop sign"),
    ("Yield", "yield sign"),
    ("N", "north arrow"),
    ("V2: 2001 Volvo S60", "vehicle V2: 2001 Volvo S60"),
    ("V1 - 2001 Chevrolet Monte Carlo, 2-dr coupe", "vehicle V1: 2001 Chevrolet Monte Carlo, 2-dr coupe"),
    ("Main Street", "street name: Main Street"),
    ("I-95", "street name: I-95"),
    ("Northbound lane grade = +3%", "text: Northbound lane grade = +3%"),
    ("Gravel shoulder", "text: Gravel shoulder"),
])
def test_ocr_lines_become_short_facts(text, fact):
    facts = facts_from_ocr([_line(text)])
    assert [f.text for f in facts] == [fact]
    assert facts[0].source == "sketch:ocr" and facts[0].bbox == (0, 0, 10, 10)


def test_low_confidence_text_is_dropped():
    assert facts_from_ocr([_line("V1", score=0.3)]) == []


def test_speed_limit_conversion_rounds_to_5_mph():
    assert speed_limit_mph("56 km/h") == 35
    assert speed_limit_mph("80 km/h (50 mph)") == 50
    assert speed_limit_mph("no number") is None


def test_cache_is_keyed_by_image_content(tmp_path):
    image = tmp_path / "copy.jpg"
    image.write_bytes((CIREN / "103378" / "sketch.jpg").read_bytes())
    import hashlib
    digest = hashlib.sha256(image.read_bytes()).hexdigest()
    entry = cache_dir() / "ocr" / f"{digest}.v1.json"
    entry.parent.mkdir(parents=True)
    entry.write_text(json.dumps([{"text": "Speed Limit 45 mph", "score": 0.99, "bbox": [1, 2, 3, 4]}]))
    assert [line.text for line in ocr_lines(image)] == ["Speed Limit 45 mph"]  # no OCR run: from the cache


def test_unreadable_image_is_a_sketch_error(tmp_path):
    bad = tmp_path / "sketch.jpg"
    bad.write_bytes(b"\xff\xd8\xff garbage")
    with pytest.raises(SketchError, match="not a readable image"):
        ocr_lines(bad)
    with pytest.raises(SketchError, match="cannot read"):
        ocr_lines(tmp_path / "missing.jpg")


def test_drawn_double_centre_line_is_seen():
    assert [f.text for f in line_facts(CIREN / "3-C1-2018-001" / "sketch.jpg")] == ["double solid line drawn"]
    assert [f.text for f in line_facts(CIREN / "108812" / "sketch.jpg")] == ["broken line drawn"]


def _road(path: Path, doubles: list[int], singles: list[int], dashed: list[int]) -> Path:
    """A synthetic sketch of a straight road: double lines (two 2 px strokes 6 px apart), single lines, dashed lines
    at the given heights [px]."""
    import cv2
    import numpy as np

    image = np.full((500, 900, 3), 255, np.uint8)
    for y in doubles:
        cv2.line(image, (20, y), (880, y), (0, 0, 0), 2)
        cv2.line(image, (20, y + 6), (880, y + 6), (0, 0, 0), 2)
    for y in singles:
        cv2.line(image, (20, y), (880, y), (0, 0, 0), 2)
    for y in dashed:
        for x in range(20, 880, 40):
            cv2.line(image, (x, y), (x + 20, y), (0, 0, 0), 2)
    cv2.imwrite(str(path), image)
    return path


def test_a_double_line_between_the_road_edges_is_a_centre_line(tmp_path):
    facts = [f.text for f in line_facts(_road(tmp_path / "centre.png", [247], [150, 350], []))]
    assert facts == ["double solid line drawn"]


def test_double_drawn_road_edges_are_no_centre_line(tmp_path):
    facts = [f.text for f in line_facts(_road(tmp_path / "edges.png", [150, 344], [], [250]))]
    assert facts == ["double solid line drawn", EDGE_ONLY]
    # the same edges around a double centre line: the centre is found
    facts = [f.text for f in line_facts(_road(tmp_path / "both.png", [150, 247, 344], [], []))]
    assert facts == ["double solid line drawn"]


def _curved_road(path: Path, doubles: list[int], singles: list[int], radius: int = 600) -> Path:
    """A synthetic sketch of a road on an arc of `radius` [px]: double and single lines at the given offsets [px]."""
    import cv2
    import numpy as np

    image = np.full((900, 900, 3), 255, np.uint8)
    angles = np.linspace(-0.6, 0.6, 200)

    def arc(r: int) -> None:
        points = np.stack([450 - radius + r * np.cos(angles), 450 + r * np.sin(angles)], 1).astype(np.int32)
        cv2.polylines(image, [points], False, (0, 0, 0), 2)

    for offset in doubles:
        arc(radius + offset)
        arc(radius + offset + 6)
    for offset in singles:
        arc(radius + offset)
    cv2.imwrite(str(path), image)
    return path


def test_a_double_line_along_a_curve_is_read_on_short_straight_runs(tmp_path):
    assert [f.text for f in line_facts(_curved_road(tmp_path / "curve.png", [0], [-100, 100]))] == [CURVED_DOUBLE]
    # the same curve with single lines only: nothing double is drawn
    assert [f.text for f in line_facts(_curved_road(tmp_path / "single.png", [], [-100, 0, 100]))] == []
    # double-drawn edges of a curve with a single centre line are no centre line
    edges = [f.text for f in line_facts(_curved_road(tmp_path / "edges.png", [-100, 94], [0]))]
    assert edges == [CURVED_DOUBLE, EDGE_ONLY]


@pytest.mark.slow
@pytest.mark.parametrize("case, expected", [
    ("103378", {"vehicle label V2", "speed limit 45 mph"}),
    ("108812", {"north arrow", "speed limit 55 mph", "vehicle label V1", "vehicle label V2"}),
    ("3-C1-2018-005", {"vehicle V1: 2007 GMC Yukon 1500", "speed limit 45 mph"}),
])
def test_real_ocr_on_bundled_sketches(case, expected):
    facts = sketch_facts(CIREN / case / "sketch.jpg")
    assert expected <= {f.text for f in facts}
    assert all(0.0 <= f.confidence <= 1.0 for f in facts)
    cached = list((cache_dir() / "ocr").glob("*.json"))
    assert len(cached) == 1  # the second call reads the cache
    assert {f.text for f in sketch_facts(CIREN / case / "sketch.jpg")} == {f.text for f in facts}
