"""The one table of unit factors and physical constants.

Everything inside crashscene is SI (m, s, m/s, m/s2, rad); mph and km/h
appear only at the edges (the DSL's `speed_mph`, the reports' km/h, CARLA's
agents), converted with these factors.
"""
from __future__ import annotations

MPH = 0.44704  # [m/s] per mph (exact: 1609.344 m / 3600 s)
KMH_PER_MPH = 1.609344  # [km/h] per mph (exact)
KMH_PER_MPS = 3.6  # [km/h] per m/s
G = 9.81  # [m/s2] gravitational acceleration
