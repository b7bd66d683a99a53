"""Sketch facts: read a CIREN crash sketch offline and turn it into short text facts.

rapidocr (ONNX models shipped in its wheel; it reads the boxed V1/V2 labels that
tesseract misses) finds the text on the sketch; OpenCV measures the drawn lines.
What is read becomes `SketchFact`s such as "vehicle label V1", "speed limit 35
mph", "stop sign", "north arrow", "street name: Main St", each with its source
("sketch:ocr", "sketch:lines"), a confidence and a pixel bounding box, so the
extractors can ground a field in the sketch and quote it as evidence.

OCR takes 1-3 s per sketch (more on a busy machine), so the raw OCR lines are
cached by the image's SHA-256 in the user cache dir (`$CRASHSCENE_CACHE_DIR`,
else `$XDG_CACHE_HOME/crashscene`, else `~/.cache/crashscene`). Facts are
derived from the cached lines on every call, so improving the fact rules never
needs a new OCR run.
"""
from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import re
from pathlib import Path

from pydantic import BaseModel, ConfigDict

from crashscene.cache import cache_dir
from crashscene.extract.errors import SketchError
from crashscene.units import KMH_PER_MPH

OCR_CACHE_VERSION = 1  # bump when the raw OCR record format or engine settings change
MIN_OCR_SCORE = 0.5  # rapidocr's own default text score threshold



class SketchFact(BaseModel):
    """One short fact read from a sketch, with where it came from."""

    model_config = ConfigDict(frozen=True)

    text: str
    source: str = "sketch:ocr"
    confidence: float = 1.0
    bbox: tuple[int, int, int, int] | None = None  # [px] x0, y0, x1, y1 in the image

    def __str__(self) -> str:
        return f"{self.text} ({self.source}, {self.confidence:.2f})"


class OcrLine(BaseModel):
    """One raw OCR result: the cached unit."""

    text: str
    score: float
    bbox: tuple[int, int, int, int]


# ---------------------------------------------------------------- public API


def sketch_facts(image: Path | str, use_cache: bool = True) -> list[SketchFact]:
    """OCR (cached) and line analysis of a sketch image, as short facts in reading order."""
    image = Path(image)
    lines = ocr_lines(image, use_cache=use_cache)
    facts = facts_from_ocr(lines)
    facts.extend(line_facts(image, use_cache=use_cache))
    return facts


def ocr_lines(image: Path, use_cache: bool = True) -> list[OcrLine]:
    """The text lines rapidocr reads on the image, from the cache when the same image was read before."""
    try:
        data = image.read_bytes()
    except OSError as exc:
        raise SketchError(f"cannot read sketch image: {exc.strerror or exc}", image) from None
    digest = hashlib.sha256(data).hexdigest()
    cache_file = cache_dir() / "ocr" / f"{digest}.v{OCR_CACHE_VERSION}.json"
    if use_cache and cache_file.is_file():
        try:
            return [OcrLine.model_validate(item) for item in json.loads(cache_file.read_text("utf-8"))]
        except (ValueError, OSError):
            pass  # a damaged cache entry is simply recomputed
    lines = _run_ocr(data, image)
    if use_cache:
        _write_cache(cache_file, lines)
    return lines


# ---------------------------------------------------------------- OCR


@functools.cache
def _ocr_engine():
    """One rapidocr engine per process: loading its three ONNX models takes seconds."""
    try:
        from rapidocr import RapidOCR
    except ImportError as exc:
        raise SketchError(f"sketch OCR needs rapidocr and onnxruntime (pip install rapidocr onnxruntime): {exc}") \
            from None
    logging.getLogger("RapidOCR").setLevel(logging.ERROR)
    return RapidOCR(params={"Global.log_level": "error"})


MAX_SKETCH_PIXELS = 40_000_000  # [pixels] CIREN sketches are 1-5 Mpx; a 20000 x 20000 image would take 2.4 GB


def decode_image(data: bytes, image: Path, grey: bool = False):
    """Decode a sketch with OpenCV after checking its size from the header (no decoding of huge images)."""
    import io
    import warnings

    import cv2
    import numpy as np
    from PIL import Image, UnidentifiedImageError

    too_large = f"at most {MAX_SKETCH_PIXELS // 1_000_000} megapixels are decoded (scale the sketch down)"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data)) as header:
                width, height = header.size
    except Image.DecompressionBombError as exc:  # PIL's own, higher limit
        raise SketchError(f"image is too large ({exc}); {too_large}", image) from None
    except (UnidentifiedImageError, OSError, ValueError):
        raise SketchError("not a readable image (JPEG or PNG expected)", image) from None
    if width * height > MAX_SKETCH_PIXELS:
        raise SketchError(f"image is {width} x {height} pixels; {too_large}", image)
    pixels = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR)
    if pixels is None:
        raise SketchError("not a readable image (JPEG or PNG expected)", image)
    return pixels


def _run_ocr(data: bytes, image: Path) -> list[OcrLine]:
    pixels = decode_image(data, image)
    try:
        result = _ocr_engine()(pixels)
    except SketchError:
        raise
    except Exception as exc:  # onnxruntime errors are not one type
        raise SketchError(f"OCR failed: {exc}", image) from None
    if result.boxes is None or result.txts is None:
        return []
    lines = []
    for box, text, score in zip(result.boxes, result.txts, result.scores):
        xs = [float(p[0]) for p in box]
        ys = [float(p[1]) for p in box]
        lines.append(OcrLine(text=str(text).strip(), score=round(float(score), 4),
                             bbox=(int(min(xs)), int(min(ys)), int(max(xs)), int(max(ys)))))
    return [line for line in lines if line.text]


def _write_cache(cache_file: Path, lines: list[OcrLine]) -> None:
    _write_text(cache_file, json.dumps([line.model_dump(mode="json") for line in lines]))


def _write_text(cache_file: Path, text: str) -> None:
    try:
        cache_file.parent.mkdir(parents=True, exist_ok=True)
        tmp = cache_file.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(cache_file)
    except OSError:
        pass  # a read-only home still gets its facts, only slower next time


# ---------------------------------------------------------------- OCR lines -> facts

_LABEL = re.compile(r"^\s*[\[(|]?\s*(V|Veh|Vehicle)\s*#?\s*([1-9])\s*[\])|]?\s*$", re.I)
_VEHICLE_LIST = re.compile(r"^\s*(?:V|Veh|Vehicle)\s*#?\s*([1-9])\s*[-:=.,]\s*(.{3,})$", re.I)
_SPEED = re.compile(r"speed\s*limit", re.I)
_MPH = re.compile(r"(\d{2,3})\s*(?:mph|m\.p\.h|mi/h)", re.I)
_KMH = re.compile(r"(\d{2,3})\s*(?:kmph|km/h|km/hr|kph|kmh|km)", re.I)
# "Main Street", "N. Oak Ave", "Route 9", "I-95", "US 1", "County Road 12": a capitalised name and a road word
_STREET = re.compile(r"^(?:[A-Z0-9][\w.'-]*\s+){1,4}(?:Street|St|Road|Rd|Avenue|Ave|Boulevard|Blvd|Highway|Hwy|Drive|"
                     r"Dr|Lane|Ln|Parkway|Pkwy|Pike|Way|Court|Ct|Place|Pl|Trail|Expressway|Freeway)\.?$|"
                     r"^(?:I|US|SR|CR|Route|Rte|Highway|Hwy|State Route|County Road|Interstate)[- ]?\d{1,4}[A-Z]?$")
_NORTH = re.compile(r"^\s*[-|^↑]*\s*N\s*[-|^↑]*\s*$")


def facts_from_ocr(lines: list[OcrLine]) -> list[SketchFact]:
    """Turn raw OCR lines into short facts; unrecognised legible text is kept as 'text: ...'."""
    facts: list[SketchFact] = []
    for line in sorted(lines, key=lambda item: (item.bbox[1], item.bbox[0])):
        if line.score < MIN_OCR_SCORE:
            continue
        text = " ".join(line.text.split())
        for fact_text in _classify(text):
            facts.append(SketchFact(text=fact_text, source="sketch:ocr", confidence=line.score, bbox=line.bbox))
    return facts


def _classify(text: str) -> list[str]:
    label = _LABEL.match(text)
    if label:
        return [f"vehicle label V{label.group(2)}"]
    if _NORTH.match(text):
        return ["north arrow"]
    out: list[str] = []
    if _SPEED.search(text) or _MPH.search(text):
        mph = speed_limit_mph(text)
        if mph is not None and _SPEED.search(text):
            out.append(f"speed limit {mph} mph")
        elif mph is not None:
            out.append(f"speed {mph} mph")
    listed = _VEHICLE_LIST.match(text)
    if listed and not out:
        return [f"vehicle V{listed.group(1)}: {listed.group(2).strip()}"]
    folded = text.lower().strip(" .")
    if re.fullmatch(r"(all[\s-]*way\s+)?stop(\s+sign)?|stop\s*\(?\d?\)?", folded):
        out.append("stop sign")
    elif re.search(r"\bstop\s+sign", folded):
        out.append("stop sign")
    if re.fullmatch(r"yield(\s+sign)?", folded) or re.search(r"\byield\s+sign", folded):
        out.append("yield sign")
    if re.search(r"\b(traffic\s+)?signal(s|ized)?\b|\btraffic\s+light", folded):
        out.append("traffic signal")
    if re.search(r"\b(flashing|blinking)\s+(red|yellow|amber)", folded):
        out.append(f"flashing {re.search(r'(red|yellow|amber)', folded).group(1)} signal")
    if not out and _STREET.match(text):
        out.append(f"street name: {text}")
    if not out and len(text) >= 2:
        out.append(f"text: {text}")
    return out


def speed_limit_mph(text: str) -> int | None:
    """The mph figure of a speed-limit text; km/h alone is converted and rounded to the nearest 5 mph."""
    mph = _MPH.search(text)
    if mph:
        return int(mph.group(1))
    kmh = _KMH.search(text)
    if kmh:
        return int(5 * round(int(kmh.group(1)) / KMH_PER_MPH / 5))
    return None


# ---------------------------------------------------------------- drawn lines (OpenCV)

LINE_CACHE_VERSION = 3  # 2: centre_strokes; 3: short strokes
_INK = 160  # grey level below which a pixel is drawn ink
_LONG = 0.2  # a lane line runs over at least this share of the image's short side
_SHORT = 0.1  # a curved lane line is drawn as straight runs of at least this share of the image's short side
_DOUBLE_SHARE = 0.7  # share of cross-sections along a stroke that must show two thin parallel strokes
MIN_DOUBLE_STROKES = 2  # long double strokes needed to call a double solid line drawn
MIN_DASHES = 20  # collinear short dashes needed to call a broken line drawn
EDGE_ONLY = "double line drawn only at a road edge"
CURVED_DOUBLE = "curved double solid line drawn (short straight runs)"
_ROAD_REACH = 0.3  # share of the image's short side searched on each side of a double stroke for drawn road
_BOTH_SIDES_SHARE = 0.85  # share of cross-sections of a centre stroke with drawn road on both sides
_SECTION_HALF = 14  # [px] a cross-section of a stroke reads this far to either side of it (`_is_double_section`)


class LineSummary(BaseModel):
    """What OpenCV measures on the drawing: long double strokes and the longest row of collinear dashes."""

    long_strokes: int = 0
    double_strokes: int = 0
    collinear_dashes: int = 0
    centre_strokes: int = 0  # double strokes with drawn road (lines, edges) on both sides: between the road's edges
    short_double_strokes: int = 0  # the same on straight runs of _SHORT (a curved line is drawn as short runs)
    short_centre_strokes: int = 0


def line_facts(image: Path, use_cache: bool = True) -> list[SketchFact]:
    """Facts about drawn lane lines: 'double solid line drawn', 'broken line drawn', and 'double line drawn only
    at a road edge' when no double stroke has drawn road on both sides (a centre line lies between the road's
    edges: a double-drawn road edge has road on one side only)."""
    summary = line_summary(image, use_cache=use_cache)
    facts = []
    if summary.double_strokes >= MIN_DOUBLE_STROKES:
        facts.append(SketchFact(text="double solid line drawn", source="sketch:lines",
                                confidence=min(1.0, 0.5 + 0.1 * summary.double_strokes)))
        if not summary.centre_strokes:
            facts.append(SketchFact(text=EDGE_ONLY, source="sketch:lines"))
        return facts
    if summary.short_double_strokes >= MIN_DOUBLE_STROKES:  # no long double line: a curved one, in short runs
        facts.append(SketchFact(text=CURVED_DOUBLE, source="sketch:lines",
                                confidence=min(1.0, 0.4 + 0.05 * summary.short_double_strokes)))
        if not summary.short_centre_strokes:
            facts.append(SketchFact(text=EDGE_ONLY, source="sketch:lines"))
    if summary.collinear_dashes >= MIN_DASHES:
        facts.append(SketchFact(text="broken line drawn", source="sketch:lines",
                                confidence=min(1.0, summary.collinear_dashes / 50)))
    return facts


def line_summary(image: Path, use_cache: bool = True) -> LineSummary:
    """Measure the drawn strokes (cached by image hash like OCR; about 0.25 s uncached)."""
    try:
        data = image.read_bytes()
    except OSError as exc:
        raise SketchError(f"cannot read sketch image: {exc.strerror or exc}", image) from None
    cache_file = cache_dir() / "lines" / f"{hashlib.sha256(data).hexdigest()}.v{LINE_CACHE_VERSION}.json"
    if use_cache and cache_file.is_file():
        try:
            return LineSummary.model_validate_json(cache_file.read_text("utf-8"))
        except (ValueError, OSError):
            pass
    summary = _measure_lines(data, image)
    if use_cache:
        _write_text(cache_file, summary.model_dump_json())
    return summary


def _measure_lines(data: bytes, image: Path) -> LineSummary:
    import math

    import cv2
    import numpy as np

    grey = decode_image(data, image, grey=True)
    ink = (grey < _INK).astype(np.uint8)
    side = min(grey.shape)
    strokes, doubles, centres = _double_strokes(ink, side, _LONG)
    _, short_doubles, short_centres = _double_strokes(ink, side, _SHORT)
    found = cv2.HoughLinesP(ink * 255, 1, np.pi / 360, threshold=12, minLineLength=int(0.012 * side), maxLineGap=1)
    dashes = [] if found is None else [s[0] for s in found
                                       if math.hypot(s[0][2] - s[0][0], s[0][3] - s[0][1]) < 0.08 * side]
    items = [(math.atan2(y2 - y1, x2 - x1) % math.pi, (x1 + x2) / 2, (y1 + y2) / 2) for x1, y1, x2, y2 in dashes]
    best = 0
    for angle, mx, my in items:
        count = 0
        for other, qx, qy in items:
            turn = abs(angle - other)
            if min(turn, math.pi - turn) > 0.03:
                continue
            across = abs(-math.sin(angle) * (qx - mx) + math.cos(angle) * (qy - my))
            along = abs(math.cos(angle) * (qx - mx) + math.sin(angle) * (qy - my))
            count += across < 2.5 and along > 0.03 * side
        best = max(best, count)
    return LineSummary(long_strokes=len(strokes), double_strokes=doubles, collinear_dashes=best,
                       centre_strokes=centres, short_double_strokes=short_doubles, short_centre_strokes=short_centres)


def _double_strokes(ink, side: int, share: float) -> tuple[list, int, int]:
    """Straight strokes of at least `share` of the short side, how many of them are double (two thin parallel
    strokes along most of their length), and how many of those have drawn road on both sides."""
    import math

    import cv2
    import numpy as np

    found = cv2.HoughLinesP(ink * 255, 1, np.pi / 360, threshold=60, minLineLength=int(share * side), maxLineGap=3)
    strokes = [] if found is None else [tuple(int(v) for v in s[0]) for s in found]
    doubles = centres = 0
    for x1, y1, x2, y2 in strokes:
        length = math.hypot(x2 - x1, y2 - y1)
        nx, ny = -(y2 - y1) / length, (x2 - x1) / length
        sections = [(x1 + (x2 - x1) * t, y1 + (y2 - y1) * t) for t in np.linspace(0.05, 0.95, 19)]
        if sum(_is_double_section(ink, x, y, nx, ny) for x, y in sections) >= _DOUBLE_SHARE * 19:
            doubles += 1
            reach = int(_ROAD_REACH * side)
            both = sum(_ink_beyond(ink, x, y, nx, ny, reach) and _ink_beyond(ink, x, y, -nx, -ny, reach)
                       for x, y in sections)
            centres += both >= _BOTH_SIDES_SHARE * len(sections)
    return strokes, doubles, centres


def _ink_beyond(ink, x: float, y: float, nx: float, ny: float, reach: int, clear: int = _SECTION_HALF + 2) -> bool:
    """Whether drawn ink lies along the normal (nx, ny) from (x, y), past the double stroke's own width (`clear`
    [px]: the span `_is_double_section` reads, and 2 px more) and within `reach` [px]: another line of the road,
    or its edge."""
    height, width = ink.shape
    for k in range(clear, reach):
        px, py = int(round(x + nx * k)), int(round(y + ny * k))
        if not (0 <= px < width and 0 <= py < height):
            return False
        if ink[py, px]:
            return True
    return False


def _is_double_section(ink, x: float, y: float, nx: float, ny: float, half: int = _SECTION_HALF) -> bool:
    """Across the stroke at (x, y): two thin ink runs (<= 6 px) separated by a 1-9 px gap, one on the stroke."""
    height, width = ink.shape
    values = []
    for k in range(-half, half + 1):
        px, py = int(round(x + nx * k)), int(round(y + ny * k))
        values.append(int(ink[py, px]) if 0 <= px < width and 0 <= py < height else 0)
    runs, start = [], None
    for index, value in enumerate(values + [0]):
        if value and start is None:
            start = index
        elif not value and start is not None:
            runs.append((start, index - 1))
            start = None
    for first, second in zip(runs, runs[1:]):
        gap = second[0] - first[1] - 1
        thin = first[1] - first[0] <= 5 and second[1] - second[0] <= 5
        on_stroke = first[0] - 1 <= half <= first[1] + 1 or second[0] - 1 <= half <= second[1] + 1
        if 1 <= gap <= 9 and thin and on_stroke:
            return True
    return False
