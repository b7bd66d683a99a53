"""What every rule sees: the batch arrays, the scenario, and shared derived quantities.

Derived quantities several rules need (path conflicts, same-lane leaders,
junction arrival times) are computed once, lazily, and cached here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pyarrow as pa

from crashscene.dsl.model import Scenario
from crashscene.monitor.arrays import TraceArrays, code_of
from crashscene.monitor.conflicts import PathConflicts, path_conflicts
from crashscene.monitor.timeseries import first_index, take
from crashscene.units import MPH



@dataclass
class Leaders:
    """For each (variation, actor, step): the nearest actor ahead in the same lane."""

    index: np.ndarray     # (V, A, T) leader actor index, -1 none
    gap: np.ndarray       # (V, A, T) bumper-to-bumper gap [m], inf none
    speed: np.ndarray     # (V, A, T) leader speed [m/s], NaN none


@dataclass
class Whole:
    """The whole traces of some variations, as recorded before judging cut each actor's (judging.py)."""

    rows: np.ndarray      # (W,) indices of those variations in the batch (axis 0 of EvalContext.arrays)
    arrays: TraceArrays   # their traces, every step kept


@dataclass
class EvalContext:
    """The batch under evaluation."""

    arrays: TraceArrays
    scenario: Scenario | None
    collisions: pa.Table | None = None  # classified collisions (crashscene.monitor.collisions.CLASSIFIED_SCHEMA)
    driven_until: np.ndarray | None = None  # (V, A) step an impact upset the actor (judging.upset_steps), -1 never:
    # its path as a driver (the conflicts) ends there
    grace: int = 0                     # [steps] judging goes on this long past an upsetting contact
    whole: Whole | None = None         # untruncated traces of the variations a rule asked for (Rule.past_judging)
    conflict_stride: int = 2
    lane_half_width: float = 1.6       # [m] lateral offset still counted as the same lane
    leader_range: float = 150.0        # [m] farthest leader considered
    cache: dict = field(default_factory=dict, repr=False)  # derived quantities rules share, by name

    @property
    def shape(self) -> tuple[int, int]:
        return self.arrays.shape[:2]

    @property
    def dt(self) -> float:
        return self.arrays.dt

    @cached_property
    def time(self) -> np.ndarray:
        return self.arrays.time()

    def settled(self, grace: float) -> np.ndarray:
        """(V, A, T) steps past the test's initial conditions: for an actor under test (is_ads), at least
        `grace` [s] after its first sample (its spawn speed and gap are not its choice); for scripted
        actors, every step (their dispositions start at once)."""
        a = self.arrays
        start = take(self.time, first_index(a.alive))
        grace_of = np.where(a.is_ads, grace, 0.0)
        return a.alive & (self.time >= (start + grace_of)[..., None] - 1e-9)

    def time_at(self, step: np.ndarray) -> np.ndarray:
        """(V, A) time [s] at a per-actor step index (-1 -> NaN)."""
        return take(self.time, step)

    def is_code(self, column: str, token: str) -> np.ndarray:
        return self.arrays.codes[column] == code_of(column, token)

    @cached_property
    def conflicts(self) -> PathConflicts:
        return path_conflicts(self.arrays, stride=self.conflict_stride, last_step=self.driven_until)

    @cached_property
    def junction_entry(self) -> np.ndarray:
        """(V, A) first step inside a junction, -1 if never."""
        return first_index(self.arrays.flag("in_junction"))

    @cached_property
    def leaders(self) -> Leaders:
        """Nearest same-lane actor ahead: same lane id, or (ids unknown) within a lane's half width laterally."""
        a = self.arrays
        n_var, n_act, n_steps = a.shape
        x, y, yaw, speed = a.floats["x"], a.floats["y"], a.floats["yaw"], a.floats["speed"]
        lane = a.codes["lane_id"]
        best_gap = np.full((n_var, n_act, n_steps), np.inf)
        best_idx = np.full((n_var, n_act, n_steps), -1, dtype=np.int64)
        cos, sin = np.cos(yaw), np.sin(yaw)
        for i in range(n_act):
            for j in range(n_act):
                if i == j:
                    continue
                dx, dy = x[:, j] - x[:, i], y[:, j] - y[:, i]
                lon = dx * cos[:, i] + dy * sin[:, i]
                lat = dy * cos[:, i] - dx * sin[:, i]
                # same direction within 45 deg: cos of the heading difference above cos(45 deg)
                same_dir = (cos[:, i] * cos[:, j] + sin[:, i] * sin[:, j]) > np.cos(np.radians(45))
                same_id = (lane[:, i] >= 0) & (lane[:, i] == lane[:, j])
                geometric = np.abs(lat) < self.lane_half_width
                gap = lon - (a.length[:, i, None] + a.length[:, j, None]) / 2
                with np.errstate(invalid="ignore"):
                    ok = (same_id | geometric) & same_dir & (lon > 0) & (lon < self.leader_range)
                ok &= a.alive[:, i] & a.alive[:, j]
                gap = np.where(ok, gap, np.inf)
                better = gap < best_gap[:, i]
                best_gap[:, i] = np.where(better, gap, best_gap[:, i])
                best_idx[:, i] = np.where(better, j, best_idx[:, i])
        lead_speed = np.take_along_axis(speed, np.clip(best_idx, 0, None), axis=1)
        lead_speed = np.where(best_idx >= 0, lead_speed, np.nan)
        return Leaders(index=best_idx, gap=best_gap, speed=lead_speed)

    @cached_property
    def first_contact(self) -> np.ndarray:
        """(V, A) step of each actor's first collision, -1 never."""
        from crashscene.monitor.collisions import first_contact_steps

        if self.collisions is None:
            return np.full(self.shape, -1, dtype=np.int64)
        return first_contact_steps(self.arrays, self.collisions)

    def struck_stopped(self, stopped_speed: float) -> np.ndarray:
        """(V, A) time [s] an actor first rear-ended a vehicle slower than `stopped_speed` [m/s], NaN never."""
        out = np.full(self.shape, np.nan)
        table = self.collisions
        if table is None or not table.num_rows:
            return out
        rows = table.to_pydict()
        role_index = {r: i for i, r in enumerate(self.arrays.roles)}
        for k in range(table.num_rows):
            striker = rows["striking_actor"][k]
            if rows["class"][k] != "rear_end" or striker not in role_index:
                continue
            struck_speed = rows["speed_b"][k] if striker == rows["actor_a"][k] else rows["speed_a"][k]
            if struck_speed is None or not struck_speed < stopped_speed:
                continue
            v = int(np.searchsorted(self.arrays.variations, rows["variation"][k]))
            a = role_index[striker]
            out[v, a] = np.fmin(out[v, a], rows["t"][k])
        return out

    # --- scenario-derived facts -------------------------------------------------------------
    def environment(self) -> tuple[str, str, str]:
        """(weather, road_surface, time_of_day) tokens; not_mentioned without a scenario."""
        if self.scenario is None:
            return "not_mentioned", "not_mentioned", "not_mentioned"
        env = self.scenario.environment
        return str(env.weather), str(env.road_surface), str(env.time_of_day)

    def scenario_speed_limit(self) -> float | None:
        """The DSL's posted limit [m/s], or None."""
        if self.scenario is None or self.scenario.road_network.speed_limit_mph is None:
            return None
        return self.scenario.road_network.speed_limit_mph * MPH
