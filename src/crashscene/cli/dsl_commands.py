"""`crashscene validate` and `crashscene schema`."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


@app.command()
def validate(
    files: Annotated[list[Path], typer.Argument(help="Scenario YAML files.")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable diagnostics on stdout.")] = False,
) -> None:
    """Validate scenario files; exit 0 only when all are valid (warnings allowed)."""
    from crashscene.dsl import DslError, validate_file

    report = []
    failed = False
    for path in files:
        try:
            _, warnings = validate_file(path)
            diagnostics, valid = warnings, True
        except DslError as exc:
            diagnostics, valid = exc.diagnostics, False
            failed = True
        report.append({"file": str(path), "valid": valid, "diagnostics": [d.to_json() for d in diagnostics]})
        if not as_json:
            for diag in diagnostics:
                typer.echo(str(diag), err=True)
            typer.echo(f"{path}: {'ok' if valid else 'INVALID'}")
    if as_json:
        typer.echo(json.dumps({"valid": not failed, "files": report}, indent=2))
    raise typer.Exit(1 if failed else 0)


@app.command()
def schema(
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write to this file instead of stdout.")] = None,
) -> None:
    """Print the JSON Schema of the DSL (also the LLM's structured-output schema)."""
    from crashscene.dsl.schema import json_schema_text

    text = json_schema_text()
    if output is None:
        typer.echo(text, nl=False)
    else:
        output.write_text(text, encoding="utf-8")
