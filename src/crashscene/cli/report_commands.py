"""`crashscene report`: the HTML report, results.json and JUnit XML of a run or campaign folder."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


@app.command()
def report(
    out_dir: Annotated[Path, typer.Argument(help="Output folder of `crashscene run` or `crashscene campaign`.")],
    gifs: Annotated[bool, typer.Option("--gifs/--no-gifs", help="Animated bird's-eye GIFs (slower).")] = True,
) -> None:
    """Write DIR/report.html (self-contained), DIR/results.json and DIR/junit.xml."""
    from crashscene.report import ReportError, write_report

    try:
        written = write_report(out_dir, gifs=gifs, progress=lambda line: typer.echo(line, err=True))
    except ReportError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(f"report: {written.html}\nresults: {written.results}\njunit: {written.junit}")
