"""The render stage flows one way: plan, then map, then program, then sampler (issue 14 point 5).

Every import between the stage's modules, at module level or inside a function, is read from the source
and must point to the same step or an earlier one; no step imports the package facade (`render/__init__.py`,
which runs the steps), and the stage imports nothing from the stages after it.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import crashscene.render

PACKAGE = Path(crashscene.render.__file__).resolve().parent
STEPS = {  # module -> step; a module may import only modules of its own step or an earlier one
    "errors": 0,
    "plan": 1,
    "opendrive": 2, "maps": 2,
    "scenic_support": 3, "program": 3,
    "sampling_plan": 4, "compiled_sampler": 4, "sample": 4,
}
LATER_STAGES = ("simulate", "pipeline", "campaign", "report", "export", "search", "extract", "evaluation", "traces",
                "cli")
MODULES = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")


def imports_of(module: str) -> set[str]:
    """Dotted names of every crashscene module `module` imports (`from pkg import sub` resolved to pkg.sub)."""
    tree = ast.parse((PACKAGE / f"{module}.py").read_text(encoding="utf-8"))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            for alias in node.names:  # `from crashscene.render import scenic_support` names a submodule
                if node.module == "crashscene.render" and (PACKAGE / f"{alias.name}.py").exists():
                    found.discard(node.module)
                    found.add(f"{node.module}.{alias.name}")
    return {name for name in found if name == "crashscene" or name.startswith("crashscene.")}


def test_every_module_of_the_stage_has_a_step():
    assert MODULES == sorted(STEPS), "place a new render module in STEPS (plan, map, program or sampler)"


@pytest.mark.parametrize("module", MODULES)
def test_imports_point_to_the_same_or_an_earlier_step(module):
    for name in imports_of(module):
        assert name != "crashscene.render", f"render/{module}.py imports the package facade; import the step"
        if name.startswith("crashscene.render."):
            target = name.split(".")[2]
            assert STEPS[target] <= STEPS[module], (
                f"render/{module}.py (step {STEPS[module]}) climbs back to render/{target}.py (step {STEPS[target]})")
        else:
            stage = name.split(".")[1] if "." in name else ""
            assert stage not in LATER_STAGES, f"render/{module}.py imports {name}, a stage after render"


def test_no_cycle_within_a_step():
    graph = {m: {n.split(".")[2] for n in imports_of(m) if n.startswith("crashscene.render.")} - {m}
             for m in MODULES}
    done: set[str] = set()

    def visit(module: str, path: tuple[str, ...]) -> None:
        assert module not in path, f"import cycle: {' -> '.join((*path, module))}"
        if module in done:
            return
        for target in graph[module]:
            visit(target, (*path, module))
        done.add(module)

    for module in MODULES:
        visit(module, ())


def test_the_facade_runs_the_steps_in_order():
    """`render()` calls plan, map, program and sampling plan, in that order (the flow a scenario follows)."""
    source = (PACKAGE / "__init__.py").read_text(encoding="utf-8")
    body = source[source.index("def render("):]
    calls = ["convert(", "prepare_map(", "program_context(", "program_text(", "install_map(", "sampling_plan("]
    positions = [body.index(call) for call in calls]
    assert positions == sorted(positions)
