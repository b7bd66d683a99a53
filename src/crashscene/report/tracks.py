"""Find the trace of one variation for the report: from kept run folders, else by re-simulating it.

Variation i depends only on (scenario, seed, mode, i), so re-running it alone
(one-variation chunk) reproduces exactly the rows the campaign stored; the
result is cached under `OUT/cases/<case>/report/`.
"""
from __future__ import annotations

from pathlib import Path

import pyarrow.compute as pc
import pyarrow.parquet as pq

from crashscene.campaign.model import ChunkTask, SimOptions
from crashscene.report.birdseye import ActorTrack


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
    from crashscene.campaign.worker import simulate_chunk

    target = case_work / "report" / f"{run['mode']}-{variation:06d}"
    task = ChunkTask(case_id=case_id, scenario_yaml=run["scenario_yaml"], scenario_hash=run["scenario_hash"],
                     seed=run["seed"], mode=run["mode"], first=variation, count=1,
                     options=SimOptions.model_validate_json(run["options"]), keep_dir=str(target))
    simulate_chunk(task)
    return target


def load_tracks(run_dir: Path, variation: int) -> list[ActorTrack]:
    """Every actor's track in `variation`, ego first."""
    traces = pq.read_table(run_dir / "traces.parquet", columns=["variation", "actor", "t", "x", "y", "yaw"],
                           filters=[("variation", "=", variation)])
    actors = pq.read_table(run_dir / "actors.parquet", columns=["variation", "actor", "length", "width"],
                           filters=[("variation", "=", variation)]).to_pylist()
    tracks = []
    for actor in sorted(actors, key=lambda a: (a["actor"] != "ego", a["actor"])):
        rows = traces.filter(pc.equal(traces.column("actor"), actor["actor"])).sort_by("t")
        cols = {c: rows.column(c).to_numpy() for c in ("t", "x", "y", "yaw")}
        tracks.append(ActorTrack(role=actor["actor"], length=actor["length"], width=actor["width"], **cols))
    return tracks


def map_file_of(run_dir: Path, case_work: Path) -> Path | None:
    for candidate in (run_dir / "map.xodr", case_work / "render" / "map.xodr"):
        if candidate.exists():
            return candidate
    return None
