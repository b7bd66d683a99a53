"""Per-case exports shared by the export tests: one short simulated run per bundled case, exported once."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import EXAMPLES

RUN_VARIATIONS = 4  # simulated variations per case: each becomes a concrete scenario
RUN_SEED = 7


@dataclass(frozen=True)
class CaseExport:
    case: str
    run_dir: Path
    out_dir: Path
    result: object  # crashscene.export.pipeline.Exported


@pytest.fixture(scope="session")
def case_export(tmp_path_factory):
    """case name -> CaseExport (simulated and exported on first use, then reused)."""
    from crashscene.dsl import load_file
    from crashscene.export.pipeline import export_scenario
    from crashscene.pipeline.simulate import simulate_scenario

    cache: dict[str, CaseExport] = {}

    def get(case: str) -> CaseExport:
        if case not in cache:
            root = tmp_path_factory.mktemp(f"export_{case}")
            scenario_path = EXAMPLES / case / "golden.yaml"
            run_dir = root / "run"
            simulate_scenario(load_file(scenario_path), run_dir, n=RUN_VARIATIONS, seed=RUN_SEED, mode="reproduce",
                              monitor=False)
            result = export_scenario(scenario_path, root / "export", run_dir=run_dir)
            cache[case] = CaseExport(case, run_dir, root / "export", result)
        return cache[case]

    return get
