"""Campaigns: many cases x thousands of variations, chunked, on a process pool or Ray, stored in DuckDB.

- `runner.run_campaign(cases, out_dir, CampaignConfig(...), worker=None) -> CampaignSummary`
- `store.Store`: the database (`OUT/campaign.duckdb`), written one transaction per chunk
- `engines`: `LocalEngine` (process pool) and `RayEngine` (Ray tasks)
- `worker.simulate_chunk`: the default worker (simulate + monitor one chunk)
"""
from crashscene.campaign.errors import CampaignError, ChunkFailed
from crashscene.campaign.model import ChunkResult, ChunkTask, SimOptions
from crashscene.campaign.runner import CampaignConfig, CampaignSummary, plan_chunks, run_campaign, summarize_runs
from crashscene.campaign.store import DB_NAME, Store

__all__ = ["DB_NAME", "CampaignConfig", "CampaignError", "CampaignSummary", "ChunkFailed", "ChunkResult",
           "ChunkTask", "SimOptions", "Store", "plan_chunks", "run_campaign", "summarize_runs"]
