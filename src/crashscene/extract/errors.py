"""The exception family of the extract stage.

Every message names what was wrong, where (file, field) and what is allowed,
so the CLI can print it as is, without a traceback.
"""
from __future__ import annotations

from pathlib import Path


class ExtractError(Exception):
    """Base of every error raised while turning a report into a scenario."""

    def __init__(self, message: str, path: str | Path | None = None):
        self.path = str(path) if path is not None else None
        self.message = message
        super().__init__(f"{self.path}: {message}" if self.path else message)


class CaseInputError(ExtractError):
    """The report input (case folder, narrative, sketch path) is missing, unreadable or not text."""


class SketchError(ExtractError):
    """The sketch image cannot be read or OCR is unavailable."""


class RulesError(ExtractError):
    """The rule-based extractor could not produce a valid scenario from the report."""
