"""`crashscene campaign`: many cases x N variations, chunked, resumable, on a process pool or Ray."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from crashscene.cli import app
from crashscene.cli.simulation_options import (
    AdsOpt,
    AdsParamOpt,
    AllowImportsOpt,
    BackendOpt,
    BaseUrlOpt,
    CarlaHostOpt,
    CarlaPortOpt,
    DtOpt,
    EgoOpt,
    ExtractorOpt,
    HorizonOpt,
    LlmModelOpt,
    MapOpt,
    ModeOpt,
    ModelPathOpt,
    RulesOpt,
    SamplerOpt,
    parse_ads_params,
)

EXTRACTORS = ("rules", "openai", "local", "auto")


def build_config(n: int, seed: int, mode: str, engine: str, workers: int | None, address: str | None, resume: bool,
                 chunk_size: int, extractor: str, dsl: str | None, simulator: str, ego: str, map_mode: str,
                 carla_maps: Path | None, rules: Path | None = None, *, ads: str | None = None,
                 ads_params: dict | None = None, dt: float = 0.1, horizon: float = 20.0,
                 carla_host: str = "127.0.0.1", carla_port: int = 2000, allow_imports: bool = False,
                 sampler: str | None = None, search: list[str] | None = None, budget: int = 400,
                 objective: str = "robustness"):
    """Options -> CampaignConfig, with the CLI's spelling of each bad value in the error. The backend and the
    rulebook are checked here, once, before any case is extracted or rendered."""
    from crashscene.campaign import CampaignConfig, CampaignError, SimOptions
    from crashscene.campaign.search import SearchPlan, check_plan

    modes = {"both": ("reproduce", "test"), "reproduce": ("reproduce",), "test": ("test",)}
    if mode not in modes:
        raise CampaignError(f"--mode {mode!r}: allowed: {', '.join(modes)}")
    if map_mode not in ("generated", "carla"):
        raise CampaignError(f"--map {map_mode!r}: allowed: generated, carla")
    if n < 0 or (n == 0 and not search):
        raise CampaignError(f"-n {n}: the number of variations must be positive (0 only with --search)")
    if extractor not in EXTRACTORS:
        raise CampaignError(f"--extractor {extractor!r}: allowed: {', '.join(EXTRACTORS)}")
    from crashscene.simulate import SimulationError, backend_target, get_simulator_class

    try:
        target = backend_target(simulator)
        get_simulator_class(simulator)
    except SimulationError as exc:
        raise CampaignError(f"--backend/--simulator {simulator!r}: {exc}") from None
    digest = None
    if rules is not None:
        from crashscene.monitor import MonitorError
        from crashscene.monitor.rulebook import load_rulebook, rulebook_digest

        if not rules.is_file():
            raise CampaignError(f"--rules {rules}: no such rulebook file")
        try:
            load_rulebook(rules, allow_imports)
            digest = rulebook_digest(rules)
        except MonitorError as exc:
            raise CampaignError(f"--rules: {exc}") from None
    if chunk_size <= 0:
        raise CampaignError(f"--chunk-size {chunk_size}: must be positive")
    from crashscene.render.sample import SAMPLERS

    if sampler is not None and sampler not in SAMPLERS:
        raise CampaignError(f"--sampler {sampler!r}: allowed: {', '.join(SAMPLERS)}")
    try:
        sim = SimOptions(sampler=sampler, backend=simulator, backend_target=target, ego_role=ego, map_mode=map_mode,
                         carla_maps=str(carla_maps.resolve()) if carla_maps else None,
                         rules_file=str(rules.resolve()) if rules else None, rules_digest=digest,
                         allow_imports=allow_imports, ads=ads, ads_params=ads_params or {}, dt=dt, horizon=horizon,
                         carla_host=carla_host, carla_port=carla_port)
    except ValueError as exc:  # pydantic: --dt, --horizon, --carla-port out of range
        raise CampaignError(f"simulation options: {exc}") from None
    plan = SearchPlan(samplers=tuple(search), budget=budget, objective=objective) if search else None
    if plan is not None:
        check_plan(plan)
    return CampaignConfig(n=n, seed=seed, modes=modes[mode], engine=engine, workers=workers, address=address,
                          resume=resume, chunk_size=chunk_size, extract_backend=extractor, dsl_name=dsl, sim=sim,
                          search=plan)


def print_summary(summary, as_json: bool) -> None:
    """The end-of-campaign summary: a table on stdout (or JSON)."""
    from rich.console import Console
    from rich.table import Table

    from crashscene.campaign.runner import summary_json

    if as_json:
        typer.echo(summary_json(summary))
        return
    console = Console(width=None if Console().is_terminal else 120)
    table = Table(title=f"crashscene campaign: {summary.out_dir}")
    for col in ("case", "mode", "variations", "valid", "pass", "violation", "collision", "invalid", "reproduced",
                "first contact"):
        table.add_column(col, justify="left" if col in ("case", "mode") else "right")
    for run in summary.runs:
        rate = f"{run.reproduced} ({run.reproduction_rate:.0%})" if run.reproduction_rate is not None else "-"
        v = run.verdicts
        table.add_row(run.case_id, run.mode, str(run.variations), str(run.valid), str(v.get("pass", 0)),
                      str(v.get("violation", 0)), str(v.get("collision", 0)), str(v.get("invalid", 0)), rate,
                      f"{run.first_contact_rate:.0%}" if run.first_contact_rate is not None else "-")
    if summary.runs:
        console.print(table)
    for row in summary.searches:
        console.print(f"search {row['case_id']} [{row['sampler']}, {row['objective']}]: {row['failures']} failures "
                      f"in {row['evaluated']} variations, min objective {row['min_objective']}")
    for failure in summary.failures[:20]:
        console.print(f"[red]chunk {failure['chunk']} failed:[/red] {failure['error'].splitlines()[0]}", soft_wrap=True)
    if len(summary.failures) > 20:
        console.print(f"... and {len(summary.failures) - 20} more failed chunks (table chunk_errors)")
    for case in summary.cases:
        if case["status"] != "ok":
            console.print(f"[red]case {case['case_id']} failed:[/red] {case['error']}", soft_wrap=True)
    console.print(f"{summary.chunks_run} chunk(s) run, {summary.chunks_skipped} already done, "
                  f"{summary.chunks_failed} failed; {summary.variations_run} variations in {summary.seconds:.1f} s "
                  f"({summary.throughput:.1f} variations/s, engine {summary.engine} x{summary.workers}); "
                  f"database {summary.database}")
    if not summary.complete:
        console.print("[yellow]incomplete: fix the failures above and rerun with --resume[/yellow]")


@app.command()
def campaign(
    cases_dir: Annotated[Path, typer.Argument(help="Folder of case folders (narrative.txt, sketch) or scenario .yaml files.")],
    n: Annotated[Optional[int], typer.Option("-n", help="Variations per case and mode [default: 2000, or none "
                                                        "with --search].")] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (DuckDB, artefacts, report).")] = Path("out/campaign"),
    engine: Annotated[str, typer.Option("--engine", help="local (process pool) or ray.")] = "local",
    workers: Annotated[Optional[int], typer.Option("--workers", min=1, help="Worker processes / Ray CPUs [default: all cores].")] = None,
    resume: Annotated[bool, typer.Option("--resume", help="Continue the campaign in --out, skipping finished chunks.")] = False,
    address: Annotated[Optional[str], typer.Option("--address", help="Ray cluster to join (with --engine ray).")] = None,
    seed: Annotated[int, typer.Option("--seed", help="Campaign seed: variation i depends only on (scenario, seed, i).")] = 0,
    mode: ModeOpt = "both",
    chunk_size: Annotated[int, typer.Option("--chunk-size", help="Variations per chunk (the unit of resume).")] = 250,
    extractor: ExtractorOpt = "rules",
    model: LlmModelOpt = None,
    base_url: BaseUrlOpt = None,
    model_path: ModelPathOpt = None,
    dsl: Annotated[Optional[str], typer.Option("--dsl", help="Use CASE/<NAME> (e.g. golden.yaml) instead of extracting, when present.")] = None,
    simulator: BackendOpt = "embedded",
    ego: EgoOpt = "ego",
    ads: AdsOpt = None,
    ads_param: AdsParamOpt = [],  # noqa: B006
    dt: DtOpt = 0.1,
    horizon: HorizonOpt = 20.0,
    carla_host: CarlaHostOpt = "127.0.0.1",
    carla_port: CarlaPortOpt = 2000,
    map_mode: MapOpt = "generated",
    carla_maps: Annotated[Optional[Path], typer.Option("--carla-maps", help="Folder of CARLA .xodr towns (--map carla).")] = None,
    rules: RulesOpt = None,
    allow_imports: AllowImportsOpt = False,
    sampler: SamplerOpt = None,
    keep_traces: Annotated[bool, typer.Option("--keep-traces", help="Keep every chunk's traces under OUT/cases.")] = False,
    report: Annotated[bool, typer.Option("--report/--no-report", help="Write OUT/report.html at the end.")] = True,
    search: Annotated[Optional[list[str]], typer.Option("--search", help="Also search each case with this sampler "
                                                                       "(random, halton, ce, bo, cmaes; repeatable).")] = None,
    budget: Annotated[int, typer.Option("--budget", help="Variations per search (--search).")] = 400,
    objective: Annotated[str, typer.Option("--objective", help="Search objective: robustness or ttc.")] = "robustness",
    as_json: Annotated[bool, typer.Option("--json", help="Summary as JSON on stdout.")] = False,
) -> None:
    """Run N variations of every case, chunked into a resumable DuckDB campaign (and searches with --search)."""
    from crashscene.campaign import CampaignError, run_campaign

    try:
        n = n if n is not None else (0 if search else 2000)
        config = build_config(n, seed, mode, engine, workers, address, resume, chunk_size, extractor, dsl,
                              simulator, ego, map_mode, carla_maps, rules, ads=ads,
                              ads_params=parse_ads_params(ads_param), dt=dt, horizon=horizon, carla_host=carla_host,
                              carla_port=carla_port, allow_imports=allow_imports, sampler=sampler,
                              search=search, budget=budget, objective=objective)
        llm = {k: str(v) for k, v in (("model", model), ("base_url", base_url), ("model_path", model_path)) if v}
        config = config.model_copy(update={"llm": llm})
        config = config.model_copy(update={"keep_traces": keep_traces})
        summary = run_campaign(cases_dir, out, config, quiet=as_json)
    except CampaignError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    except KeyboardInterrupt:
        typer.echo(f"interrupted; finished chunks are stored in {out}; continue with --resume", err=True)
        raise typer.Exit(130) from None
    print_summary(summary, as_json)
    if report and (any(r.variations for r in summary.runs) or summary.searches):
        write_report_cli(out, quiet=as_json)
    raise typer.Exit(0 if summary.complete else 1)


def write_report_cli(out: Path, quiet: bool = False) -> None:
    from crashscene.report import ReportError, write_report

    try:
        written = write_report(out, progress=None if quiet else (lambda line: typer.echo(line, err=True)))
    except ReportError as exc:
        typer.echo(f"report: {exc}", err=True)
        raise typer.Exit(2) from None
    if not quiet:
        typer.echo(f"report: {written.html}")
