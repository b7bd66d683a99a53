"""Shared fixtures: data paths relative to the repository, never ../shared."""
from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples" / "ciren"
CARLA_MAPS = Path(__file__).resolve().parent / "data" / "maps" / "carla"
CASES = sorted(p.name for p in EXAMPLES.iterdir() if (p / "golden.yaml").exists())


@pytest.fixture
def examples_dir() -> Path:
    return EXAMPLES


@pytest.fixture
def carla_maps_dir() -> Path:
    return CARLA_MAPS
