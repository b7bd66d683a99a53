"""Find the cases of a campaign and prepare each one: extract -> validate -> render.

A case is a crash-report folder (narrative.txt|md|pdf, optional sketch) that is
extracted to the DSL, or a DSL `.yaml` file used as is. Preparation happens once
per case in the driver (it is fast); its artefacts are kept under
`OUT/cases/<case_id>/`: `scenario.yaml`, `extraction.json`, `render/scenario.scenic`,
`render/map.xodr`. A case that fails to prepare is recorded with its error and the
campaign goes on with the others.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import time
from pathlib import Path

from pydantic import BaseModel, ConfigDict

from crashscene.campaign.errors import CampaignError
from crashscene.campaign.model import SimOptions
from crashscene.dsl import DslError, Scenario, dumps, validate, validate_file

NARRATIVES = ("narrative.txt", "narrative.md", "narrative.pdf")
SKETCHES = ("sketch.jpg", "sketch.jpeg", "sketch.png")


class PreparedCase(BaseModel):
    """A case ready to simulate, or the reason it is not."""

    model_config = ConfigDict(extra="forbid")

    case_id: str
    case_dir: str
    work_dir: str
    status: str  # ok | error
    error: str | None = None
    scenario_yaml: str | None = None
    scenario_hash: str | None = None
    extract_backend: str | None = None
    warnings: list[str] = []
    seconds: float = 0.0


class PrepareTask(BaseModel):
    """One case to prepare in a worker process (cases are prepared in parallel on the local engine)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    path: Path
    out_dir: Path
    options: SimOptions
    extract_backend: str = "rules"
    dsl_name: str | None = None
    llm: dict[str, str] = {}  # model, base_url, model_path for the openai/local extractors

    @property
    def key(self) -> str:
        return f"case {self.path}"


def prepare_task(task: PrepareTask) -> PreparedCase:
    return prepare_case(task.path, task.out_dir, task.options, task.extract_backend, task.dsl_name, task.llm)


def is_case_folder(path: Path) -> bool:
    return path.is_dir() and any((path / name).is_file() for name in NARRATIVES)


def discover_cases(cases_dir: str | Path, dsl_name: str | None = None) -> list[Path]:
    """Case folders and DSL files in `cases_dir` (or `cases_dir` itself when it is one case), sorted."""
    root = Path(cases_dir)
    if not root.exists():
        raise CampaignError(f"{root}: no such folder; give a folder of case folders (each with narrative.txt) "
                            "or of scenario .yaml files")
    if root.is_file():
        if root.suffix.lower() in (".yaml", ".yml"):
            return [root]
        raise CampaignError(f"{root}: not a case; expected a case folder or a scenario .yaml file")
    if is_case_folder(root) or (dsl_name and (root / dsl_name).is_file()):
        return [root]
    found = [p for p in sorted(root.iterdir())
             if is_case_folder(p) or (dsl_name and (p / dsl_name).is_file())
             or (p.is_file() and p.suffix.lower() in (".yaml", ".yml"))]
    if not found:
        raise CampaignError(f"{root}: no cases found; expected sub-folders with one of {', '.join(NARRATIVES)}"
                            f"{' or ' + dsl_name if dsl_name else ''}, or scenario .yaml files")
    return found


def case_id_of(path: Path) -> str:
    return path.stem if path.is_file() else path.resolve().name


def scenario_hash(scenario: Scenario, options: SimOptions) -> str:
    """Content hash of the canonical DSL text and the render options (the campaign's scenario key)."""
    text = dumps(scenario) + json.dumps(options.model_dump(include={"map_mode", "carla_maps"}), sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def prepare_case(path: Path, out_dir: Path, options: SimOptions, extract_backend: str = "rules",
                 dsl_name: str | None = None, llm: dict[str, str] | None = None) -> PreparedCase:
    """Extract (or read), validate and render one case; errors are returned in the record, not raised."""
    start = time.perf_counter()
    case_id = case_id_of(path)
    work = out_dir / "cases" / case_id
    work.mkdir(parents=True, exist_ok=True)
    record = dict(case_id=case_id, case_dir=str(path), work_dir=str(work))
    try:
        scenario, backend, warnings = _scenario_of(path, work, extract_backend, dsl_name, llm or {})
        (work / "scenario.yaml").write_text(dumps(scenario), encoding="utf-8")
        digest = _render(scenario, work / "render", options) or scenario_hash(scenario, options)
    except Exception as exc:  # noqa: BLE001  (a case that fails is reported; the campaign goes on)
        return PreparedCase(**record, status="error", error=_message(exc), seconds=time.perf_counter() - start)
    return PreparedCase(**record, status="ok", scenario_yaml=dumps(scenario), scenario_hash=digest,
                        extract_backend=backend, warnings=warnings, seconds=time.perf_counter() - start)


def _scenario_of(path: Path, work: Path, backend: str, dsl_name: str | None,
                 llm: dict[str, str]) -> tuple[Scenario, str, list[str]]:
    dsl_file = path if path.is_file() else (path / dsl_name if dsl_name else None)
    if dsl_file is not None and dsl_file.is_file():
        scenario, warnings = validate_file(dsl_file)
        return scenario, f"file:{dsl_file.name}", [str(w) for w in warnings]
    from crashscene.extract.pipeline import extract_case

    result = extract_case(path, backend=backend, **llm)
    meta = _extraction_meta(result, backend)
    (work / "extraction.json").write_text(json.dumps(meta, indent=2, default=str), encoding="utf-8")
    if result.scenario is None:
        raise CampaignError(f"{path}: extraction ({backend}) failed: {result.error or 'no scenario'}")
    warnings = [*getattr(result, "warnings", []), *map(str, validate(result.scenario))]
    return result.scenario, str(meta.get("backend") or backend), [str(w) for w in warnings]


def _extraction_meta(result: object, backend: str) -> dict:
    """What the extraction result says about itself (backend, tokens, cost, seconds), JSON-safe."""
    meta = {"backend": backend}
    dump = getattr(result, "model_dump", None)
    if callable(dump):
        data = dump(mode="json", exclude={"scenario"})
        meta.update({k: v for k, v in data.items() if isinstance(v, (str, int, float, bool, list, dict, type(None)))})
    return meta


def _render(scenario: Scenario, render_dir: Path, options: SimOptions) -> str | None:
    """Render the Scenic program and map (kept as artefacts); returns the renderer's scenario hash."""
    if importlib.util.find_spec("crashscene.render") is None:  # no render stage in this build: the DSL hash keys
        return None
    from crashscene.render import render

    rendered = render(scenario, render_dir, map_mode=options.map_mode,
                      carla_maps=Path(options.carla_maps) if options.carla_maps else None)
    return getattr(rendered, "scenario_hash", None)


def _message(exc: Exception) -> str:
    if isinstance(exc, DslError):
        return "invalid scenario: " + "; ".join(str(d) for d in exc.diagnostics if d.severity == "error")[:2000]
    return f"{type(exc).__name__}: {exc}"[:2000]
