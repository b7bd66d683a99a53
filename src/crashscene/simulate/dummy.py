"""The smallest backend, shipped in the package like Scenic's `DummySimulator`.

Every actor keeps its sampled heading and speed and drives straight ahead: no
engine, no dynamics, no reaction to anything. It exercises the whole pipeline
(sampling, recording, monitoring, campaigns) without a simulator, and it is the
template of a new backend: one module whose `run_scene` fills the state
protocol of `crashscene.simulate.recorder` (each actor's x, y, yaw and speed
per step), after which the shared recorder fills every trace column.
Selected with `--backend dummy`.
"""
from __future__ import annotations

import numpy as np

from crashscene.scene import SampledScene
from crashscene.simulate.backend import SimulationRequest, Simulator
from crashscene.simulate.recorder import SceneRun, Track, find_contacts


class DummySimulator(Simulator):
    """Straight-line, constant-speed motion of every actor from its sampled pose."""

    name = "dummy"

    def run_scene(self, request: SimulationRequest, scene: SampledScene) -> SceneRun:
        dt = self.settings.dt
        t = np.arange(self.settings.steps + 1) * dt  # [s]
        tracks = {actor.role: Track(role=actor.role, x=actor.x + actor.speed * t * np.cos(actor.yaw),
                                    y=actor.y + actor.speed * t * np.sin(actor.yaw), yaw=np.full(t.shape, actor.yaw),
                                    speed=np.full(t.shape, actor.speed))
                  for actor in scene.actors}
        sizes = {actor.role: (actor.length, actor.width) for actor in scene.actors}
        return SceneRun(tracks, contacts=find_contacts(tracks, sizes, dt))
