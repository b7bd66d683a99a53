"""The search stage's exception family."""
from __future__ import annotations


class SearchError(Exception):
    """A search cannot run: bad budget, sampler, objective, or a scenario with nothing to search."""
