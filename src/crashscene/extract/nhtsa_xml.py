"""Facts from an NHTSA case XML (`nhtsa_case.xml` of CIREN/NASS exports), in the sketch-fact form.

The XML codes what the police report and the investigator recorded per vehicle:
the posted speed limit (km/h), light and atmospheric conditions, the surface.
These become `SketchFact`s with source "nhtsa:xml" ("speed limit 25 mph",
"conditions: Daylight, No adverse atmospheric-related driving conditions, Dry"),
the first vehicle's (V1's) values first, so an extractor can use them where the
narrative and the sketch are silent. Only these few elements are read; the file
is size-capped and parsed without external entities.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from crashscene.extract.errors import CaseInputError
from crashscene.extract.sketch import SketchFact
from crashscene.units import KMH_PER_MPH

MAX_XML_BYTES = 20_000_000  # [bytes] case files with images inlined stay far below
SOURCE = "nhtsa:xml"


def nhtsa_facts(path: Path | str) -> list[SketchFact]:
    """Speed limit and conditions coded in the case XML; raises `CaseInputError` on an unreadable file."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_XML_BYTES:
            raise CaseInputError(f"case XML is larger than {MAX_XML_BYTES} bytes", path)
        root = ET.parse(path).getroot()
    except OSError as exc:
        raise CaseInputError(f"cannot read case XML: {exc.strerror or exc}", path) from None
    except ET.ParseError as exc:
        raise CaseInputError(f"not well-formed XML ({exc})", path) from None
    facts: list[SketchFact] = []
    mph = _speed_limit_mph(root)
    if mph is not None:
        facts.append(SketchFact(text=f"speed limit {mph} mph", source=SOURCE))
    conditions = [_text(root, "Light"), _text(root, "Atmosphere"), _text(root, "SurfaceCondition")]
    conditions = [c for c in conditions if c and c.lower() not in ("unknown", "other")]
    if conditions:
        facts.append(SketchFact(text="conditions: " + ", ".join(conditions), source=SOURCE))
    return facts


def _text(root: ET.Element, tag: str) -> str | None:
    element = next(root.iter(tag), None)
    return " ".join(element.text.split()) if element is not None and element.text else None


def _speed_limit_mph(root: ET.Element) -> int | None:
    """The first numeric posted limit (V1's), converted from km/h and rounded to the nearest 5 mph."""
    for element in root.iter("PostedSpeedLimit"):
        value = (element.get("value") or element.text or "").strip()
        if not value.isdigit() or int(value) <= 0:
            continue  # "No Statutory Limit", "Unknown"
        unit = (element.get("UOM") or "kmph").lower()
        speed = int(value)
        return speed if unit in ("mph", "mi/h") else int(5 * round(speed / KMH_PER_MPH / 5))
    return None
