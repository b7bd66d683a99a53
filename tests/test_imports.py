"""Every `crashscene` import written in the sources and tests resolves, lazy ones inside functions included.

Modules move (issue 14 point 5 folded the render stage, moved the orchestrators to `pipeline/`); an import
inside a function only fails when that function runs, so this reads every import statement and resolves it.
"""
from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
FILES = sorted([*(REPO / "src" / "crashscene").rglob("*.py"), *(REPO / "tests").rglob("*.py"),
                *(REPO / "benchmarks").glob("*.py")])


def crashscene_imports(path: Path) -> list[tuple[int, str, tuple[str, ...]]]:
    """(line, module, names) of every absolute `crashscene` import in the file."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name, ()) for alias in node.names if alias.name.split(".")[0] == "crashscene"]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "crashscene":
            out.append((node.lineno, node.module, tuple(alias.name for alias in node.names)))
    return out


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(REPO)))
def test_every_crashscene_import_resolves(path):
    for line, module_name, names in crashscene_imports(path):
        where = f"{path.relative_to(REPO)}:{line}"
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if (exc.name or "").split(".")[0] == "crashscene":
                pytest.fail(f"{where}: no module {exc.name} (moved? see the README's layout)")
            continue  # an optional dependency (carla, ray, ...) absent here: not this test's business
        for name in names:
            if name == "*" or hasattr(module, name):
                continue
            try:
                importlib.import_module(f"{module_name}.{name}")
            except ModuleNotFoundError:
                pytest.fail(f"{where}: {module_name} has no {name}")
