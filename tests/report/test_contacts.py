"""The contact table: reported crash sequence against simulated contacts, matched as rules.md says."""
from __future__ import annotations

from crashscene.report.contacts import contact_table, labels_of, reported_contacts

RAW = {"actors": {"ego": {"label": "V1"}, "npc1": {"label": "V2"}, "npc2": {}},
       "collisions": [{"striking": "npc1", "struck": "ego", "striking_area": "front", "struck_area": "rear",
                       "class": "rear_end"},
                      {"striking": "ego", "struck": "npc2", "striking_area": "front", "struck_area": "front",
                       "class": "head_on"}]}


def _sim(a, b, cls, t, area_a=None, area_b=None, dva=None, dvb=None):
    return {"actor_a": a, "actor_b": b, "class": cls, "t": t, "area_a": area_a, "area_b": area_b,
            "delta_v_a": dva, "delta_v_b": dvb}


def test_labels_and_reported_contacts():
    assert labels_of(RAW) == {"ego": "V1", "npc1": "V2", "npc2": "V3"}
    assert reported_contacts({"actors": {}}) is None and reported_contacts({"collisions": []}) == []


def test_sequence_in_order_matches_and_areas_are_their_own_figure():
    sim = [_sim("ego", "npc1", "rear_end", 3.0, "rear", "front", 4.1, 3.9), _sim("ego", "npc2", "sideswipe", 3.5),
           _sim("ego", "npc2", "head_on", 4.0, "left", "front")]
    rows = contact_table(reported_contacts(RAW), sim, labels_of(RAW))
    assert [r["status"] for r in rows] == ["match", "match", "not reported"]
    assert rows[0]["reported"]["pair"] == "V2 → V1" and rows[0]["simulated"]["pair"] == "V1-V2"
    assert rows[0]["areas"] is True and rows[1]["areas"] is False  # V1 touched with its left, not its front
    assert rows[0]["simulated"]["delta_v"] == "V1 4.1, V2 3.9"
    assert rows[2]["simulated"]["class"] == "sideswipe"


def test_a_wrong_first_contact_is_a_mismatch_and_a_missing_one_has_no_partner():
    sim = [_sim("ego", "npc2", "head_on", 2.0)]
    rows = contact_table(reported_contacts(RAW), sim, labels_of(RAW))
    assert [r["status"] for r in rows] == ["mismatch", "mismatch"]
    assert rows[0]["simulated"]["pair"] == "V1-V3"  # the first simulated contact sits beside the first reported
    assert rows[1]["simulated"] is None  # the later contact never happened after a matched one
    assert [r["status"] for r in contact_table(None, sim, {})] == ["simulated"]
    assert contact_table([], [], {}) == []
