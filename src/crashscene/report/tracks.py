"""The traces of one variation as the report draws them, and where to find them.

In order of preference: the traces the campaign kept in its database for the
variations the report draws (`campaign.keep`), a kept run folder
(`crashscene run`, `--keep-traces`), or, for an old campaign that kept
neither, a one-variation re-simulation (variation i depends only on
(scenario, seed, mode, i), so it reproduces the stored rows; cached under
`OUT/cases/<case>/report/`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from crashscene.report.palette import label_of, label_sort_key


@dataclass
class ActorTrack:
    """One actor's trace in one variation."""

    role: str
    t: np.ndarray  # [s]
    x: np.ndarray  # [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # [rad]
    length: float  # [m]
    width: float  # [m]
    label: str = ""  # report label (V1, V2, ...); derived from the role when empty
    type: str = "car"
    is_ads: bool = False

    def __post_init__(self) -> None:
        self.label = label_of(self.role, self.label)

    def at(self, time: float) -> tuple[float, float, float]:
        """Pose at `time` [s] (the last sample at or before it)."""
        k = int(np.clip(np.searchsorted(self.t, time, side="right") - 1, 0, len(self.t) - 1))
        return float(self.x[k]), float(self.y[k]), float(self.yaw[k])


def tracks_from_tables(traces: pa.Table, actors: pa.Table, variation: int) -> list[ActorTrack]:
    """Every actor's track in `variation`, in report-label order (V1 first)."""
    traces = traces.filter(pc.equal(traces.column("variation"), variation))
    rows = actors.filter(pc.equal(actors.column("variation"), variation)).to_pylist()
    out = []
    for actor in rows:
        sel = traces.filter(pc.equal(traces.column("actor"), actor["actor"])).sort_by("t")
        if sel.num_rows == 0:
            continue
        cols = {c: sel.column(c).to_numpy() for c in ("t", "x", "y", "yaw")}
        out.append(ActorTrack(role=actor["actor"], length=float(actor["length"]), width=float(actor["width"]),
                              label=actor.get("label") or "", type=actor.get("type") or "car",
                              is_ads=bool(actor.get("is_ads")), **cols))
    return sorted(out, key=lambda tr: (label_sort_key(tr.label), tr.role))


def _run_dirs(case_work: Path, mode: str) -> list[Path]:
    return sorted(p for p in (case_work / "runs" / mode).glob("*-*") if (p / "traces.parquet").exists())


def find_run_dir(case_work: Path, mode: str, variation: int) -> Path | None:
    """The kept chunk folder holding `variation`, if any."""
    for run_dir in _run_dirs(case_work, mode):
        first, last = (int(x) for x in run_dir.name.split("-"))
        if first <= variation <= last:
            return run_dir
    cached = case_work / "report" / f"{mode}-{variation:06d}"
    return cached if (cached / "traces.parquet").exists() else None


def ensure_run_dir(case_work: Path, case_id: str, run: dict, variation: int) -> Path:
    """A folder with the traces of `variation`: a kept chunk, or a fresh one-variation re-simulation."""
    found = find_run_dir(case_work, run["mode"], variation)
    if found is not None:
        return found
    from crashscene.campaign.model import ChunkTask, SimOptions
    from crashscene.campaign.worker import simulate_chunk

    target = case_work / "report" / f"{run['mode']}-{variation:06d}"
    task = ChunkTask(case_id=case_id, scenario_yaml=run["scenario_yaml"], scenario_hash=run["scenario_hash"],
                     seed=run["seed"], mode=run["mode"], first=variation, count=1,
                     options=SimOptions.model_validate_json(run["options"]), keep_dir=str(target))
    simulate_chunk(task)
    return target


def load_tracks(run_dir: Path, variation: int) -> list[ActorTrack]:
    """Every actor's track in `variation` from a run folder."""
    traces = pq.read_table(run_dir / "traces.parquet", columns=["variation", "actor", "t", "x", "y", "yaw"],
                           filters=[("variation", "=", variation)])
    names = pq.read_schema(run_dir / "actors.parquet").names
    cols = [c for c in ("variation", "actor", "label", "type", "is_ads", "length", "width") if c in names]
    actors = pq.read_table(run_dir / "actors.parquet", columns=cols, filters=[("variation", "=", variation)])
    return tracks_from_tables(traces, actors, variation)


def map_file_of(run_dir: Path | None, case_work: Path) -> Path | None:
    for candidate in ((run_dir / "map.xodr") if run_dir else None, case_work / "render" / "map.xodr"):
        if candidate is not None and candidate.exists():
            return candidate
    return None
