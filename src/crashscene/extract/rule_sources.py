"""The record of which bundled cases each extraction rule was written from (issue 11).

An honest held-out figure needs to know which cases were looked at while a rule was written: `crashscene
eval --folds K` splits the bundled cases into K folds (`crashscene.evaluation.folds.assign_folds`) and reports a
fold as held out only when no rule below names one of its cases. Every rule rests on at least two cases
(`tests/extract/test_rule_sources.py` checks that, and that every case named exists).

Rules written in the first round (commits 45cdc70..c4787e2, before this record existed) were developed
looking at all 37 bundled cases; there is no held-out figure for them. `ROUND_ONE` says so, and the fold
report counts it only when asked (`include_round_one`).

Issue 11 rules were written looking at folds 0, 1 and 2 of `--folds 4` only; fold 3 (105203, 109525,
3-C1-2017-001, 3-C1-2017-006, 3-C2-2017-002, 3-C2-2018-008, 3-C4-2017-002, 3-C4-2017-004, 3-C4-2018-015)
was not read while writing them. (Their golden `collisions` evidence quotes were seen once, in a listing
of all goldens, before the split was made.)
"""
from __future__ import annotations

HELD_OUT = {"folds": 4, "fold": 3}  # the split the issue 11 rules were written under

ROUND_ONE = "all"  # the first round's rules: written from every bundled case

RULE_SOURCES: dict[str, tuple[str, ...]] = {
    # rules_collisions: the impact formulas ("the front of V2 struck the right side of V1", possessive planes,
    # "with its frontal plane", passive "was struck by", "collided head-on", "causing V1 to strike")
    "rules_collisions.impact_formula": ("100237", "100343", "103341", "108812", "117021", "119489", "119897",
                                        "121520", "3-C1-2018-012", "3-C4-2017-007"),
    "rules_collisions.possessive_and_with_its": ("3-C1-2018-003", "3-C1-2018-007", "3-C5-2018-004",
                                                 "3-C1-2018-010"),
    "rules_collisions.collided_head_on_at_fault": ("3-C2-2017-004", "3-C4-2018-010"),
    "rules_collisions.corner_by_configuration": ("3-C4-2018-012", "3-C5-2018-004", "3-C2-2017-004"),
    "rules_collisions.event_numbers_and_merge": ("3-C1-2018-003", "3-C4-2017-007", "3-C5-2018-004"),
    "rules_collisions.noun_impact_is_not_a_contact": ("3-C1-2018-003", "3-C5-2018-004"),
    # rules_road: who an unattributed stop or yield sign controls
    "rules_road.attribute_signs": ("100237", "117021"),
    # rules_oracle: rear-end codes read from the crash sequence, cause statements by their subject
    "rules_oracle.sequence_rear_end": ("109176", "120013", "3-C1-2018-003", "3-C1-2018-012", "3-C5-2018-004"),
    "rules_oracle.cause_statements": ("117330", "119897", "103341"),
}
