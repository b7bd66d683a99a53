"""Drivers: every actor has one. NPC behaviour drivers with injected dispositions, the reference ADS,
and the step interface a user ADS implements (`crashscene.simulate.drivers.base`)."""
from crashscene.simulate.drivers.ads import (
           ReferenceADS,
           ReferenceAdsParams,
           load_driver,
)
from crashscene.simulate.drivers.base import Action, Driver, DriverContext, Observation
from crashscene.simulate.drivers.behaviors import BehaviorDriver

__all__ = ["Action", "BehaviorDriver", "Driver", "DriverContext", "Observation", "ReferenceADS",
           "ReferenceAdsParams", "load_driver"]
