"""Fixtures for campaign tests: small case sets from the bundled CIREN examples."""
from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples" / "ciren"


@pytest.fixture
def two_cases() -> list[Path]:
    return [EXAMPLES / "120013", EXAMPLES / "100237"]
