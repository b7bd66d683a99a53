"""Trace columns: the contract between simulators (any backend) and the monitor.

A run directory holds, as Parquet (pyarrow):
- `traces.parquet`: one row per (variation, actor, step), columns TRACE_SCHEMA.
- `actors.parquet`: one row per (variation, actor), columns ACTOR_SCHEMA.
- `collisions.parquet`: one row per contact event (each onset of contact of a
  pair; a re-contact after separation is a new row), columns COLLISION_SCHEMA
  (the simulator reports contact; the monitor classifies it).
- `variations.parquet`: one row per variation, columns VARIATION_SCHEMA.
Units are SI, angles yaw [rad] (0 = +x, counter-clockwise), as in `crashscene.scene`.
Columns the producing backend cannot know are null (NaN for floats) and the
monitor treats the rules that need them as not_applicable.
"""
from __future__ import annotations

import functools
import hashlib
import inspect
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

SIGNAL_STATES = ("none", "green", "yellow", "red")  # state of the signal governing the actor's next stop line
CONTROLS = ("none", "signal", "stop", "yield")  # control device of the approach the actor is on
MANEUVERS = ("none", "straight", "left", "right", "u_turn")  # at the current/next junction
CENTERLINE_MARKERS = ("none", "broken_line", "solid_line", "double_solid_line", "solid_and_broken_line",
                      "not_mentioned")

TRACE_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("actor", pa.string()),          # DSL role: ego, npc1, ...
    ("step", pa.int32()),
    ("t", pa.float64()),             # [s]
    ("x", pa.float64()),             # [m] centre
    ("y", pa.float64()),             # [m]
    ("yaw", pa.float64()),           # [rad]
    ("speed", pa.float64()),         # [m/s] >= 0
    ("accel", pa.float64()),         # [m/s2] longitudinal, negative when braking
    ("lat_accel", pa.float64()),     # [m/s2] lateral (speed * yaw rate)
    ("lane_id", pa.string()),        # lane uid under the actor's centre, null off-road
    ("route_s", pa.float64()),       # [m] station along the actor's planned route
    ("opposing_lane", pa.bool_()),   # centre is in a lane whose direction opposes the actor's travel
    ("off_road", pa.bool_()),        # centre is outside every drivable lane
    ("centerline_marker", pa.string()),   # CENTERLINE_MARKERS of the road the actor is on
    ("centerline_intrusion", pa.float64()),  # [m] how far the footprint's farthest corner is beyond the centre line (<=0: not beyond)
    ("in_junction", pa.bool_()),     # centre inside a junction area
    ("junction_id", pa.string()),    # junction the actor is in or approaching, null if none
    ("maneuver", pa.string()),       # MANEUVERS: the actor's manoeuvre at that junction
    ("control", pa.string()),        # CONTROLS of the actor's approach to that junction
    ("signal", pa.string()),         # SIGNAL_STATES governing the actor's stop line
    ("stop_line_dist", pa.float64()),  # [m] front bumper to that stop line along the route; >0 before, <0 past; NaN if none
    ("speed_limit", pa.float64()),   # [m/s] posted limit of the lane, NaN if unknown
    ("lane_change", pa.bool_()),     # executing a lane change this step
    ("target_lane_id", pa.string()), # lane being changed into, null otherwise
    ("lost_control", pa.bool_()),    # the actor is skidding / out of control
])

ACTOR_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("actor", pa.string()),
    ("label", pa.string()),
    ("type", pa.string()),           # car | truck | motorcycle
    ("behavior", pa.string()),       # DSL behavior token
    ("is_ads", pa.bool_()),          # driven by the ADS under test in this run
    ("length", pa.float64()),        # [m]
    ("width", pa.float64()),         # [m]
    ("dispositions", pa.list_(pa.string())),  # oracle codes injected into this actor's driver
])

COLLISION_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("t", pa.float64()),             # [s] onset of the contact
    ("actor_a", pa.string()),
    ("actor_b", pa.string()),
    ("speed_a", pa.float64()),       # [m/s]
    ("speed_b", pa.float64()),
    ("yaw_a", pa.float64()),         # [rad]
    ("yaw_b", pa.float64()),
    ("x", pa.float64()),             # [m] contact point estimate
    ("y", pa.float64()),
    ("delta_v_a", pa.float64()),     # [m/s] change of actor_a's velocity vector in the contact (null: not known)
    ("delta_v_b", pa.float64()),
])

VARIATION_SCHEMA = pa.schema([
    ("variation", pa.int32()),
    ("seed", pa.int64()),
    ("scenario_hash", pa.string()),
    ("valid", pa.bool_()),
    ("invalid_reason", pa.string()),  # null when valid
    ("dt", pa.float64()),            # [s]
    ("steps", pa.int32()),
    ("params", pa.string()),         # JSON object of sampled parameters
])

TABLES = {"traces": TRACE_SCHEMA, "actors": ACTOR_SCHEMA, "collisions": COLLISION_SCHEMA,
          "variations": VARIATION_SCHEMA}


SCENARIO_DIGEST_KEY = b"crashscene.scenario_sha256"  # Parquet metadata: the scenario the traces were simulated from


def scenario_digest(scenario) -> str:
    """sha256 of the scenario's canonical YAML: stored with the traces, checked by the monitor."""
    from crashscene.dsl import dumps

    return hashlib.sha256(dumps(scenario).encode("utf-8")).hexdigest()


def stored_digest(run_dir: str | Path) -> str | None:
    """The scenario digest stored with `run_dir/traces.parquet` (None for runs written without one)."""
    path = Path(run_dir) / "traces.parquet"
    metadata = pq.read_schema(path).metadata or {}
    value = metadata.get(SCENARIO_DIGEST_KEY)
    return value.decode("ascii") if value else None


# Parquet layout, written out (pyarrow's defaults) because `_page_aligned` relies on it
ROW_GROUP_ROWS = 1024 * 1024  # rows per row group
PAGE_ROWS = 20_000  # rows per data page at most
PAGE_BYTES = 2**20  # [bytes] a data page's size at most
ALIGNED_STRING_BYTES = 40  # [bytes] longest string value for which PAGE_ROWS rows always fit in PAGE_BYTES
_LAYOUT = {"row_group_size": ROW_GROUP_ROWS, "max_rows_per_page": PAGE_ROWS, "data_page_size": PAGE_BYTES}


def write_table(run_dir: str | Path, name: str, table: pa.Table) -> Path:
    """Write one of TABLES to `run_dir/<name>.parquet`, cast to its schema (column order fixed); the table's
    schema metadata (the scenario digest) is kept.

    The same rows give the same bytes however they are chunked (the blocks of different worker counts, the
    simulator's chunks): the writer's pages follow the chunks it is handed, so the columns are cut where a page
    starts anyway (`_page_aligned`, no copy but of the pieces that straddle a page start), or else combined
    into one chunk each (a copy of the table)."""
    schema = TABLES[name]
    metadata = table.schema.metadata
    table = table.select(schema.names).cast(schema)
    aligned = _page_aligned(table)
    table = aligned if aligned is not None else table.combine_chunks()
    if metadata:
        table = table.replace_schema_metadata(metadata)
    path = Path(run_dir) / f"{name}.parquet"
    pq.write_table(table, path, compression="zstd", **(_LAYOUT if aligned is not None else {}))
    return path


def _page_aligned(table: pa.Table) -> pa.Table | None:
    """`table` with its columns chunked exactly at the rows where a data page starts, or None when a page may
    start elsewhere (or this pyarrow cannot fix the rows per page).

    With every page at most PAGE_ROWS rows and PAGE_ROWS rows of every column within PAGE_BYTES (fixed-width
    values, strings of at most ALIGNED_STRING_BYTES), pages start at each row group's start and every PAGE_ROWS
    rows after it, whatever the values; the writer then sees the same batches of values as from one chunk."""
    if "max_rows_per_page" not in _write_table_parameters():
        return None
    for column in table.columns:
        if pa.types.is_string(column.type):
            longest = pc.max(pc.binary_length(column)).as_py() if len(column) else None
            if longest is not None and longest > ALIGNED_STRING_BYTES:
                return None
        elif not pa.types.is_primitive(column.type):
            return None
    n = table.num_rows
    starts = [g + k for g in range(0, n, ROW_GROUP_ROWS) for k in range(0, min(ROW_GROUP_ROWS, n - g), PAGE_ROWS)]
    bounds = list(zip(starts, starts[1:] + [n]))

    def cut(column: pa.ChunkedArray) -> pa.ChunkedArray:
        pieces = []
        for lo, hi in bounds:
            parts = [chunk for chunk in column.slice(lo, hi - lo).chunks if len(chunk)]
            pieces.append(parts[0] if len(parts) == 1 else pa.concat_arrays(parts))
        return pa.chunked_array(pieces, type=column.type)

    return pa.Table.from_arrays([cut(column) for column in table.columns], schema=table.schema)


@functools.cache
def _write_table_parameters() -> frozenset[str]:
    return frozenset(inspect.signature(pq.write_table).parameters)


def read_table(run_dir: str | Path, name: str) -> pa.Table:
    """Read `run_dir/<name>.parquet`, checking it carries the contract's columns."""
    path = Path(run_dir) / f"{name}.parquet"
    if not path.exists():
        raise FileNotFoundError(f"{path}: no {name} table in this run directory")
    table = pq.read_table(path)
    missing = [col for col in TABLES[name].names if col not in table.column_names]
    if missing:
        raise ValueError(f"{path}: missing columns {missing}; expected {TABLES[name].names}")
    return table.select(TABLES[name].names)
