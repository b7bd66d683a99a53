"""The variations the report draws: chosen per chunk, pruned as chunks finish, the same whatever the chunking."""
from __future__ import annotations

import pyarrow as pa

from crashscene.campaign import CampaignConfig, Store, keep, run_campaign
from crashscene.monitor.result import RULE_RESULT_SCHEMA
from tests.report.conftest import EXAMPLES
from tests.report.fakes import fake_chunk_with_traces


def _rules(rows: list[tuple[int, str, float, bool]]) -> pa.Table:
    return pa.Table.from_pylist([{"variation": v, "actor": "ego", "code": "CVC_21703", "verdict": verdict,
                                  "robustness": rob, "is_ads": ads} for v, verdict, rob, ads in rows],
                                RULE_RESULT_SCHEMA)


def test_pick_chooses_per_reason_among_valid_variations():
    variations = [dict(variation=10, valid=False, reproduced=True, collided=True),
                  dict(variation=11, valid=True, reproduced=False, collided=False),
                  dict(variation=12, valid=True, reproduced=True, collided=True),
                  dict(variation=13, valid=True, reproduced=True, collided=False)]
    rules = _rules([(11, "satisfied", 0.7, True), (12, "satisfied", 0.2, True), (13, "violated", -0.4, True),
                    (11, "violated", -5.0, False)])  # a violation by a non-ADS actor is not the ADS's
    collisions = pa.Table.from_pylist([{"variation": 12, "involves_ads": False}])
    shown = {r["reason"]: (r["variation"], r["score"]) for r in keep.pick(variations, rules, collisions).to_pylist()}
    assert shown["first_reproducing"] == (12, 12.0)  # 10 reproduced but is invalid
    assert shown["first_ads_violation"] == (13, 13.0)
    assert shown["closest_robustness"] == (13, -0.4)
    assert shown["first_collision"] == (12, 12.0) and shown["first_variation"] == (11, 11.0)
    assert "closest_ttc" not in shown  # no criticality given
    ttc = keep.pick(variations, rules, collisions, ttc={11: 2.5, 12: 0.8, 13: 1.1}).to_pylist()
    assert [(r["variation"], r["score"]) for r in ttc if r["reason"] == "closest_ttc"] == [(12, 0.8)]
    ads_hit = pa.Table.from_pylist([{"variation": 11, "involves_ads": True}])
    low = [r for r in keep.pick(variations, rules, ads_hit).to_pylist() if r["reason"] == "closest_robustness"]
    assert low[0]["variation"] == 11 and low[0]["score"] == keep.COLLISION_SCORE  # a collision is the lowest


def _kept(out, chunk_size: int) -> tuple[list[dict], list[dict], list[dict]]:
    run_campaign([EXAMPLES / "120013"], out, CampaignConfig(n=40, chunk_size=chunk_size, workers=1,
                                                            dsl_name="golden.yaml"),
                 worker=fake_chunk_with_traces, quiet=True)
    with Store(out, read_only=True) as store:
        return (store.query("SELECT mode, reason, variation, score FROM shown ORDER BY ALL"),
                store.query("SELECT mode, variation, count(*) AS n FROM shown_traces GROUP BY ALL ORDER BY ALL"),
                store.query("SELECT mode, variation, verdict, reproduced FROM variations WHERE valid ORDER BY ALL"))


def test_kept_variations_are_the_runs_best_whatever_the_chunking(tmp_path):
    shown, kept, rows = _kept(tmp_path / "chunks-of-5", 5)
    for mode in ("reproduce", "test"):
        mine = {r["reason"]: r["variation"] for r in shown if r["mode"] == mode}
        assert len(mine) == sum(r["mode"] == mode for r in shown)  # one variation per reason after pruning
        assert mine["first_reproducing"] == min(r["variation"] for r in rows if r["mode"] == mode and r["reproduced"])
        assert mine["first_variation"] == min(r["variation"] for r in rows if r["mode"] == mode)
        assert {k["variation"] for k in kept if k["mode"] == mode} == set(mine.values())  # no orphan traces
    assert _kept(tmp_path / "one-chunk", 40)[:2] == (shown, kept)
