"""The exception family of the monitor stage.

Every message names where the problem is (run directory, rulebook file, rule
code, parameter), the bad value and what is allowed.
"""
from __future__ import annotations


class MonitorError(Exception):
    """Base of every error the monitor raises on bad input."""


class RulebookError(MonitorError):
    """A rulebook file (or mapping) that cannot be read or names unknown rules or bad parameters."""


class TraceError(MonitorError):
    """Trace tables that do not follow `crashscene.traces`."""


class RegistryError(MonitorError):
    """A rule class that cannot be registered (bad or clashing code)."""
