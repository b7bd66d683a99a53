"""Trace tables reshaped into dense numpy arrays (variation, actor, step).

Every rule works on these arrays so that a whole batch is evaluated with a
few vectorised operations, never a Python loop over variations. Missing rows
(an actor absent from a variation, a trace that ended early) and columns a
backend could not fill are NaN (floats) or -1 (categorical codes).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from crashscene.dsl.model import actor_order
from crashscene.monitor.errors import TraceError
from crashscene.traces import (
    CENTERLINE_MARKERS,
    CONTROLS,
    MANEUVERS,
    SIGNAL_STATES,
    TABLES,
)

FLOAT_COLUMNS = ("t", "x", "y", "yaw", "speed", "accel", "lat_accel", "route_s", "centerline_intrusion",
                 "stop_line_dist", "speed_limit")
BOOL_COLUMNS = ("opposing_lane", "off_road", "in_junction", "lane_change", "lost_control")
VOCAB_COLUMNS = {"signal": SIGNAL_STATES, "control": CONTROLS, "maneuver": MANEUVERS,
                 "centerline_marker": CENTERLINE_MARKERS}
ID_COLUMNS = ("lane_id", "target_lane_id", "junction_id")
DEFAULT_DT = 0.1  # [s] when neither the variations table nor the time column says


def code_of(column: str, token: str) -> int:
    """Integer code of a vocabulary token in a categorical array (see VOCAB_COLUMNS)."""
    return VOCAB_COLUMNS[column].index(token)


@dataclass
class TraceArrays:
    """A batch of traces as arrays; axis 0 variation, axis 1 actor, axis 2 step."""

    variations: np.ndarray                 # (V,) variation numbers
    roles: list[str]                       # (A,) actor roles, ego first
    dt: float                              # [s] step of the batch
    present: np.ndarray                    # (V, A) the actor exists in the variation
    alive: np.ndarray                      # (V, A, T) a row with a finite position exists
    floats: dict[str, np.ndarray]          # FLOAT_COLUMNS and BOOL_COLUMNS as float (1/0/NaN), (V, A, T)
    codes: dict[str, np.ndarray]           # VOCAB_COLUMNS and ID_COLUMNS as int32 codes, -1 null, (V, A, T)
    length: np.ndarray                     # (V, A) [m]
    width: np.ndarray                      # (V, A) [m]
    is_ads: np.ndarray                     # (V, A) bool
    behavior: np.ndarray                   # (V, A) object: DSL behaviour token or None
    actor_type: np.ndarray                 # (V, A) object
    valid: np.ndarray                      # (V,) bool, from the variations table
    invalid_reason: list[str | None]       # (V,)
    id_values: list[str] = field(default_factory=list)  # strings of the ID_COLUMNS codes

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.alive.shape

    def __getattr__(self, name: str) -> np.ndarray:
        floats = self.__dict__.get("floats", {})
        if name in floats:
            return floats[name]
        codes = self.__dict__.get("codes", {})
        if name in codes:
            return codes[name]
        raise AttributeError(name)

    def flag(self, name: str) -> np.ndarray:
        """A boolean column as bool (null counts as False)."""
        return self.floats[name] == 1.0

    def known(self, name: str) -> np.ndarray:
        """Where a float/bool column is filled."""
        return np.isfinite(self.floats[name])

    def truncate(self, last_step: np.ndarray) -> None:
        """Drop, in place, each actor's rows after `last_step` (V, A; -1 = keep all)."""
        steps = np.arange(self.shape[2])
        drop = (last_step[..., None] >= 0) & (steps > last_step[..., None])
        if not drop.any():
            return
        for name, arr in self.floats.items():
            if name != "t":
                arr[drop] = np.nan
        for arr in self.codes.values():
            arr[drop] = -1
        self.alive &= ~drop

    def select(self, rows: np.ndarray) -> TraceArrays:
        """A copy of the variations at indices `rows` (axis 0)."""
        return TraceArrays(variations=self.variations[rows], roles=list(self.roles), dt=self.dt,
                           present=self.present[rows], alive=self.alive[rows],
                           floats={k: v[rows] for k, v in self.floats.items()},
                           codes={k: v[rows] for k, v in self.codes.items()}, length=self.length[rows],
                           width=self.width[rows], is_ads=self.is_ads[rows], behavior=self.behavior[rows],
                           actor_type=self.actor_type[rows], valid=self.valid[rows],
                           invalid_reason=[self.invalid_reason[r] for r in rows], id_values=list(self.id_values))

    def time(self) -> np.ndarray:
        """(V, A, T) time [s]; steps without a row get step * dt."""
        t = self.floats["t"]
        steps = np.arange(t.shape[2]) * self.dt
        return np.where(np.isfinite(t), t, steps)


def _np_float(column: pa.ChunkedArray) -> np.ndarray:
    return column.to_numpy(zero_copy_only=False).astype(np.float64, copy=False)


def _np_bool_as_float(column: pa.ChunkedArray) -> np.ndarray:
    filled = pc.fill_null(column.cast(pa.float64()), np.nan)
    return filled.to_numpy(zero_copy_only=False)


def _vocab_codes(column: pa.ChunkedArray, vocab: tuple[str, ...]) -> np.ndarray:
    index = pc.index_in(column, value_set=pa.array(list(vocab)))
    return pc.fill_null(index, -1).to_numpy(zero_copy_only=False).astype(np.int32)


def _id_codes(columns: list[pa.ChunkedArray]) -> tuple[list[np.ndarray], list[str]]:
    """Codes sharing one dictionary across several string columns (lane_id and target_lane_id compare)."""
    uniques = set()
    for column in columns:
        uniques.update(v for v in pc.unique(column).to_pylist() if v is not None)
    values = sorted(uniques)
    value_set = pa.array(values, type=pa.string())
    codes = [pc.fill_null(pc.index_in(col.cast(pa.string()), value_set=value_set), -1)
             .to_numpy(zero_copy_only=False).astype(np.int32) for col in columns]
    return codes, values


def _check_columns(tables: dict[str, pa.Table]) -> None:
    for name in ("traces", "actors"):
        if name not in tables:
            raise TraceError(f"tables: no {name!r} table; expected tables {sorted(TABLES)}")
    for name, table in tables.items():
        if name not in TABLES:
            continue
        missing = [c for c in TABLES[name].names if c not in table.column_names]
        if missing:
            raise TraceError(f"{name} table: missing columns {missing}; expected {TABLES[name].names}")


def build_arrays(tables: dict[str, pa.Table]) -> TraceArrays:
    """Reshape the tables of `crashscene.traces` into a TraceArrays batch."""
    _check_columns(tables)
    traces, actors = tables["traces"], tables["actors"]
    variations_table = tables.get("variations")

    var_sets = [np.asarray(traces.column("variation").to_numpy(zero_copy_only=False), dtype=np.int64),
                np.asarray(actors.column("variation").to_numpy(zero_copy_only=False), dtype=np.int64)]
    if variations_table is not None:
        var_sets.append(np.asarray(variations_table.column("variation").to_numpy(zero_copy_only=False),
                                   dtype=np.int64))
    variations = np.unique(np.concatenate(var_sets))
    role_set = set(actors.column("actor").to_pylist()) | set(pc.unique(traces.column("actor")).to_pylist())
    role_set.discard(None)
    try:
        roles = sorted(role_set, key=lambda r: (actor_order(r), r))
    except ValueError:
        roles = sorted(role_set)
    n_var, n_act = len(variations), len(roles)
    role_index = {r: i for i, r in enumerate(roles)}

    steps = traces.column("step").to_numpy(zero_copy_only=False).astype(np.int64)
    if len(steps) and steps.min() < 0:
        raise TraceError(f"traces table: negative step {int(steps.min())}; steps count from 0")
    n_steps = int(steps.max()) + 1 if len(steps) else 1  # one empty step keeps every array op defined
    vi = np.searchsorted(variations, traces.column("variation").to_numpy(zero_copy_only=False))
    ai = _role_indices(traces.column("actor"), role_index)

    shape = (n_var, n_act, n_steps)
    flat = (vi * n_act + ai) * n_steps + steps
    # traces written in (variation, actor, step) order and complete: a reshape, no scatter
    dense = len(flat) == n_var * n_act * n_steps and bool(np.all(flat[1:] > flat[:-1]))

    def place(values: np.ndarray, fill, dtype) -> np.ndarray:
        if dense:
            return np.array(values, dtype=dtype).reshape(shape)
        arr = np.full(n_var * n_act * n_steps, fill, dtype=dtype)
        arr[flat] = values
        return arr.reshape(shape)

    floats: dict[str, np.ndarray] = {}
    for name in FLOAT_COLUMNS:
        floats[name] = place(_np_float(pc.fill_null(traces.column(name), np.nan)), np.nan, np.float64)
    for name in BOOL_COLUMNS:
        floats[name] = place(_np_bool_as_float(traces.column(name)), np.nan, np.float64)
    codes: dict[str, np.ndarray] = {}
    for name, vocab in VOCAB_COLUMNS.items():
        codes[name] = place(_vocab_codes(traces.column(name), vocab), -1, np.int32)
    id_codes, id_values = _id_codes([traces.column(name) for name in ID_COLUMNS])
    for name, values in zip(ID_COLUMNS, id_codes):
        codes[name] = place(values, -1, np.int32)

    alive = np.isfinite(floats["x"]) & np.isfinite(floats["y"])
    # Headings and speeds a backend left empty are derived from positions, so geometry still works.
    _fill_kinematics(floats, alive, _batch_dt(traces, variations_table))

    avi = np.searchsorted(variations, actors.column("variation").to_numpy(zero_copy_only=False))
    aai = _role_indices(actors.column("actor"), role_index)
    present = np.zeros((n_var, n_act), dtype=bool)
    present[avi, aai] = True
    present |= alive.any(axis=2)
    length = np.full((n_var, n_act), 4.5)
    width = np.full((n_var, n_act), 1.9)
    length[avi, aai] = _np_float(pc.fill_null(actors.column("length"), 4.5))
    width[avi, aai] = _np_float(pc.fill_null(actors.column("width"), 1.9))
    is_ads = np.zeros((n_var, n_act), dtype=bool)
    is_ads[avi, aai] = pc.fill_null(actors.column("is_ads"), False).to_numpy(zero_copy_only=False)
    behavior = np.full((n_var, n_act), None, dtype=object)
    behavior[avi, aai] = np.asarray(actors.column("behavior").to_pylist(), dtype=object)
    actor_type = np.full((n_var, n_act), None, dtype=object)
    actor_type[avi, aai] = np.asarray(actors.column("type").to_pylist(), dtype=object)

    valid = np.ones(n_var, dtype=bool)
    reasons: list[str | None] = [None] * n_var
    if variations_table is not None and variations_table.num_rows:
        wvi = np.searchsorted(variations, variations_table.column("variation").to_numpy(zero_copy_only=False))
        valid[wvi] = pc.fill_null(variations_table.column("valid"), True).to_numpy(zero_copy_only=False)
        for i, reason in zip(wvi, variations_table.column("invalid_reason").to_pylist()):
            reasons[int(i)] = reason
    return TraceArrays(variations=variations, roles=roles, dt=_batch_dt(traces, variations_table),
                       present=present, alive=alive, floats=floats, codes=codes, length=length, width=width,
                       is_ads=is_ads, behavior=behavior, actor_type=actor_type, valid=valid,
                       invalid_reason=reasons, id_values=id_values)


def _role_indices(column: pa.ChunkedArray, role_index: dict[str, int]) -> np.ndarray:
    encoded = pc.dictionary_encode(column).combine_chunks()
    lookup = np.array([role_index.get(r, -1) for r in encoded.dictionary.to_pylist()], dtype=np.int64)
    idx = encoded.indices.to_numpy(zero_copy_only=False)
    out = lookup[idx] if len(lookup) else np.zeros(0, dtype=np.int64)
    if (out < 0).any():
        raise TraceError("traces table: rows with a null actor role")
    return out


def _batch_dt(traces: pa.Table, variations_table: pa.Table | None) -> float:
    if variations_table is not None and variations_table.num_rows:
        dts = variations_table.column("dt").to_numpy(zero_copy_only=False).astype(float)
        dts = dts[np.isfinite(dts) & (dts > 0)]
        if len(dts):
            return float(np.median(dts))
    if traces.num_rows > 1:
        t = traces.column("t").to_numpy(zero_copy_only=False).astype(float)
        step = traces.column("step").to_numpy(zero_copy_only=False).astype(float)
        ok = np.isfinite(t) & (step > 0)
        if ok.any():
            return float(np.median(t[ok] / step[ok]))
    return DEFAULT_DT


def _fill_kinematics(floats: dict[str, np.ndarray], alive: np.ndarray, dt: float) -> None:
    """Derive yaw [rad] and speed [m/s] from positions where a backend left them empty."""
    x, y = floats["x"], floats["y"]
    missing_speed = alive & ~np.isfinite(floats["speed"])
    missing_yaw = alive & ~np.isfinite(floats["yaw"])
    if x.shape[2] < 2 or not (missing_speed.any() or missing_yaw.any()):
        return
    dx = np.gradient(np.where(alive, x, np.nan), axis=2)
    dy = np.gradient(np.where(alive, y, np.nan), axis=2)
    floats["speed"][missing_speed] = (np.hypot(dx, dy) / dt)[missing_speed]
    floats["yaw"][missing_yaw] = np.arctan2(dy, dx)[missing_yaw]
