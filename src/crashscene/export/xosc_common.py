"""Pieces shared by the logical and the concrete OpenSCENARIO files: version, header date, vehicles, atomic writes.

Entity reference point: the vehicle's centre (the bounding box is centred on it), so
that exported positions are the trace's and the scenes' (x, y) [m] unchanged.
"""
from __future__ import annotations

import datetime as dt
import os
from pathlib import Path

from scenariogeneration import xosc

OSC_MINOR = 2  # ASAM OpenSCENARIO XML 1.2
AUTHOR = "crashscene"
# Fixed header date: the same inputs give the same bytes (the export is a function of them, not of the clock).
HEADER_DATE = dt.datetime(2026, 1, 1, 0, 0, 0)
VEHICLE_HEIGHT = {"car": 1.5, "truck": 3.5, "motorcycle": 1.3}  # [m]
CATEGORY = {"car": xosc.VehicleCategory.car, "truck": xosc.VehicleCategory.truck,
            "motorcycle": xosc.VehicleCategory.motorbike}
MAX_SPEED = 70.0  # [m/s] performance limits declared for every vehicle
MAX_ACCEL = 10.0  # [m/s2]
MAX_DECEL = 10.0  # [m/s2]
EGO_PROPERTY = ("type", "ego_vehicle")  # CARLA ScenarioRunner spawns this entity as the hero vehicle


def vehicle(name: str, kind: str, length: float, width: float, ego: bool) -> xosc.Vehicle:
    """An OpenSCENARIO vehicle of DSL type `kind` (car, truck, motorcycle), `name` being its model (blueprint)."""
    height = VEHICLE_HEIGHT.get(kind, 1.5)
    box = xosc.BoundingBox(width, length, height, 0.0, 0.0, height / 2)
    wheel = 0.35 * 2 if kind != "truck" else 1.0  # [m] wheel diameter
    front = xosc.Axle(0.5, wheel, 0.85 * width, 0.3 * length, wheel / 2)
    rear = xosc.Axle(0.0, wheel, 0.85 * width, -0.3 * length, wheel / 2)
    veh = xosc.Vehicle(name, CATEGORY.get(kind, xosc.VehicleCategory.car), box, front, rear, MAX_SPEED, MAX_ACCEL,
                       MAX_DECEL)
    if ego:
        veh.add_property(*EGO_PROPERTY)
    return veh


def write_atomic(document, path: Path) -> Path:
    """Write a scenariogeneration document (`write_xml`) to a temporary name beside `path`, then rename it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        document.write_xml(str(tmp))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def copy_atomic(source: Path, path: Path) -> Path:
    """Copy a file to `path` via a temporary name and a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(Path(source).read_bytes())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def stop_after(seconds: float | str) -> xosc.Trigger:
    """A stop trigger firing when the simulation time exceeds `seconds` [s] (a number or a parameter expression)."""
    return xosc.ValueTrigger("horizon_reached", 0, xosc.ConditionEdge.rising,
                             xosc.SimulationTimeCondition(seconds, xosc.Rule.greaterThan), "stop")


def at_time(name: str, seconds: float | str) -> xosc.ValueTrigger:
    """A start trigger firing when the simulation time exceeds `seconds` [s]."""
    return xosc.ValueTrigger(name, 0, xosc.ConditionEdge.rising,
                             xosc.SimulationTimeCondition(seconds, xosc.Rule.greaterThan))
