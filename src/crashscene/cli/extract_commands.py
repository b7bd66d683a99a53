"""`crashscene extract`: crash reports (case folders or narrative files) to DSL scenario files."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from crashscene.cli import app


@app.command()
def extract(
    paths: Annotated[list[Path], typer.Argument(help="Case folders (narrative.txt, optional sketch.jpg|png) or "
                                                     "narrative text files.")],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="One case: a .yaml file (else a folder). "
                                                "Several cases: a folder for <case>.yaml and summary.json.")] = None,
    backend: Annotated[str, typer.Option("--backend", help="rules | openai | local | auto (auto: local with "
                                         "--model-path, openai with OPENAI_API_KEY or --base-url, else rules).")
                       ] = "auto",
    model: Annotated[str, typer.Option("--model", help="Model name for the openai backend.")] = "gpt-4o-mini",
    base_url: Annotated[str | None, typer.Option("--base-url", help="Any OpenAI-compatible endpoint (Ollama, "
                                                 "vLLM, llama.cpp server).")] = None,
    model_path: Annotated[Path | None, typer.Option("--model-path", help="GGUF file for the local backend "
                                                    "(default: the crashscene\\[local-model] extra).")] = None,
    no_revise: Annotated[bool, typer.Option("--no-revise", help="Skip the LLM review-and-revise pass.")] = False,
    no_image: Annotated[bool, typer.Option("--no-image", help="Do not send the sketch image (text-only models); "
                                           "its OCR facts are still sent.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable results on stdout.")] = False,
) -> None:
    """Extract Extended Scenic DSL scenarios from crash reports; exit 1 if any case failed."""
    from pydantic import ValidationError

    from crashscene.dsl import DslError, dumps
    from crashscene.extract.errors import ExtractError
    from crashscene.extract.pipeline import BACKENDS, ExtractOptions, extract_batch, extract_case

    if backend not in BACKENDS:
        _fail(f"--backend {backend!r} is not a backend; allowed: {', '.join(BACKENDS)}")
    try:
        options = ExtractOptions(backend=backend, model=model, base_url=base_url, model_path=model_path,
                                 revise=not no_revise, send_image=not no_image)
    except ValidationError as exc:
        _fail(f"bad option: {exc.errors()[0]['msg']}")
    several = len(paths) > 1
    if several and output is None:
        _fail("several cases need -o DIR (a folder for <case>.yaml files and summary.json)")
    if several and output is not None and output.exists() and not output.is_dir():
        _fail(f"{output}: exists and is not a folder; several cases need -o DIR")
    try:
        if several or (output is not None and (output.is_dir() or output.suffix.lower() not in (".yaml", ".yml"))):
            results = extract_batch(paths, output, options=options,
                                    progress=None if as_json else _progress)
            summary_path = Path(output) / "summary.json"
            summary = json.loads(summary_path.read_text(encoding="utf-8"))
            if as_json:
                typer.echo(json.dumps(summary, indent=2))
            else:
                typer.echo(f"{summary['ok']}/{summary['cases']} cases extracted into {output} "
                           f"({summary['tokens']} tokens, cost {_money(summary['cost_usd'])}, "
                           f"{summary['seconds']:.1f} s); summary: {summary_path}")
            raise typer.Exit(1 if summary["failed"] else 0)
        result = extract_case(paths[0], options=options)
    except (ExtractError, DslError) as exc:
        _fail(str(exc), code=1)
    assert result.scenario is not None
    text = dumps(result.scenario)
    if output is not None:
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(text, encoding="utf-8")
        result.output = str(output)
    if as_json:
        row = result.summary_row()
        row["scenario"] = result.scenario.model_dump(mode="json", exclude_none=True)
        typer.echo(json.dumps(row, indent=2))
        return
    for warning in result.warnings:
        typer.echo(f"warning: {warning}", err=True)
    if output is None:
        typer.echo(text, nl=False)
    typer.echo(f"{result.case_id}: ok ({result.backend}{' ' + result.model if result.model else ''}, "
               f"{result.tokens.total} tokens, cost {_money(result.cost_usd)}, {result.seconds:.1f} s)"
               + (f" -> {output}" if output else ""), err=True)


def _progress(result) -> None:  # noqa: ANN001  (ExtractionResult; imported lazily)
    if result.status == "ok":
        typer.echo(f"{result.case_id}: ok ({result.tokens.total} tokens, {result.seconds:.1f} s, "
                   f"{len(result.warnings)} warnings)", err=True)
    else:
        typer.echo(f"{result.case_id}: FAILED: {result.error}", err=True)


def _money(cost: float | None) -> str:
    return "unknown" if cost is None else f"${cost:.4f}"


def _fail(message: str, code: int = 2) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)
