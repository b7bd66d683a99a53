"""Read a crash report: a case folder or a single text file, into a `Report`.

A case folder holds `narrative.txt` (or `narrative.md`, or `narrative.pdf` when
a PDF text library is installed), an optional `sketch.jpg|jpeg|png` and an
optional `nhtsa_case.xml`. A single text file is a narrative on its own; when
it is named `narrative.*`, its folder is read as the case folder.

Bad input fails early with a `CaseInputError` naming the file and the problem:
missing, unreadable, empty, binary data posing as text, or too large to be a
crash narrative.
"""
from __future__ import annotations

import re
from pathlib import Path

from pydantic import BaseModel, ConfigDict

from crashscene.extract.errors import CaseInputError

NARRATIVE_NAMES = ("narrative.txt", "narrative.md", "narrative.pdf")
SKETCH_NAMES = ("sketch.jpg", "sketch.jpeg", "sketch.png")
XML_NAME = "nhtsa_case.xml"
TEXT_SUFFIXES = (".txt", ".md", ".text", ".pdf")

MAX_TEXT_BYTES = 1_000_000  # [bytes] CIREN narratives are 1-5 kB; a megabyte is not a narrative
MAX_NARRATIVE_CHARS = 200_000  # [chars] after decoding (and after PDF text extraction)
MAX_PDF_BYTES = 50_000_000  # [bytes]
MAX_SKETCH_BYTES = 30_000_000  # [bytes]
MIN_NARRATIVE_CHARS = 20  # [chars] shorter than a sentence is not a report

_IMAGE_MAGIC = {b"\xff\xd8\xff": "JPEG", b"\x89PNG\r\n\x1a\n": "PNG"}


class Report(BaseModel):
    """One crash report as the extractors see it."""

    model_config = ConfigDict(frozen=True)

    case_id: str
    narrative: str
    sketch: Path | None = None
    source: Path
    nhtsa_xml: Path | None = None


def load_report(path: Path | str) -> Report:
    """Read a case folder or a narrative text file into a `Report`."""
    path = Path(path)
    if not path.exists():
        raise CaseInputError("no such file or folder; give a case folder (narrative.txt, optional sketch.jpg|png) "
                          "or a narrative text file", path)
    if path.is_dir():
        return _load_folder(path)
    if path.name.lower() in NARRATIVE_NAMES:
        folder_report = _load_folder(path.parent, narrative=path)
        return folder_report
    return Report(case_id=path.stem, narrative=read_narrative(path), source=path)


def _load_folder(folder: Path, narrative: Path | None = None) -> Report:
    if narrative is None:
        narrative = next((folder / name for name in NARRATIVE_NAMES if (folder / name).is_file()), None)
    if narrative is None:
        present = sorted(p.name for p in folder.iterdir())[:10]
        raise CaseInputError(f"case folder has no narrative; expected one of {', '.join(NARRATIVE_NAMES)} "
                          f"(found: {', '.join(present) or 'nothing'})", folder)
    sketch = next((folder / name for name in SKETCH_NAMES if (folder / name).is_file()), None)
    if sketch is not None:
        check_sketch(sketch)
    xml = folder / XML_NAME
    return Report(case_id=folder.resolve().name, narrative=read_narrative(narrative), sketch=sketch,
                  source=folder, nhtsa_xml=xml if xml.is_file() else None)


def read_narrative(path: Path) -> str:
    """Return the narrative text of a .txt/.md (UTF-8 or Windows-1252) or .pdf file, whitespace tidied."""
    if path.suffix.lower() == ".pdf":
        text = _pdf_text(path)
    else:
        data = _read_bytes(path, MAX_TEXT_BYTES)
        text = _decode(data, path)
    text = _tidy(text)
    if len(text) < MIN_NARRATIVE_CHARS:
        raise CaseInputError(f"narrative is empty or too short ({len(text)} characters); a crash narrative "
                          f"describes the vehicles and the crash in sentences", path)
    if len(text) > MAX_NARRATIVE_CHARS:
        raise CaseInputError(f"narrative has {len(text)} characters; at most {MAX_NARRATIVE_CHARS} are accepted "
                          f"(is this a whole case file rather than its narrative?)", path)
    return text


def check_sketch(path: Path) -> None:
    """Refuse a sketch that is unreadable, too large, or not a JPEG/PNG image."""
    head = _read_bytes(path, MAX_SKETCH_BYTES)[:8]
    if not any(head.startswith(magic) for magic in _IMAGE_MAGIC):
        raise CaseInputError(f"sketch is not a JPEG or PNG image (starts with {head[:4]!r}); allowed: "
                          f"{', '.join(SKETCH_NAMES)}", path)


def _read_bytes(path: Path, limit: int) -> bytes:
    try:
        size = path.stat().st_size
        if size > limit:
            raise CaseInputError(f"file is {size} bytes; at most {limit} bytes are accepted", path)
        return path.read_bytes()
    except OSError as exc:
        raise CaseInputError(f"cannot read file: {exc.strerror or exc}", path) from None


def _decode(data: bytes, path: Path) -> str:
    if b"\x00" in data[:65536]:
        raise CaseInputError("contains NUL bytes: binary data, not a text narrative", path)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        # NHTSA exports are often Windows-1252 (smart quotes); anything still odd is binary
        try:
            text = data.decode("cp1252")
        except UnicodeDecodeError as exc:
            raise CaseInputError(f"not UTF-8 or Windows-1252 text (byte {exc.start}); binary data?", path) from None
    controls = sum(1 for ch in text if ord(ch) < 32 and ch not in "\t\n\r\f")
    if text and controls / len(text) > 0.01:
        raise CaseInputError(f"{controls} control characters in {len(text)}: binary data, not a text narrative",
                          path)
    return text


def _pdf_text(path: Path) -> str:
    _read_bytes(path, MAX_PDF_BYTES)
    try:
        from pypdf import PdfReader  # optional: pip install pypdf
    except ImportError:
        raise CaseInputError("reading a PDF narrative needs the 'pypdf' package (pip install pypdf); "
                          "or save the narrative as narrative.txt", path) from None
    try:
        reader = PdfReader(str(path))
        return "\n".join(page.extract_text() or "" for page in reader.pages)
    except Exception as exc:  # pypdf raises many unrelated types on damaged files
        raise CaseInputError(f"cannot read PDF text: {exc}", path) from None


def _tidy(text: str) -> str:
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    for fancy, plain in (("\u2019", "'"), ("\u2018", "'"), ("\u201c", '"'), ("\u201d", '"'),
                         ("\u2013", "-"), ("\u2014", "-"), ("\u00a0", " ")):
        text = text.replace(fancy, plain)
    text = re.sub(r"[ \t]+", " ", text)
    return re.sub(r"\n{3,}", "\n\n", text).strip()
