"""The campaign's DuckDB database: one file in the output folder, one writer (the driver).

Tables (keys: scenario_hash, seed, mode, variation):
- `cases`: one row per case folder (status, error, scenario hash, extraction backend);
- `runs`: one row per (scenario_hash, seed, mode) with n, chunk size and the DSL text;
- `shown`, `shown_traces`, `shown_actors`: the variations the report draws and their traces (`keep`);
- `variations`, `violations`, `collisions`, `criticality`: result rows (`model.ROW_SCHEMAS` + keys);
- `searches`, `search_evaluations`: `campaign --search` (see `campaign.search`), one row per finished
  search and one per variation it evaluated, written together;
- `chunks`: one row per finished chunk, written in the SAME transaction as its result
  rows, so a chunk is either fully stored and marked done or absent (kill -9 included);
- `chunk_errors`: chunks whose worker failed (retried on resume);
- `sessions`: one row per invocation (start, engine, workers), for resume bookkeeping;
- `settings`: the options that shape the results (every campaign option, the rulebook's sha256), written by
  the first invocation; a resume with other values is refused, naming what differs.

A damaged file (truncated, overwritten) is reported as such, with its path and
what can still be recovered, never as a raw database error.
"""
from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

import duckdb
import pyarrow as pa

from crashscene.campaign.errors import CampaignError
from crashscene.campaign.keep import prune as prune_shown
from crashscene.campaign.model import ROW_SCHEMAS, ChunkResult, ChunkTask

DB_NAME = "campaign.duckdb"
KEYS = "scenario_hash VARCHAR NOT NULL, seed BIGINT NOT NULL, mode VARCHAR NOT NULL"

DDL = f"""
CREATE TABLE IF NOT EXISTS sessions (
    session INTEGER PRIMARY KEY, started_at TIMESTAMP, command VARCHAR, engine VARCHAR, workers INTEGER);
CREATE TABLE IF NOT EXISTS cases (
    case_id VARCHAR PRIMARY KEY, case_dir VARCHAR, status VARCHAR, error VARCHAR, scenario_hash VARCHAR,
    extract_backend VARCHAR, warnings VARCHAR, seconds DOUBLE);
CREATE TABLE IF NOT EXISTS runs (
    {KEYS}, case_id VARCHAR, n INTEGER, chunk_size INTEGER, options VARCHAR, scenario_yaml VARCHAR,
    created_at TIMESTAMP, PRIMARY KEY (scenario_hash, seed, mode));
CREATE TABLE IF NOT EXISTS chunks (
    {KEYS}, first INTEGER NOT NULL, count INTEGER, session INTEGER, seconds DOUBLE, finished_at TIMESTAMP,
    PRIMARY KEY (scenario_hash, seed, mode, first));
CREATE TABLE IF NOT EXISTS chunk_errors (
    {KEYS}, first INTEGER, count INTEGER, session INTEGER, error VARCHAR, failed_at TIMESTAMP);
CREATE TABLE IF NOT EXISTS variations (
    {KEYS}, variation INTEGER NOT NULL, valid BOOLEAN, invalid_reason VARCHAR, verdict VARCHAR,
    reproduced BOOLEAN, collided BOOLEAN, params VARCHAR, first_contact BOOLEAN, sequence BOOLEAN,
    area_match BOOLEAN, PRIMARY KEY (scenario_hash, seed, mode, variation));
CREATE TABLE IF NOT EXISTS violations (
    {KEYS}, variation INTEGER NOT NULL, actor VARCHAR, is_ads BOOLEAN, code VARCHAR, violation VARCHAR,
    t_first DOUBLE, value DOUBLE, threshold DOUBLE, unit VARCHAR, robustness DOUBLE);
CREATE TABLE IF NOT EXISTS settings (name VARCHAR PRIMARY KEY, value VARCHAR);
CREATE TABLE IF NOT EXISTS collisions (
    {KEYS}, variation INTEGER NOT NULL, t DOUBLE, actor_a VARCHAR, actor_b VARCHAR, collision_class VARCHAR,
    speed_a DOUBLE, speed_b DOUBLE, x DOUBLE, y DOUBLE, contact_index INTEGER, area_a VARCHAR, area_b VARCHAR,
    delta_v_a DOUBLE, delta_v_b DOUBLE);
CREATE TABLE IF NOT EXISTS shown (
    {KEYS}, variation INTEGER NOT NULL, reason VARCHAR, score DOUBLE);
CREATE TABLE IF NOT EXISTS shown_traces (
    {KEYS}, variation INTEGER NOT NULL, actor VARCHAR, t DOUBLE, x DOUBLE, y DOUBLE, yaw DOUBLE, speed DOUBLE);
CREATE TABLE IF NOT EXISTS shown_actors (
    {KEYS}, variation INTEGER NOT NULL, actor VARCHAR, label VARCHAR, type VARCHAR, is_ads BOOLEAN, length DOUBLE,
    width DOUBLE);
-- databases written before the crash sequence was judged gain its columns (NULL in their old rows)
ALTER TABLE variations ADD COLUMN IF NOT EXISTS first_contact BOOLEAN;
ALTER TABLE variations ADD COLUMN IF NOT EXISTS sequence BOOLEAN;
ALTER TABLE variations ADD COLUMN IF NOT EXISTS area_match BOOLEAN;
ALTER TABLE collisions ADD COLUMN IF NOT EXISTS contact_index INTEGER;
ALTER TABLE collisions ADD COLUMN IF NOT EXISTS area_a VARCHAR;
ALTER TABLE collisions ADD COLUMN IF NOT EXISTS area_b VARCHAR;
ALTER TABLE collisions ADD COLUMN IF NOT EXISTS delta_v_a DOUBLE;
ALTER TABLE collisions ADD COLUMN IF NOT EXISTS delta_v_b DOUBLE;
CREATE TABLE IF NOT EXISTS criticality (
    {KEYS}, variation INTEGER NOT NULL, actor_a VARCHAR, actor_b VARCHAR, involves_ads BOOLEAN, min_ttc DOUBLE,
    pet DOUBLE, min_thw DOUBLE, max_drac DOUBLE, collided BOOLEAN, impact_speed DOUBLE, delta_v_a DOUBLE,
    delta_v_b DOUBLE);
CREATE TABLE IF NOT EXISTS searches (
    scenario_hash VARCHAR NOT NULL, seed BIGINT NOT NULL, sampler VARCHAR NOT NULL, objective VARCHAR NOT NULL,
    budget INTEGER NOT NULL, case_id VARCHAR, evaluated INTEGER, failures INTEGER, min_objective DOUBLE,
    best_parameters VARCHAR, summary VARCHAR, seconds DOUBLE, finished_at TIMESTAMP,
    PRIMARY KEY (scenario_hash, seed, sampler, objective, budget));
CREATE TABLE IF NOT EXISTS search_evaluations (
    scenario_hash VARCHAR NOT NULL, seed BIGINT NOT NULL, sampler VARCHAR NOT NULL, objective VARCHAR NOT NULL,
    budget INTEGER NOT NULL, variation INTEGER NOT NULL, round INTEGER, objective_value DOUBLE, verdict VARCHAR,
    failure BOOLEAN, min_ttc DOUBLE, params VARCHAR);
"""


def _now() -> datetime:
    return datetime.now(timezone.utc).replace(tzinfo=None)


class Store:
    """Read/write access to `DIR/campaign.duckdb`; use as a context manager."""

    def __init__(self, out_dir: str | Path, read_only: bool = False):
        self.path = Path(out_dir) / DB_NAME
        if read_only and not self.path.exists():
            raise CampaignError(f"{self.path}: no campaign database here (run `crashscene run` or "
                                "`crashscene campaign` with this --out first)")
        if not read_only:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self.con = duckdb.connect(str(self.path), read_only=read_only)
            if not read_only:
                self.con.execute(DDL)
            self.con.execute("SELECT count(*) FROM runs").fetchone()
        except duckdb.Error as exc:
            if isinstance(exc, duckdb.IOException) and "lock" in str(exc).lower():
                raise CampaignError(f"{self.path}: cannot open the campaign database ({exc}); "
                                    "is another campaign writing to it?") from exc
            raise self.damaged(exc) from exc

    def damaged(self, exc: Exception) -> CampaignError:
        """The error for a database file that cannot be read: where it is, and what can be recovered."""
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        cases = self.path.parent / "cases"
        return CampaignError(
            f"{self.path}: the campaign database is damaged ({first}). Its result rows cannot be read. Still "
            f"there: the prepared cases under {cases} (scenario.yaml, extraction.json, the rendered program and "
            f"map, and chunk traces if --keep-traces was on). To recover the results, move the damaged file aside "
            f"and run the same campaign again with the same options: the same seed gives the same rows.")

    def close(self) -> None:
        self.con.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- sessions and runs -------------------------------------------------------------------------
    def has_results(self) -> bool:
        return self.query("SELECT count(*) AS n FROM runs")[0]["n"] > 0

    def start_session(self, command: str, engine: str, workers: int) -> int:
        number = self.con.execute("SELECT coalesce(max(session), 0) + 1 FROM sessions").fetchone()[0]
        self.con.execute("INSERT INTO sessions VALUES (?, ?, ?, ?, ?)", [number, _now(), command, engine, workers])
        return number

    def put_case(self, case_id: str, case_dir: str, status: str, error: str | None = None,
                 scenario_hash: str | None = None, extract_backend: str | None = None,
                 warnings: list[str] | None = None, seconds: float = 0.0) -> None:
        self.con.execute("INSERT OR REPLACE INTO cases VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                         [case_id, case_dir, status, error, scenario_hash, extract_backend,
                          json.dumps(warnings or []), seconds])

    def ensure_run(self, case_id: str, scenario_hash: str, seed: int, mode: str, n: int, chunk_size: int,
                   options: str, scenario_yaml: str) -> None:
        """Register a run, or check that a resumed one was planned with the same n and chunk size."""
        row = self.con.execute("SELECT n, chunk_size FROM runs WHERE scenario_hash=? AND seed=? AND mode=?",
                               [scenario_hash, seed, mode]).fetchone()
        if row is None:
            self.con.execute("INSERT INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                             [scenario_hash, seed, mode, case_id, n, chunk_size, options, scenario_yaml, _now()])
        elif tuple(row) != (n, chunk_size):
            raise CampaignError(f"case {case_id} ({mode}, seed {seed}) was started with -n {row[0]} and chunk size "
                                f"{row[1]}; resume with the same values (got -n {n}, chunk size {chunk_size}) "
                                "or use a new --out")

    def done_chunks(self, scenario_hash: str, seed: int, mode: str) -> set[int]:
        rows = self.query("SELECT first FROM chunks WHERE scenario_hash=? AND seed=? AND mode=?",
                          [scenario_hash, seed, mode])
        return {r["first"] for r in rows}

    # --- results -------------------------------------------------------------------------------------
    def write_chunk(self, task: ChunkTask, result: ChunkResult, session: int) -> None:
        """Store one chunk's rows and mark it done, atomically."""
        keys = [task.scenario_hash, task.seed, task.mode]
        tables = {name: _conform(name, result.table(name), task) for name in ROW_SCHEMAS}
        self.con.execute("BEGIN TRANSACTION")
        try:
            for name, table in tables.items():
                if table.num_rows == 0:
                    continue
                self.con.register("chunk_rows", table)
                cols = ", ".join(table.column_names)
                self.con.execute(f"INSERT INTO {name} (scenario_hash, seed, mode, {cols}) "
                                 f"SELECT ?, ?, ?, {cols} FROM chunk_rows", keys)
                self.con.unregister("chunk_rows")
            if tables["shown"].num_rows:
                prune_shown(self.con, *keys)
            self.con.execute("INSERT INTO chunks VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                             [*keys, task.first, task.count, session, result.seconds, _now()])
            self.con.execute("COMMIT")
        except duckdb.Error as exc:
            self.con.execute("ROLLBACK")
            raise CampaignError(f"chunk {task.key}: rows rejected by the database ({exc})") from exc
        except BaseException:
            self.con.execute("ROLLBACK")
            raise

    def write_chunk_error(self, task: ChunkTask, session: int, error: str) -> None:
        self.con.execute("INSERT INTO chunk_errors VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                         [task.scenario_hash, task.seed, task.mode, task.first, task.count, session, error, _now()])

    def query(self, sql: str, params: list | None = None) -> list[dict]:
        """Rows of a query as dicts (for summaries and the report)."""
        try:
            cur = self.con.execute(sql, params or [])
            names = [d[0] for d in cur.description]
            return [dict(zip(names, row)) for row in cur.fetchall()]
        except duckdb.Error as exc:
            if _is_damage(exc):
                raise self.damaged(exc) from exc
            raise

    def arrow(self, sql: str, params: list | None = None) -> pa.Table:
        try:
            return self.con.sql(sql, params=params or None).to_arrow_table()
        except duckdb.Error as exc:
            if _is_damage(exc):
                raise self.damaged(exc) from exc
            raise

    # --- settings ------------------------------------------------------------------------------------
    def check_settings(self, settings: dict, resume: bool) -> None:
        """Store the campaign's result-shaping options, or (resume) refuse values that differ from them."""
        row = self.query("SELECT value FROM settings WHERE name = 'options'")
        if not row:
            self.con.execute("INSERT INTO settings VALUES ('options', ?)", [json.dumps(settings, sort_keys=True)])
            return
        stored = json.loads(row[0]["value"])
        differ = [f"{name} {_show(stored.get(name))} (now {_show(settings.get(name))})"
                  for name in sorted(set(stored) | set(settings)) if stored.get(name) != settings.get(name)]
        if differ:
            raise CampaignError(f"{self.path.parent} was started with other options: {'; '.join(differ)}. "
                                f"{'Resume' if resume else 'Continue'} with the same options, or use a new --out")


def _is_damage(exc: duckdb.Error) -> bool:
    """A read failure of the file itself (not a mistake in a query)."""
    damage = (duckdb.IOException, duckdb.InternalException, duckdb.FatalException, duckdb.SerializationException)
    return isinstance(exc, damage) or type(exc) is duckdb.Error or "corrupt" in str(exc).lower()


def _show(value: object) -> str:
    return "(not set)" if value is None else json.dumps(value) if not isinstance(value, str) else value


def _conform(name: str, table: pa.Table, task: ChunkTask) -> pa.Table:
    """Check a worker's table against its schema and the chunk's range; cast to the schema."""
    schema = ROW_SCHEMAS[name]
    missing = [c for c in schema.names if c not in table.column_names]
    if missing:
        raise CampaignError(f"chunk {task.key}: worker's {name} rows lack columns {missing}")
    table = table.select(schema.names).cast(schema)
    if table.num_rows:
        idx = table.column("variation").to_pylist()
        if min(idx) < task.first or max(idx) >= task.first + task.count:
            raise CampaignError(f"chunk {task.key}: worker returned {name} rows for variations outside "
                                f"[{task.first}, {task.first + task.count})")
    if name == "variations" and table.num_rows != task.count:
        raise CampaignError(f"chunk {task.key}: worker returned {table.num_rows} variation rows, "
                            f"expected {task.count}")
    return table
