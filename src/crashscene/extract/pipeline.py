"""The extraction pipeline: one case or a batch, with the `rules`, `openai` or `local` backend.

For one case: read the report, read the sketch facts (offline OCR), then
either run the deterministic rules, or ask the model (prompt -> structured
reply -> re-ask until valid -> field-by-field review -> one revision) and
record tokens, cost and seconds. `extract_batch` writes `DIR/<case>.yaml` for
every case that succeeds and `DIR/summary.json` for all of them, going on with
the other cases after a failure.

Backend choice with `auto`: a `model_path` means `local`; an `OPENAI_API_KEY`
or a `base_url` means `openai`; otherwise `rules`, which needs nothing.
"""
from __future__ import annotations

import json
import os
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from crashscene.dsl import DslError, Scenario, dump_file, validate
from crashscene.extract.errors import ExtractError
from crashscene.extract.openai_backend import DEFAULT_MODEL, DEFAULT_TIMEOUT, ChatBackend, RetryPolicy, Usage

BackendName = Literal["auto", "rules", "openai", "local"]
BACKENDS = ("auto", "rules", "openai", "local")
SUMMARY_FILE = "summary.json"


class ExtractOptions(BaseModel):
    """How to extract: backend and its settings."""

    model_config = ConfigDict(frozen=True)

    backend: BackendName = "auto"
    model: str = DEFAULT_MODEL
    base_url: str | None = None
    model_path: Path | None = None
    timeout: float = Field(default=DEFAULT_TIMEOUT, gt=0, description="[s] per request")
    max_reasks: int | None = Field(default=None, ge=0, le=5,
                                   description="re-asks after an invalid reply; None: 2 openai, 1 local")
    retry: RetryPolicy = Field(default_factory=RetryPolicy, description="timeouts, 429 and 5xx")
    revise: bool = True
    exemplars: int | None = Field(default=None, ge=0, le=4, description="few-shot pairs; None: 3 openai, 1 local")
    use_sketch: bool = True
    send_image: bool = True  # False for text-only endpoints: the sketch then reaches the model as its facts only

    def resolved_backend(self) -> str:
        if self.backend != "auto":
            return self.backend
        if self.model_path is not None:
            return "local"
        if os.environ.get("OPENAI_API_KEY") or self.base_url:
            return "openai"
        return "rules"


class Tokens(BaseModel):
    prompt: int = 0
    cached: int = 0  # of prompt, from the endpoint's prompt cache
    completion: int = 0
    total: int = 0
    requests: int = 0


class ExtractionResult(BaseModel):
    """The outcome of one case: the scenario (None on failure) and what it cost."""

    case_id: str
    source: str
    status: Literal["ok", "error"] = "ok"
    backend: str
    model: str | None = None
    scenario: Scenario | None = None
    tokens: Tokens = Field(default_factory=Tokens)
    cost_usd: float | None = None
    seconds: float = 0.0  # [s] wall time for the case
    warnings: list[str] = Field(default_factory=list)
    error: str | None = None
    output: str | None = None  # the YAML file written, in a batch

    def summary_row(self) -> dict[str, Any]:
        return self.model_dump(mode="json", exclude={"scenario"})


def extract_case(path: Path | str, backend: BackendName = "auto", model: str = DEFAULT_MODEL,
                 base_url: str | None = None, model_path: Path | str | None = None, *,
                 options: ExtractOptions | None = None, chat: ChatBackend | None = None) -> ExtractionResult:
    """Extract one case folder or narrative file; raises `ExtractError` when the case cannot be extracted.

    `chat` reuses an already configured backend (a batch, a started local server).
    """
    options = options or ExtractOptions(backend=backend, model=model, base_url=base_url,
                                        model_path=Path(model_path) if model_path else None)
    name = options.resolved_backend() if chat is None else chat.name
    if chat is None and name in ("openai", "local"):
        with open_chat(options) as opened:
            return extract_case(path, options=options, chat=opened)
    from crashscene.extract.case_input import load_report

    started = time.perf_counter()
    report = load_report(path)
    warnings: list[str] = []
    facts = _facts(report, warnings) if options.use_sketch else []
    usage = Usage()
    scenario_id = f"CIREN-{report.case_id}"
    if chat is None:
        from crashscene.extract.rules import extract_rules

        scenario = extract_rules(report, facts)
        model_name = None
    else:
        try:
            scenario = _extract_llm(report, facts, chat, options, usage, warnings, scenario_id)
        except ExtractError as exc:
            exc.usage, exc.cost = usage, chat.cost(usage)  # a failed case still spent tokens: report them
            raise
        model_name = chat.model
    warnings += [str(d) for d in _validated(scenario, report.source)]
    return ExtractionResult(case_id=report.case_id, source=str(report.source), backend=name, model=model_name,
                            scenario=scenario, tokens=_tokens(usage),
                            cost_usd=chat.cost(usage) if chat is not None else 0.0,
                            seconds=round(time.perf_counter() - started, 3), warnings=warnings)


def extract_batch(paths: Sequence[Path | str], out_dir: Path | str, backend: BackendName = "auto",
                  model: str = DEFAULT_MODEL, base_url: str | None = None, model_path: Path | str | None = None, *,
                  options: ExtractOptions | None = None, progress: Any = None) -> list[ExtractionResult]:
    """Extract every case into `out_dir/<case>.yaml` and write `out_dir/summary.json`; failures do not stop it.

    `progress(result)` is called after each case (the CLI prints a line).
    """
    options = options or ExtractOptions(backend=backend, model=model, base_url=base_url,
                                        model_path=Path(model_path) if model_path else None)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results: list[ExtractionResult] = []
    started = time.perf_counter()
    name = options.resolved_backend()
    with (open_chat(options) if name in ("openai", "local") else _nothing()) as chat:
        for path in paths:
            result = _guarded(Path(path), options, chat, name)
            if result.scenario is not None:
                target = out / f"{result.case_id}.yaml"
                dump_file(result.scenario, target)
                result.output = str(target)
            results.append(result)
            if progress is not None:
                progress(result)
    write_summary(results, out / SUMMARY_FILE, seconds=time.perf_counter() - started)
    return results


def write_summary(results: list[ExtractionResult], path: Path, seconds: float | None = None) -> dict[str, Any]:
    """`summary.json`: per-case status, tokens, cost, seconds, and the totals."""
    costs = [r.cost_usd for r in results if r.cost_usd is not None]
    summary = {
        "cases": len(results),
        "ok": sum(r.status == "ok" for r in results),
        "failed": sum(r.status == "error" for r in results),
        "tokens": sum(r.tokens.total for r in results),
        "cost_usd": round(sum(costs), 6) if costs else None,
        "seconds": round(seconds if seconds is not None else sum(r.seconds for r in results), 3),
        "results": [r.summary_row() for r in results],
    }
    path.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary


@contextmanager
def open_chat(options: ExtractOptions) -> Iterator[ChatBackend]:
    """The configured LLM backend; for `local`, the embedded server runs for the duration."""
    name = options.resolved_backend()
    if name == "openai":
        chat = ChatBackend(model=options.model, base_url=options.base_url, timeout=options.timeout,
                           retry=options.retry, send_image=options.send_image)
        chat.client  # a missing key fails here, once, rather than once per case
        yield chat
        return
    if name != "local":
        raise ExtractError(f"backend {name!r} has no chat model; allowed: openai, local")
    from crashscene.extract.local_backend import LocalServer, default_model_path, local_chat_backend

    model_path = options.model_path or default_model_path()
    with LocalServer(Path(model_path)) as server:
        yield local_chat_backend(server)


def _extract_llm(report: Any, facts: list[Any], chat: ChatBackend, options: ExtractOptions, usage: Usage,
                 warnings: list[str], scenario_id: str) -> Scenario:
    from crashscene.extract.openai_backend import image_part
    from crashscene.extract.prompt import DEFAULT_EXEMPLARS, build_messages, fact_lines as prompt_fact_lines
    from crashscene.extract.revise import ask_until_valid, prune_oracle, review, revise

    fact_lines = prompt_fact_lines(facts)
    image = image_part(report.sketch) if chat.send_image and report.sketch is not None and options.use_sketch \
        else None
    exemplars = options.exemplars if options.exemplars is not None else (DEFAULT_EXEMPLARS if chat.send_image else 1)
    messages = build_messages(report.narrative, fact_lines, report.case_id, image, exemplars)
    source = str(report.source)
    reasks = options.max_reasks if options.max_reasks is not None else (1 if chat.name == "local" else 2)
    draft = ask_until_valid(chat, messages, usage, scenario_id, reasks, source)
    findings = review(draft, report.narrative, fact_lines)
    if options.revise:
        scenario, findings = revise(chat, messages, draft, findings, report.narrative, fact_lines, usage,
                                    reasks, source)
    else:
        scenario = draft
    scenario, dropped = prune_oracle(scenario)
    warnings += [f"review: {finding}" for finding in findings] + dropped
    return scenario


def _guarded(path: Path, options: ExtractOptions, chat: ChatBackend | None, name: str) -> ExtractionResult:
    started = time.perf_counter()
    try:
        return extract_case(path, options=options, chat=chat)
    except (ExtractError, DslError) as exc:
        usage = getattr(exc, "usage", None) or Usage()
        return ExtractionResult(case_id=_case_name(path), source=str(path), status="error", backend=name,
                                model=chat.model if chat else None, error=str(exc), tokens=_tokens(usage),
                                cost_usd=getattr(exc, "cost", None) if chat else 0.0,
                                seconds=round(time.perf_counter() - started, 3))


def _facts(report: Any, warnings: list[str]) -> list[Any]:
    if report.sketch is None:
        return []
    from crashscene.extract.errors import SketchError
    from crashscene.extract.sketch import sketch_facts

    try:
        return sketch_facts(report.sketch)
    except SketchError as exc:
        warnings.append(f"sketch not read, extracting from the narrative alone: {exc}")
        return []


def _validated(scenario: Scenario, source: Path) -> list[Any]:
    try:
        return validate(scenario)
    except DslError as exc:
        raise ExtractError(f"extracted scenario is invalid: {exc}", source) from None


def _tokens(usage: Usage) -> Tokens:
    return Tokens(prompt=usage.prompt_tokens, cached=usage.cached_tokens, completion=usage.completion_tokens,
                  total=usage.total_tokens,
                  requests=usage.requests)


def _case_name(path: Path) -> str:
    if path.is_dir() or path.name.lower().startswith("narrative."):
        return (path if path.is_dir() else path.parent).resolve().name
    return path.stem


@contextmanager
def _nothing() -> Iterator[None]:
    yield None
