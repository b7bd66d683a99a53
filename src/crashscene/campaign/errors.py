"""The campaign stage's exception family."""
from __future__ import annotations


class CampaignError(Exception):
    """A campaign cannot start, resume or finish; the message says what and where."""


class ChunkFailed(CampaignError):
    """One chunk's worker raised; the campaign records it and goes on with the others."""

    def __init__(self, key: str, message: str):
        super().__init__(f"chunk {key}: {message}")
        self.key = key
        self.message = message
