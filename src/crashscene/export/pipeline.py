"""`export_scenario`: a DSL scenario (and optionally a simulated run of it) -> OpenSCENARIO + OpenDRIVE files.

Writes DIR/scenario.xosc (logical), DIR/distribution.xosc (its stochastic parameter
distribution), DIR/map.xodr and, from a run directory, DIR/variations/<i>.xosc (concrete
replays) and DIR/parameter_sets.xosc (the exported variations' drawn values as a
deterministic distribution over scenario.xosc, for players without stochastic support).
Every document is built before any file is written, and each file is written to a
temporary name and renamed, so a failed export leaves what was exported before intact.
"""
from __future__ import annotations

import json
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from crashscene.export.concrete import build_variation
from crashscene.export.errors import ExportError
from crashscene.export.logical import build_distribution, build_logical, build_parameter_sets
from crashscene.export.program import read_program
from crashscene.export.xosc_common import copy_atomic, write_atomic

FAILING_VERDICTS = ("violation", "collision")  # variations where the actor under test failed
RUN_FILES = ("scenario.scenic", "map.xodr", "render.json", "scenes.jsonl", "traces.parquet", "actors.parquet",
             "variations.parquet")
DEFAULT_RUNS = 100  # numberOfTestRuns of distribution.xosc without a run directory


@dataclass
class Exported:
    scenario: Path
    distribution: Path
    map: Path
    variations: dict[int, Path] = field(default_factory=dict)
    parameter_sets: Path | None = None

    def to_json(self) -> dict:
        return {"scenario": str(self.scenario), "distribution": str(self.distribution), "map": str(self.map),
                "parameter_sets": str(self.parameter_sets) if self.parameter_sets else None,
                "variations": {str(k): str(v) for k, v in sorted(self.variations.items())}}


def parse_variations(text: str) -> list[int]:
    """'3,17' -> [3, 17]; a clear error on anything else."""
    out = []
    for item in text.split(","):
        item = item.strip()
        if not item.isdigit():
            raise ExportError(f"--variations {text!r}: {item!r} is not a variation index; allowed: "
                              "comma-separated non-negative integers, e.g. 3,17")
        out.append(int(item))
    if not out:
        raise ExportError("--variations is empty; allowed: comma-separated indices, e.g. 3,17")
    return sorted(set(out))


def _load_scenario(path: Path):
    from crashscene.dsl import DslError, load_file

    try:
        return load_file(path)
    except DslError as exc:
        raise ExportError(f"{path}: not a valid scenario:\n{exc}") from exc
    except OSError as exc:
        raise ExportError(f"{path}: cannot read the scenario: {exc}") from exc


def _plan(scenario, path: Path):
    from crashscene.render.errors import RenderError
    from crashscene.render.plan import convert

    try:
        return convert(scenario)
    except RenderError as exc:
        raise ExportError(f"{path}: the scenario cannot be rendered: {exc}") from exc


def _network(map_path: Path):
    from scenic.domains.driving.roads import Network

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return Network.fromFile(str(map_path), useCache=True, writeCache=False)
    except Exception as exc:  # Scenic's parser raises many types
        raise ExportError(f"{map_path}: Scenic cannot parse the map: {type(exc).__name__}: {exc}") from exc


def _read_run(run_dir: Path, scenario, scenario_path: Path):
    """Check a run directory against the scenario; return (variations table, scenes by index)."""
    from crashscene.render.plan import scenario_hash
    from crashscene.scene import SampledScene

    if not run_dir.is_dir():
        raise ExportError(f"--from {run_dir}: not a directory (expected a `crashscene simulate --out` folder)")
    missing = [name for name in RUN_FILES if not (run_dir / name).is_file()]
    if missing:
        raise ExportError(f"--from {run_dir}: missing {', '.join(missing)}; a run directory of `crashscene simulate` "
                          f"holds {', '.join(RUN_FILES)}")
    try:
        meta = json.loads((run_dir / "render.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ExportError(f"{run_dir / 'render.json'}: unreadable: {exc}") from exc
    if meta.get("map_mode") != "generated":
        raise ExportError(f"{run_dir / 'render.json'}: map_mode = {meta.get('map_mode')!r} is not supported; allowed: "
                          "'generated' (the export ships the map; re-simulate with --map generated)")
    try:
        variations = pq.read_table(run_dir / "variations.parquet")
    except Exception as exc:  # pyarrow raises several types on a corrupt file
        raise ExportError(f"{run_dir / 'variations.parquet'}: unreadable: {exc}") from exc
    for col in ("variation", "scenario_hash", "valid", "params"):
        if col not in variations.column_names:
            raise ExportError(f"{run_dir / 'variations.parquet'}: no column {col!r}")
    expected = scenario_hash(scenario, map_mode="generated", town="")
    hashes = sorted(set(variations["scenario_hash"].to_pylist()))
    if hashes != [expected]:
        raise ExportError(f"{run_dir / 'variations.parquet'}: scenario_hash = {', '.join(map(str, hashes))}, but "
                          f"{scenario_path} hashes to {expected}: the run was simulated from another scenario")
    scenes = {}
    with open(run_dir / "scenes.jsonl", encoding="utf-8") as fh:
        for line_no, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                scene = SampledScene.model_validate_json(line)
            except ValueError as exc:
                raise ExportError(f"{run_dir / 'scenes.jsonl'}: line {line_no}: not a sampled scene: {exc}") from exc
            scenes[scene.index] = scene
    if not scenes:
        raise ExportError(f"{run_dir / 'scenes.jsonl'}: no scenes")
    return variations, scenes


def _choose(run_dir: Path, variations: pa.Table, chosen: list[int] | None, failing: bool) -> list[int]:
    rows = {r["variation"]: r for r in variations.to_pylist()}
    if failing:
        path = run_dir / "verdicts.parquet"
        if not path.is_file():
            raise ExportError(f"--failing needs {path}: run `crashscene monitor {run_dir}` first")
        verdicts = pq.read_table(path).to_pylist()
        chosen = sorted(r["variation"] for r in verdicts if r["verdict"] in FAILING_VERDICTS)
    elif chosen is None:
        chosen = sorted(v for v, r in rows.items() if r["valid"])
    unknown = [v for v in chosen if v not in rows]
    if unknown:
        raise ExportError(f"--variations {','.join(map(str, unknown))}: not in {run_dir / 'variations.parquet'}; "
                          f"allowed: {min(rows)}..{max(rows)}")
    invalid = [v for v in chosen if not rows[v]["valid"]]
    if invalid:
        reasons = "; ".join(f"{v}: {rows[v].get('invalid_reason')}" for v in invalid)
        raise ExportError(f"variations {','.join(map(str, invalid))} are invalid (not simulated: {reasons}); "
                          "choose valid ones")
    return chosen


def export_scenario(scenario_path: Path, out_dir: Path, run_dir: Path | None = None,
                    variations: list[int] | None = None, failing: bool = False, n: int = DEFAULT_RUNS,
                    seed: int = 0) -> Exported:
    """Export `scenario_path` to `out_dir`; with `run_dir`, also its chosen (or failing, or all valid) variations."""
    from crashscene.render import RenderError, render
    from crashscene.render.sample import sample_scenes

    scenario_path, out_dir = Path(scenario_path), Path(out_dir)
    if (variations is not None or failing) and run_dir is None:
        raise ExportError("--variations and --failing need --from RUN_DIR (a `crashscene simulate --out` folder)")
    if variations is not None and failing:
        raise ExportError("--variations and --failing exclude each other; give one")
    scenario = _load_scenario(scenario_path)
    plan = _plan(scenario, scenario_path)
    concrete, parameter_sets = {}, None
    with tempfile.TemporaryDirectory(prefix="crashscene-export-") as tmp:
        if run_dir is not None:
            run_dir = Path(run_dir)
            table, scenes = _read_run(run_dir, scenario, scenario_path)
            program, map_path = run_dir / "scenario.scenic", run_dir / "map.xodr"
            reference = scenes[min(scenes)]
            seeds = sorted(set(table["seed"].to_pylist())) if "seed" in table.column_names else [seed]
            n, seed = table.num_rows, int(seeds[0])
        else:
            try:
                rendered = render(scenario, Path(tmp) / "render")
                program, map_path = rendered.program, rendered.map
                reference = sample_scenes(program, 1, seed)[0]
            except RenderError as exc:
                raise ExportError(f"{scenario_path}: render/sample failed: {exc}") from exc
        sampling = read_program(program)
        logical = build_logical(plan, sampling, reference, map_path, network=_network(map_path))
        distribution = build_distribution(sampling, n, seed)
        if run_dir is not None:
            chosen = _choose(run_dir, table, variations, failing)
            try:
                traces = pq.read_table(run_dir / "traces.parquet",
                                       columns=["variation", "actor", "step", "t", "x", "y", "yaw", "speed"])
                actors = pq.read_table(run_dir / "actors.parquet")
            except Exception as exc:  # corrupt or foreign Parquet
                raise ExportError(f"{run_dir}: traces.parquet/actors.parquet unreadable or without the trace "
                                  f"columns (variation, actor, step, t, x, y, yaw, speed): {exc}") from exc
            params = {r["variation"]: r["params"] for r in table.to_pylist()}
            for v in chosen:
                if v not in scenes:
                    raise ExportError(f"{run_dir / 'scenes.jsonl'}: no scene for variation {v}")
                mask_t = pc.equal(traces["variation"], v)
                mask_a = pc.equal(actors["variation"], v)
                concrete[v] = build_variation(v, scenes[v], traces.filter(mask_t), actors.filter(mask_a), params[v],
                                              scenario_id=plan.scenario_id)
            if chosen:
                parameter_sets = build_parameter_sets(sampling, [scenes[v] for v in chosen])
        out_dir.mkdir(parents=True, exist_ok=True)
        result = Exported(scenario=write_atomic(logical, out_dir / "scenario.xosc"),
                          distribution=write_atomic(distribution, out_dir / "distribution.xosc"),
                          map=copy_atomic(map_path, out_dir / "map.xodr"))
        for v, document in concrete.items():
            result.variations[v] = write_atomic(document, out_dir / "variations" / f"{v}.xosc")
        if parameter_sets is not None:
            result.parameter_sets = write_atomic(parameter_sets, out_dir / "parameter_sets.xosc")
    return result
