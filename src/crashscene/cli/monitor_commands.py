"""`crashscene monitor RUN_DIR [--rules FILE] [--json]`: re-evaluate the stored traces of a run."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


@app.command()
def monitor(
    run_dir: Annotated[Path, typer.Argument(help="Run directory written by `crashscene simulate` "
                                                 "(scenario.yaml + traces/actors/collisions/variations.parquet).")],
    rules: Annotated[Path | None, typer.Option("--rules", help="Rulebook YAML overriding thresholds "
                                               "(rules: {CVC_21703: {min_headway: 1.5}}).")] = None,
    allow_imports: Annotated[bool, typer.Option("--allow-imports", help="Let the --rules file's `imports:` import "
                                                "Python modules (runs their code).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON on stdout.")] = False,
) -> None:
    """Check every actor of every variation against the rulebook (`crashscene rules`), classify
    collisions and give each variation a verdict; writes rule_results.parquet, collisions_classified.parquet,
    verdicts.parquet and monitor.json into RUN_DIR."""
    from crashscene.monitor import MonitorError, monitor_run

    try:
        result = monitor_run(run_dir, rules, allow_imports)
    except MonitorError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    summary = result.summary()
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    _print_summary(run_dir, summary)


def _print_summary(run_dir: Path, summary: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    console.print(f"[bold]{run_dir}[/]: {summary['variations']} variations, {summary['valid']} valid")
    verdicts = ", ".join(f"{name} {count}" for name, count in summary["verdicts"].items())
    console.print(f"verdicts: {verdicts}")
    rate = summary["reproduction_rate"]
    console.print(f"reproduced: {summary['reproduced']}" + (f" ({rate:.1%} of valid)" if rate is not None else ""))
    rates = [f"{name.replace('_rate', '').replace('_', ' ')} {summary[name]:.1%}"
             for name in ("first_contact_rate", "sequence_rate", "area_match_rate") if summary.get(name) is not None]
    if rates:
        console.print("crash sequence: " + ", ".join(rates))
    if summary["violations"]:
        table = Table(title="violations", caption="(variations)")
        table.add_column("code")
        roles = sorted({r for per in summary["violations"].values() for r in per})
        for role in roles:
            table.add_column(role, justify="right")
        for code, per in summary["violations"].items():
            table.add_row(code, *[str(per.get(role, 0)) for role in roles])
        console.print(table)
    collisions = ", ".join(f"{k} {v}" for k, v in summary["collisions"].items() if v)
    console.print(f"collisions: {collisions or 'none'}")
    expected = summary.get("expected_collision")
    if expected:
        accepted = "/".join(expected["accepted"] or ["any class"])
        console.print(f"expected crash: {accepted} between {' and '.join(expected['actors'])}")
    for entry in summary["oracle"]:
        seen = "unmonitored" if not entry["monitored"] else f"observed in {entry['observed']}"
        console.print(f"oracle {entry['code']} by {entry['actor']}: {seen}")


@app.command("rules")
def rules_command(
    rules: Annotated[Path | None, typer.Option("--rules", help="Show this rulebook's effective values "
                                               "instead of the defaults.")] = None,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write to this file instead of stdout.")] = None,
    allow_imports: Annotated[bool, typer.Option("--allow-imports", help="Let the --rules file's `imports:` import "
                                                "Python modules (runs their code).")] = False,
) -> None:
    """Print the monitor's rulebook (every rule, threshold and unit) as an editable YAML file for --rules."""
    from crashscene.monitor import MonitorError
    from crashscene.monitor.rulebook import load_rulebook, rulebook_yaml

    try:
        text = rulebook_yaml(load_rulebook(rules, allow_imports) if rules is not None else None)
    except MonitorError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    if output is None:
        typer.echo(text, nl=False)
    else:
        output.write_text(text, encoding="utf-8")
