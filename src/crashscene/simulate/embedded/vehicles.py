"""Vehicle limits per DSL actor type, for the kinematic bicycle model."""
from __future__ import annotations

import math

from pydantic import BaseModel, ConfigDict, Field

from crashscene.dsl.tokens import ActorType
from crashscene.vehicle_mass import MASS


class VehicleLimits(BaseModel):
    """Physical limits of one vehicle type (the body size comes from the sampled scene)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    wheelbase_ratio: float = Field(0.6, gt=0, le=1, description="wheelbase / body length [-]")
    accel_max: float = Field(3.0, gt=0, description="[m/s2] full throttle")
    brake_max: float = Field(8.0, gt=0, description="[m/s2] emergency braking")
    brake_comfort: float = Field(3.0, gt=0, description="[m/s2] comfortable braking")
    steer_max: float = Field(math.radians(35), gt=0, description="[rad] front wheel angle")
    steer_rate: float = Field(math.radians(60), gt=0, description="[rad/s] front wheel angle rate")
    lat_accel_comfort: float = Field(2.5, gt=0, description="[m/s2] lateral acceleration a driver accepts in turns")
    speed_max: float = Field(60.0, gt=0, description="[m/s]")
    mass: float = Field(MASS[ActorType.CAR], gt=0, description="[kg] impulse exchange at contact (vehicle_mass)")


VEHICLE_LIMITS: dict[str, VehicleLimits] = {
    "car": VehicleLimits(),
    "truck": VehicleLimits(wheelbase_ratio=0.55, accel_max=1.5, brake_max=6.0, brake_comfort=2.5,
                           steer_max=math.radians(30), steer_rate=math.radians(40), lat_accel_comfort=2.0,
                           speed_max=35.0, mass=MASS[ActorType.TRUCK]),
    "motorcycle": VehicleLimits(wheelbase_ratio=0.65, accel_max=4.5, brake_max=7.0, brake_comfort=3.5,
                                steer_max=math.radians(30), steer_rate=math.radians(90), lat_accel_comfort=3.0,
                                speed_max=60.0, mass=MASS[ActorType.MOTORCYCLE]),
}


def limits_for(actor_type: str) -> VehicleLimits:
    """Limits of a DSL type token; unknown tokens fall back to a car."""
    return VEHICLE_LIMITS.get(actor_type, VEHICLE_LIMITS["car"])
