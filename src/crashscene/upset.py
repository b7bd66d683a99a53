"""When an impact takes a vehicle out of its driver's control: the thresholds the simulator and the monitor share.

An impact that changes a vehicle's velocity by less than CONTROL_DELTA_V and its
yaw rate by less than CONTROL_YAW_RATE leaves its driver in control (a light
touch, a heavy truck that barely slowed): the embedded simulator lets that driver
drive on, and the monitor goes on judging the driver's manoeuvres. A vehicle the
impact upsets moves from then on as the impact and its tyres make it, not as its
driver chooses: the simulator lets it slide, and the monitor stops judging it
(rules.md judges driving; see `crashscene.monitor.judging`).
"""
from __future__ import annotations

import numpy as np

CONTROL_DELTA_V = 2.5  # [m/s] an impact changing a vehicle's velocity by less (about the 5 mph a bumper is built
# to take, FMVSS 581's former test speed) and its yaw rate by less than CONTROL_YAW_RATE leaves its driver in control
CONTROL_YAW_RATE = 0.5  # [rad/s]


def upsets(dv: np.ndarray, dw: np.ndarray) -> np.ndarray:
    """Whether an impact that changed a vehicle's velocity by dv [m/s] and its yaw rate by dw [rad/s] takes it out
    of its driver's control (else the driver drives on: a heavy truck that barely slowed, a light touch)."""
    return (np.asarray(dv) >= CONTROL_DELTA_V) | (np.abs(np.asarray(dw)) >= CONTROL_YAW_RATE)
