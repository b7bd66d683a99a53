"""Mass by DSL actor type: the one table the embedded simulator's impulse exchange and the monitor's delta-v
estimate (for backends that record none) both read, so that a contact's delta-v does not depend on who computed it."""
from __future__ import annotations

from crashscene.dsl.tokens import ActorType

MASS: dict[str, float] = {  # [kg] curb mass plus occupants
    ActorType.CAR: 1500.0,
    ActorType.TRUCK: 15000.0,  # dsl.md's heavy truck: a semi or tractor-trailer (about 15 t empty, 36 t loaded at
    # the US 80,000 lb limit), a bus (12-18 t), a box truck
    ActorType.MOTORCYCLE: 300.0,  # with its rider
}


def mass_of(actor_type: str) -> float:
    """Mass [kg] of a DSL type token; unknown tokens weigh as a car."""
    return MASS.get(str(actor_type), MASS[ActorType.CAR])
