"""Recording the embedded simulation into the tables of `crashscene.traces`.

Per step the recorder stores the state and the route-derived quantities in
(T+1, V, A) arrays; at the end of a chunk it derives the map lookups (lane under
the centre, junction, opposing lane, centre-line intrusion) in one vectorised
pass, checks each variation's validity and converts everything to Arrow.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

from crashscene.dsl.tokens import LANE_CHANGES, STANDING
from crashscene.geometry import LANE_WIDTH
from crashscene.scene import SampledScene
from crashscene.simulate.backend import SimulationSettings
from crashscene.simulate.roads import MARKERS, RoadMap
from crashscene.simulate.tables import actors_table, collisions_table, variations_table
from crashscene.traces import CONTROLS, MANEUVERS, SIGNAL_STATES, TRACE_SCHEMA

LANE_CHANGE_BEHAVIORS = (*LANE_CHANGES, "overtake")
NEVER_MOVED = 0.5  # [m] an ego that travels less than this never moved
STILL_BEHAVIORS = STANDING


class Recorder:
    def __init__(self, roadmap: RoadMap, settings: SimulationSettings):
        self.roadmap = roadmap
        self.settings = settings
        self.trace_parts: list[pa.Table] = []
        self.collision_rows: list[dict] = []
        self.valid: list[bool] = []
        self.reasons: list[str | None] = []
        self.lane_uids = np.array([lane.uid for lane in roadmap.lanes] + [None], dtype=object)
        self.junction_uids = np.array([j.uid for j in roadmap.junctions] + [None], dtype=object)

    # ------------------------------------------------------------ per chunk
    def begin(self, batch) -> None:
        n_t = self.settings.steps + 1
        shape = (n_t, batch.n_variations, batch.n_actors)
        self.batch = batch
        self.f = {name: np.full(shape, np.nan) for name in (
            "t", "x", "y", "yaw", "speed", "accel", "lat_accel", "route_s", "d", "route_yaw",
            "stop_line_dist", "speed_limit", "lat_cmd", "d_ref")}
        self.i = {name: np.zeros(shape, dtype=np.int32) for name in (
            "route_lane", "control", "signal", "maneuver", "junction", "lost")}
        self.spawn: list[str | None] = [None] * batch.n_variations
        self.first_collision = np.full(batch.n_variations, np.inf)

    def record(self, step: int, t: float, state, geo, lat_cmd: np.ndarray) -> None:
        f, i = self.f, self.i
        f["t"][step] = t
        f["x"][step] = state.x
        f["y"][step] = state.y
        f["yaw"][step] = state.yaw
        f["speed"][step] = state.v
        f["accel"][step] = state.a
        f["lat_accel"][step] = state.v * state.yaw_rate
        f["route_s"][step] = state.s - self.batch.s0
        f["d"][step] = state.d
        f["route_yaw"][step] = geo.route_yaw
        f["stop_line_dist"][step] = geo.stop_line_dist
        f["speed_limit"][step] = geo.speed_limit
        f["lat_cmd"][step] = lat_cmd
        f["d_ref"][step] = state.d_ref
        i["route_lane"][step] = geo.route_lane
        i["control"][step] = geo.control
        i["signal"][step] = geo.signal
        i["maneuver"][step] = geo.maneuver
        i["junction"][step] = geo.junction
        i["lost"][step] = state.lost

    def collision(self, hit: np.ndarray, a: int, b: int, t, state, initial: bool,
                  delta_v: tuple[np.ndarray, np.ndarray] | None = None,
                  point: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Record contact onsets; `t` [s] is a scalar or a per-variation array (contact inside the step);
        `delta_v` [m/s] each vehicle's velocity change and `point` [m] the contact point, per variation."""
        batch = self.batch
        roles = [c.role for c in batch.columns]
        times = np.broadcast_to(np.asarray(t, dtype=float), (batch.n_variations,))
        for v in np.nonzero(hit)[0]:
            t = float(times[v])
            if initial:
                self.spawn[v] = self.spawn[v] or f"spawn overlap: {roles[a]} and {roles[b]} overlap at t=0"
                continue
            self.first_collision[v] = min(self.first_collision[v], t)
            self.collision_rows.append({
                "variation": batch.scenes[v].index, "t": round(t, 6), "actor_a": roles[a], "actor_b": roles[b],
                "speed_a": float(state.v[v, a]), "speed_b": float(state.v[v, b]),
                "yaw_a": float(state.yaw[v, a]), "yaw_b": float(state.yaw[v, b]),
                "x": float(point[0][v]) if point else float((state.x[v, a] + state.x[v, b]) / 2),
                "y": float(point[1][v]) if point else float((state.y[v, a] + state.y[v, b]) / 2),
                "delta_v_a": float(delta_v[0][v]) if delta_v else None,
                "delta_v_b": float(delta_v[1][v]) if delta_v else None,
            })

    def end(self, batch, state) -> None:
        self._validity(batch, state)
        self.trace_parts.append(self._traces(batch))
        del self.f, self.i

    def absorb(self, other: Recorder) -> None:
        """The chunks `other` recorded (with these settings, on this map), as if recorded here after this one's."""
        self.trace_parts.extend(other.trace_parts)
        self.collision_rows.extend(other.collision_rows)
        self.valid.extend(other.valid)
        self.reasons.extend(other.reasons)

    # ------------------------------------------------------------ validity
    def _validity(self, batch, state) -> None:
        anchor = batch.anchor
        anchor_col = batch.columns[anchor]
        for v in range(batch.n_variations):
            reason = batch.invalid[v] or self.spawn[v]
            if reason is None and anchor_col.behavior not in STILL_BEHAVIORS and state.moved[v, anchor] < NEVER_MOVED:
                reason = f"{anchor_col.role} never moved"
            if reason is None and np.isfinite(batch.conflict_time[v]):
                for a, col in enumerate(batch.columns):
                    gone_t = state.gone_time[v, a]
                    if np.isfinite(gone_t) and gone_t < min(batch.conflict_time[v], self.first_collision[v]):
                        reason = f"{col.role} left the map before the conflict (t={gone_t:.1f} s)"
                        break
            self.valid.append(reason is None)
            self.reasons.append(reason)

    # ------------------------------------------------------------ traces
    def _traces(self, batch) -> pa.Table:
        f, i = self.f, self.i
        n_t, n_v, n_a = f["x"].shape
        roadmap = self.roadmap

        def flat(arr: np.ndarray) -> np.ndarray:
            return np.ascontiguousarray(np.transpose(arr, (1, 2, 0))).reshape(-1)

        x, y = flat(f["x"]), flat(f["y"])
        d = flat(f["d"])
        route_lane = flat(i["route_lane"])
        grid_lane, grid_junction = roadmap.lookup(x, y)
        lane_w = np.where(route_lane >= 0, batch.lane_width_table[np.maximum(route_lane, 0)], LANE_WIDTH)
        on_route_lane = (route_lane >= 0) & (np.abs(d) < lane_w / 2)
        lane = np.where(on_route_lane, route_lane, grid_lane)
        in_junction = grid_junction >= 0
        off_road = (lane < 0) & ~in_junction
        same_road = (lane >= 0) & (route_lane >= 0) & (
            batch.lane_road[np.maximum(lane, 0)] == batch.lane_road[np.maximum(route_lane, 0)])
        opposing = same_road & (batch.lane_forward[np.maximum(lane, 0)] != batch.lane_forward[np.maximum(route_lane, 0)]
                                ) & ~in_junction
        marker_idx = np.where(route_lane >= 0, batch.lane_marker[np.maximum(route_lane, 0)],
                              MARKERS.index("not_mentioned"))
        yaw = flat(f["yaw"])
        rel = yaw - flat(f["route_yaw"])
        length = np.repeat(batch.length.reshape(-1), n_t)
        width = np.repeat(batch.width.reshape(-1), n_t)
        extent = length / 2 * np.abs(np.sin(rel)) + width / 2 * np.abs(np.cos(rel))
        # centre-line offset of the route at each sample (NaN on one-way roads)
        route_idx = np.repeat(batch.route.reshape(-1), n_t)
        s_abs = flat(f["route_s"]) + np.repeat(batch.s0.reshape(-1), n_t)
        co = batch.routes.sample(batch.routes.centerline_offset, route_idx, s_abs)
        intrusion = d + extent - co
        lat_cmd = flat(f["lat_cmd"])
        changer = np.array([c.behavior in LANE_CHANGE_BEHAVIORS or (c.is_ads and c.behavior.startswith("change_lane"))
                            for c in batch.columns])
        changing = np.repeat(np.tile(changer, n_v), n_t) & (np.abs(d - lat_cmd) > 0.4)
        tgt_lane = np.full(len(changing), -1, dtype=np.int64)
        rows = np.flatnonzero(changing)  # the target lane is looked up only where a lane change is under way
        if len(rows):
            tx, ty, tyaw = batch.routes.point(route_idx[rows], s_abs[rows])
            tgt_lane[rows] = roadmap.lookup(tx - np.sin(tyaw) * lat_cmd[rows], ty + np.cos(tyaw) * lat_cmd[rows])[0]

        junction = flat(i["junction"])
        junction = np.where(in_junction, grid_junction, junction)
        variation_ids = np.array([s.index for s in batch.scenes], dtype=np.int32)
        roles = [c.role for c in batch.columns]
        lane_names = self.lane_uids[:-1].tolist()
        junction_names = self.junction_uids[:-1].tolist()
        columns = {
            "variation": np.repeat(variation_ids, n_a * n_t),
            "actor": _strings(np.repeat(np.tile(np.arange(n_a), n_v), n_t), roles),
            "step": np.tile(np.arange(n_t, dtype=np.int32), n_v * n_a),
            "t": flat(f["t"]),
            "x": x, "y": y, "yaw": yaw,
            "speed": flat(f["speed"]), "accel": flat(f["accel"]), "lat_accel": flat(f["lat_accel"]),
            "lane_id": _strings(lane, lane_names),
            "route_s": flat(f["route_s"]),
            "opposing_lane": opposing,
            "off_road": off_road,
            "centerline_marker": _strings(marker_idx, list(MARKERS)),
            "centerline_intrusion": intrusion,
            "in_junction": in_junction,
            "junction_id": _strings(junction, junction_names),
            "maneuver": _strings(flat(i["maneuver"]), list(MANEUVERS)),
            "control": _strings(flat(i["control"]), list(CONTROLS)),
            "signal": _strings(flat(i["signal"]), list(SIGNAL_STATES)),
            "stop_line_dist": flat(f["stop_line_dist"]),
            "speed_limit": flat(f["speed_limit"]),
            "lane_change": changing,
            "target_lane_id": _strings(tgt_lane, lane_names),
            "lost_control": flat(i["lost"]).astype(bool),
        }
        arrays = [columns[field.name] if isinstance(columns[field.name], pa.Array)
                  else pa.array(columns[field.name], type=field.type) for field in TRACE_SCHEMA]
        return pa.Table.from_arrays(arrays, schema=TRACE_SCHEMA)

    # ------------------------------------------------------------ result
    def tables(self, scenes: list[SampledScene]) -> dict[str, pa.Table]:
        traces = pa.concat_tables(self.trace_parts) if self.trace_parts else TRACE_SCHEMA.empty_table()
        rows = sorted(self.collision_rows, key=lambda row: (row["variation"], row["t"], row["actor_a"],
                                                            row["actor_b"]))
        return {
            "traces": traces,
            "actors": actors_table(scenes, self.settings),
            "collisions": collisions_table(rows),
            "variations": variations_table(scenes, self.valid, self.reasons, self.settings),
        }


def _strings(codes: np.ndarray, names: list[str]) -> pa.Array:
    """String column from integer codes into `names` (negative code: null), decoded in Arrow."""
    codes = np.asarray(codes)
    if not names:
        return pa.nulls(len(codes), type=pa.string())
    mask = codes < 0
    indices = pa.array(np.where(mask, 0, codes).astype(np.int32), mask=mask)
    return pa.DictionaryArray.from_arrays(indices, pa.array(names, type=pa.string())).cast(pa.string())
