"""Typed records a campaign passes around: options, chunk tasks and chunk results.

A chunk is a contiguous range of variation indices of one scenario, seed and
mode. Variation i depends only on (scenario, seed, mode, i), so any chunking
(and any engine) yields the same rows.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import pyarrow as pa
from pydantic import BaseModel, ConfigDict, Field

from crashscene.campaign.keep import SHOWN_ACTOR_ROWS, SHOWN_ROWS, SHOWN_SCHEMAS, SHOWN_TRACE_ROWS

Mode = Literal["reproduce", "test"]
MODES: tuple[str, ...] = ("reproduce", "test")
Engine = Literal["local", "ray"]

# Rows a worker returns for one chunk; the store adds the key columns (scenario_hash, seed, mode).
VARIATION_ROWS = pa.schema([
    ("variation", pa.int32()),
    ("valid", pa.bool_()),
    ("invalid_reason", pa.string()),
    ("verdict", pa.string()),        # violation | collision | pass | invalid
    ("reproduced", pa.bool_()),      # every oracle entry observed and the crash sequence happened
    ("collided", pa.bool_()),        # any collision in this variation
    ("params", pa.string()),         # JSON object: sampled parameters and per-actor start values [SI]
    ("first_contact", pa.bool_()),   # the first contact is the reported one (monitor verdicts)
    ("sequence", pa.bool_()),        # the reported crash sequence happened, in order
    ("area_match", pa.bool_()),      # ... with the reported areas (null without a written sequence)
])
VIOLATION_ROWS = pa.schema([
    ("variation", pa.int32()),
    ("actor", pa.string()),
    ("is_ads", pa.bool_()),
    ("code", pa.string()),
    ("violation", pa.string()),
    ("t_first", pa.float64()),       # [s]
    ("value", pa.float64()),
    ("threshold", pa.float64()),
    ("unit", pa.string()),
    ("robustness", pa.float64()),
])
COLLISION_ROWS = pa.schema([
    ("variation", pa.int32()),
    ("t", pa.float64()),             # [s]
    ("actor_a", pa.string()),
    ("actor_b", pa.string()),
    ("collision_class", pa.string()),  # rear_end | head_on | angle | sideswipe
    ("speed_a", pa.float64()),       # [m/s]
    ("speed_b", pa.float64()),
    ("x", pa.float64()),             # [m]
    ("y", pa.float64()),
    ("contact_index", pa.int32()),   # order of the contact in its variation, from 0
    ("area_a", pa.string()),         # front | rear | left | right of actor_a that touched
    ("area_b", pa.string()),
    ("delta_v_a", pa.float64()),     # [m/s] when the simulator records it
    ("delta_v_b", pa.float64()),
])
CRITICALITY_ROWS = pa.schema([     # monitor.criticality per (variation, actor pair)
    ("variation", pa.int32()),
    ("actor_a", pa.string()),
    ("actor_b", pa.string()),
    ("involves_ads", pa.bool_()),
    ("min_ttc", pa.float64()),       # [s]
    ("pet", pa.float64()),           # [s]
    ("min_thw", pa.float64()),       # [s]
    ("max_drac", pa.float64()),      # [m/s2]
    ("collided", pa.bool_()),
    ("impact_speed", pa.float64()),  # [m/s]
    ("delta_v_a", pa.float64()),     # [m/s]
    ("delta_v_b", pa.float64()),     # [m/s]
])
ROW_SCHEMAS = {"variations": VARIATION_ROWS, "violations": VIOLATION_ROWS, "collisions": COLLISION_ROWS,
               "criticality": CRITICALITY_ROWS, **SHOWN_SCHEMAS}


class SimOptions(BaseModel):
    """How every chunk of a campaign is simulated."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    backend: str = Field(default="embedded", description="simulate backend: a name or 'package.module:Class'")
    backend_target: str | None = Field(default=None, description="'package.module:Class' of the backend, which "
                                       "a worker process imports (a backend registered in the driver only)")
    ego_role: str = Field(default="ego", description="the DSL role driven by the ADS under test")
    ads: str | None = Field(default=None, description="'package.module:Class' of the ADS driver (None: reference)")
    ads_params: dict[str, float | int | str | bool] = Field(default_factory=dict, description="ADS parameters")
    dt: float = Field(default=0.1, gt=0, le=1.0, description="[s] simulation step")
    horizon: float = Field(default=20.0, gt=0, le=600.0, description="[s] simulated time per variation")
    carla_host: str = Field(default="127.0.0.1", description="CARLA server host (carla backend)")
    carla_port: int = Field(default=2000, ge=1, le=65535, description="CARLA server port (carla backend)")
    map_mode: Literal["generated", "carla"] = "generated"
    carla_maps: str | None = Field(default=None, description="folder of CARLA .xodr towns for map_mode=carla")
    rules_file: str | None = Field(default=None, description="YAML rulebook overriding the monitor's thresholds")
    rules_digest: str | None = Field(default=None, description="sha256 of the rulebook file's contents (resume "
                                     "compares it)")
    allow_imports: bool = Field(default=False, description="the rulebook's `imports:` may import modules")
    sampler: Literal["compiled", "scenic"] | None = Field(default=None, description="scene sampler: compiled "
                                                          "(numpy, render's sampler.json), scenic (the reference), "
                                                          "None: the backend's")


class ChunkTask(BaseModel):
    """Everything a worker needs to simulate one chunk, picklable and self-contained (no shared state)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    case_id: str
    scenario_yaml: str = Field(description="canonical DSL text of the scenario")
    scenario_hash: str
    seed: int
    mode: Mode
    first: int = Field(ge=0, description="first variation index")
    count: int = Field(gt=0)
    options: SimOptions = SimOptions()
    keep_dir: str | None = Field(default=None, description="write the chunk's run directory here (traces kept)")
    render_dir: str | None = Field(default=None, description="the case's rendered program and map (rendered once "
                                   "per case; a worker that cannot see this folder renders again)")

    @property
    def key(self) -> str:
        return f"{self.case_id}/{self.mode}/{self.first}-{self.first + self.count - 1}"


@dataclass
class ChunkResult:
    """What a worker returns: rows per table (ROW_SCHEMAS) and its wall time."""

    variations: pa.Table
    violations: pa.Table
    collisions: pa.Table
    seconds: float = 0.0
    shown: pa.Table = field(default_factory=SHOWN_ROWS.empty_table)  # the report's candidates (campaign.keep)
    shown_traces: pa.Table = field(default_factory=SHOWN_TRACE_ROWS.empty_table)
    shown_actors: pa.Table = field(default_factory=SHOWN_ACTOR_ROWS.empty_table)
    criticality: pa.Table | None = None   # None: the worker computed no criticality metrics

    def table(self, name: str) -> pa.Table:
        table = getattr(self, name)
        return ROW_SCHEMAS[name].empty_table() if table is None else table
