"""Turning Scenic simulations (Newtonian, CARLA) into the tables of `crashscene.traces`.

Scenic keeps only positions in `result.trajectory`. `StateRecorder` is a mixin
for any Scenic `Simulation` class whose `currentState()` records, per object and
step, the centre, heading and speed; `tracks_from_trajectory` turns that into
per-actor tracks, the state protocol of `crashscene.simulate.recorder`,
which finds footprint contacts (Scenic's simulators report none) and derives
every other trace column, the same way for every backend.

Angles: Scenic heading is 0 = +y, counter-clockwise; crashscene yaw is
0 = +x (OpenDRIVE), so yaw = heading + pi/2, wrapped to [-pi, pi] (`geometry.wrap_angle`).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from crashscene.geometry import wrap_angle
from crashscene.scene import SampledScene
from crashscene.simulate.backend import SimulationError
from crashscene.simulate.recorder import Track

SCENIC_TO_YAW = math.pi / 2  # [rad] yaw = Scenic heading + pi/2


def yaw_from_heading(heading: np.ndarray | float) -> np.ndarray | float:
    """Scenic heading [rad] (0 = +y) -> crashscene yaw [rad] (0 = +x), wrapped to [-pi, pi]."""
    return wrap_angle(np.asarray(heading) + SCENIC_TO_YAW, exact=True)


class StateRecorder:
    """Mixin for a Scenic `Simulation` subclass: record (x, y, heading, speed) of every object each step.

    Put it first in the bases (`class T(StateRecorder, NewtonianSimulation)`) so
    this `currentState` wins; Scenic stores its return value in
    `simulation.result.trajectory`, one entry per step (the initial state included).
    """

    def currentState(self):
        states = []
        for obj in self.objects:
            speed = obj.speed
            if speed is None:  # some interfaces leave it unset before the first step
                speed = math.hypot(obj.velocity[0], obj.velocity[1])
            states.append((float(obj.position[0]), float(obj.position[1]), float(obj.heading), float(speed)))
        return tuple(states)


def object_roles(objects: Sequence, scene: SampledScene) -> list[str]:
    """The DSL role of each Scenic object of a simulated scene, in object order.

    Rendered programs tag each object with a `cs_role` property (hand-written
    ones may use `role`); untagged objects are matched to the scene's actors in
    order, the ego object first, as Scenic lists them.
    """
    roles = [getattr(obj, "cs_role", None) or getattr(obj, "role", None) for obj in objects]
    known = {actor.role for actor in scene.actors}
    if all(isinstance(role, str) and role in known for role in roles):
        return roles
    if len(objects) != len(scene.actors):
        raise SimulationError(f"variation {scene.index}: the Scenic scene has {len(objects)} objects but the "
                              f"sampled scene has {len(scene.actors)} actors "
                              f"({', '.join(a.role for a in scene.actors)}); tag each object with `cs_role`")
    return [actor.role for actor in scene.actors]


def tracks_from_trajectory(trajectory: Sequence[Sequence[tuple[float, float, float, float]]],
                           roles: Sequence[str]) -> dict[str, Track]:
    """Per-role tracks from a `StateRecorder` trajectory (steps x objects x (x, y, heading, speed))."""
    states = np.asarray(trajectory, dtype=np.float64)  # (steps, objects, 4)
    if states.ndim != 3 or states.shape[1] != len(roles) or states.shape[2] != 4:
        raise SimulationError(f"unexpected Scenic trajectory shape {states.shape}; expected (steps, "
                              f"{len(roles)}, 4): was the simulation class built with StateRecorder?")
    return {role: Track(role=role, x=states[:, i, 0].copy(), y=states[:, i, 1].copy(),
                        yaw=yaw_from_heading(states[:, i, 2]), speed=np.abs(states[:, i, 3]))
            for i, role in enumerate(roles)}
