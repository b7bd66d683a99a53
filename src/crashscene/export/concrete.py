"""Concrete scenarios (`variations/<i>.xosc`): one simulated variation replayed by any OpenSCENARIO player.

Every actor starts where the trace starts (WorldPosition, heading = trace yaw [rad],
0 = +x, counter-clockwise: OpenSCENARIO's convention) at its first speed, and follows a
FollowTrajectoryAction whose polyline vertices are the trace's samples: vertex time =
trace `t` [s] (absolute timing, scale 1, offset 0), position = (x, y) [m], heading = yaw.
The variation's sampled parameter values are declared as parameters (for the record).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
from scenariogeneration import xosc

from crashscene.export.errors import ExportError
from crashscene.export.xosc_common import AUTHOR, HEADER_DATE, OSC_MINOR, at_time, stop_after, vehicle
from crashscene.scene import SampledScene


def build_variation(variation: int, scene: SampledScene, traces: pa.Table, actors: pa.Table, params: str | None,
                    map_ref: str = "../map.xodr", scenario_id: str | None = None) -> xosc.Scenario:
    """The concrete scenario of one variation: `traces` and `actors` rows of that variation (any order)."""
    declared = xosc.ParameterDeclarations()
    for name, value in sorted(json.loads(params or "{}").items()):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            continue  # scene settings (weather preset, map name) are in the files themselves
        declared.add_parameter(xosc.Parameter(name, xosc.ParameterType.double, repr(float(value))))
    entities, init = xosc.Entities(), xosc.Init()
    story = xosc.Story(f"variation_{variation}")
    act = xosc.Act("replay", at_time("replay_start", 0.0))
    info = {row["actor"]: row for row in actors.to_pylist()}
    blueprints = {a.role: a.blueprint for a in scene.actors}
    roles = [a.role for a in scene.actors if a.role in info]
    t_end = 0.0
    for role in roles:
        rows = traces.filter(pc.equal(traces["actor"], role)).sort_by("step")
        if rows.num_rows < 2:
            raise ExportError(f"variation {variation}: actor {role} has {rows.num_rows} trace row(s); "
                              "a trajectory needs at least 2 (was the variation simulated?)")
        t, x, y, yaw, speed = (rows[c].to_numpy(zero_copy_only=False) for c in ("t", "x", "y", "yaw", "speed"))
        bad = ~(np.isfinite(t) & np.isfinite(x) & np.isfinite(y) & np.isfinite(yaw))
        if bad.any():
            k = int(np.argmax(bad))
            raise ExportError(f"variation {variation}: actor {role} has a non-finite trace sample at step "
                              f"{rows['step'][k].as_py()} (t={t[k]!r}, x={x[k]!r}, y={y[k]!r}, yaw={yaw[k]!r})")
        meta = info[role]
        entities.add_scenario_object(role, vehicle(blueprints.get(role, "vehicle"), meta["type"], meta["length"],
                                                   meta["width"], role == "ego"))
        init.add_init_action(role, xosc.TeleportAction(xosc.WorldPosition(float(x[0]), float(y[0]), 0.0,
                                                                          float(yaw[0]))))
        v0 = float(speed[0]) if np.isfinite(speed[0]) else 0.0
        init.add_init_action(role, xosc.AbsoluteSpeedAction(v0, xosc.TransitionDynamics(
            xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0.0)))
        polyline = xosc.Polyline([float(v) for v in t],
                                 [xosc.WorldPosition(float(a), float(b), 0.0, float(h)) for a, b, h in zip(x, y, yaw)])
        trajectory = xosc.Trajectory(f"{role}_trace", False)
        trajectory.add_shape(polyline)
        action = xosc.FollowTrajectoryAction(trajectory, xosc.FollowingMode.position,
                                             xosc.ReferenceContext.absolute, 1, 0)
        event = xosc.Event(f"{role}_follow_trace", xosc.Priority.override)
        event.add_action(f"{role}_replay", action)
        event.add_trigger(at_time(f"{role}_start", 0.0))
        maneuver = xosc.Maneuver(f"{role}_replay")
        maneuver.add_event(event)
        group = xosc.ManeuverGroup(f"{role}_group")
        group.add_actor(role)
        group.add_maneuver(maneuver)
        act.add_maneuver_group(group)
        t_end = max(t_end, float(t[-1]))
    if not roles:
        raise ExportError(f"variation {variation}: no actor of the scene has a trace")
    story.add_act(act)
    board = xosc.StoryBoard(init, stop_after(t_end))
    board.add_story(story)
    return xosc.Scenario(f"crashscene {scenario_id or 'scenario'} variation {variation} (replay of the simulated trace)",
                         AUTHOR, declared, entities, board, xosc.RoadNetwork(map_ref), xosc.Catalog(),
                         osc_minor_version=OSC_MINOR, creation_date=HEADER_DATE)
