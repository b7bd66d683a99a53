"""The report stage's exception family."""
from __future__ import annotations


class ReportError(Exception):
    """The report cannot be written; the message names the folder or file and what is missing."""
