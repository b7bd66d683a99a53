"""`search --ego auto`: the ADS takes the seat V1's own swerve came at, derived from the DSL alone."""
from __future__ import annotations

from pathlib import Path

import pytest

from crashscene.dsl import load_file
from crashscene.search.seat import AUTO, ads_seat, resolve_seat

CASES = Path(__file__).resolve().parents[2] / "examples" / "ciren"


@pytest.mark.parametrize(("case", "seat"), [
    ("100343", "npc1"),          # V1 changed lanes into V2 travelling there
    ("103378", "npc1"),          # V1 drifted over the centre line into oncoming V2
    ("119897", "npc1"),          # V1 lost control across the centre line
    ("3-C4-2018-010", "npc1"),
    ("100237", "ego"),           # V2 is blamed: the hazard comes at V1
    ("103341", "ego"),           # V2 changes lanes itself: it challenges an ADS in V1's seat
    ("105203", "ego"),           # V1 clipped V2's rear: V2 had nothing to avoid it with
    ("3-C1-2018-012", "ego"),    # V2 is parked: there is no other seat
    ("120013", "ego"),           # V1 went straight on: its seat is the test
])
def test_the_ads_takes_the_seat_the_hazard_came_at(case, seat):
    scenario = load_file(CASES / case / "golden.yaml")
    assert ads_seat(scenario) == seat
    assert resolve_seat(scenario, AUTO) == seat and resolve_seat(scenario, "npc1") == "npc1"
