"""Which seat the ADS takes in a test-mode search (`crashscene search --ego auto`).

Test mode hands the ADS the ego (V1) by default. When the report's hazard is V1's
own swerve (the oracle blames V1 and nobody else, and V1's behaviour is a lateral
manoeuvre: a lane change, crossing the centre line, overtaking, losing control,
leaving the road), an ADS in V1's seat simply does not make that error, and the
vehicle V1 met keeps its lane: nothing in the scenario challenges the ADS, and a
search has nothing to find. The test a test engineer would run instead puts the
ADS in the seat of the driver the hazard came at: the other actor of V1's first
written contact, when it drives straight on and is not struck in its rear (a car
hit from behind has nothing to avoid it with). V1 then becomes an NPC that keeps
its behaviour and its dispositions, as with `--ego ROLE`.
"""
from __future__ import annotations

from crashscene.dsl import Scenario
from crashscene.render.plan import LATERAL_BEHAVIORS

AUTO = "auto"


def ads_seat(scenario: Scenario) -> str:
    """The role the ADS is tested in: `ego`, or the actor V1's own swerve came at (module docstring)."""
    blamed = {entry.actor for entry in scenario.oracle}
    ego = scenario.actors["ego"]
    if blamed != {"ego"} or ego.behavior not in LATERAL_BEHAVIORS:
        return "ego"
    first = next((c for c in (scenario.collisions or []) if "ego" in (c.striking, c.struck)), None)
    if first is None:
        return "ego"
    partner, area = (first.struck, first.struck_area) if first.striking == "ego" else (first.striking, None)
    other = scenario.actors.get(partner)
    if other is None or other.behavior != "go_forward" or area == "rear":
        return "ego"
    return partner


def resolve_seat(scenario: Scenario, role: str) -> str:
    """`role`, with AUTO replaced by `ads_seat`."""
    return ads_seat(scenario) if role == AUTO else role
