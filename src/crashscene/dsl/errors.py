"""Diagnostics and the exception family of the DSL stage.

Every problem is addressed the same way: the file, the field path
(`actors.npc1.position.heading`), the line when YAML gives one, the bad value
and what is allowed.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True)
class Diagnostic:
    """One problem found in a scenario file."""

    message: str
    path: str = ""
    file: str | None = None
    line: int | None = None
    value: Any = None
    allowed: list[str] = field(default_factory=list)
    severity: Severity = Severity.ERROR

    def __str__(self) -> str:
        where = self.file or "<scenario>"
        if self.line is not None:
            where += f":{self.line}"
        text = f"{where}: {self.severity}: "
        if self.path:
            text += f"{self.path}: "
        text += self.message
        if self.value is not None:
            text += f" (got {_short(self.value)})"
        if self.allowed:
            text += f"; allowed: {', '.join(self.allowed)}"
        return text

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["severity"] = str(self.severity)
        data["value"] = _short(self.value) if self.value is not None else None
        return data


def _short(value: Any, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class DslError(Exception):
    """A scenario that cannot be read or is invalid; carries every diagnostic found."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = diagnostics
        super().__init__("\n".join(str(d) for d in diagnostics))
