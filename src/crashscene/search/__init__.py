"""Search-based testing: sample a scenario's VerifAI parameters adaptively to find where the ADS fails.

`search_scenario(scenario, out_dir, budget=..., sampler=..., objective=...)` runs
rounds of variations through render -> sample (parameters pinned) -> simulate
-> monitor, steering each round by the objective of the previous ones, and
writes every evaluated variation, the failures and the failure region.
"""
from crashscene.search.errors import SearchError
from crashscene.search.objective import OBJECTIVES
from crashscene.search.samplers import SAMPLERS
from crashscene.search.run import search_scenario

__all__ = ["OBJECTIVES", "SAMPLERS", "SearchError", "search_scenario"]
