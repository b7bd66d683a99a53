"""Reports that are not crash reports, and sketches too large to decode: clear errors naming the file."""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.extract.errors import SketchError
from crashscene.extract.sketch import MAX_SKETCH_PIXELS, line_summary, ocr_lines

LOREM = ("Lorem ipsum dolor sit amet, consectetur adipiscing elit, sed do eiusmod tempor incididunt ut labore et "
         "dolore magna aliqua. Ut enim ad minim veniam, quis nostrud exercitation ullamco laboris.\n")


def test_text_describing_no_crash_fails_naming_the_file(tmp_path: Path) -> None:
    narrative = tmp_path / "lorem" / "narrative.txt"
    narrative.parent.mkdir()
    narrative.write_text(LOREM, encoding="utf-8")
    result = CliRunner().invoke(app, ["extract", str(narrative.parent), "--backend", "rules", "-o",
                                      str(tmp_path / "out.yaml")])
    assert result.exit_code != 0
    assert "no vehicle found" in result.output and str(narrative.parent) in result.output
    assert not (tmp_path / "out.yaml").exists()


def _png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims width x height pixels (the pixel data is a stub: it must never be decoded)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + \
        chunk(b"IEND", b"")


def test_a_huge_sketch_is_refused_before_decoding(tmp_path: Path) -> None:
    for width, height in ((20_000, 20_000), (8_000, 6_000)):  # beyond PIL's own limit, and beyond ours only
        image = tmp_path / f"sketch-{width}.png"
        image.write_bytes(_png_header(width, height))
        assert width * height > MAX_SKETCH_PIXELS
        for read in (ocr_lines, line_summary):
            with pytest.raises(SketchError, match="megapixels are decoded") as err:
                read(image, use_cache=False)
            assert str(image) in str(err.value)
