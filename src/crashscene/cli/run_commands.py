"""`crashscene run`: one case, the whole pipeline, one command."""
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


@app.command()
def run(
    case_dir: Annotated[Path, typer.Argument(help="A case folder (narrative.txt, optional sketch) or a scenario .yaml file.")],
    n: Annotated[int, typer.Option("-n", help="Variations per mode.")] = 2000,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder: every stage's artefact and the report.")] = Path("out/run"),
    seed: Annotated[int, typer.Option("--seed", help="Variation i depends only on (scenario, seed, i).")] = 0,
    mode: ModeOpt = "both",
    workers: Annotated[Optional[int], typer.Option("--workers", min=1, help="Worker processes [default: all cores].")] = None,
    chunk_size: Annotated[int, typer.Option("--chunk-size", help="Variations per chunk.")] = 250,
    resume: Annotated[bool, typer.Option("--resume", help="Continue an interrupted run in --out.")] = False,
    extractor: ExtractorOpt = "rules",
    model: LlmModelOpt = None,
    base_url: BaseUrlOpt = None,
    model_path: ModelPathOpt = None,
    dsl: Annotated[Optional[str], typer.Option("--dsl", help="Use CASE/<NAME> (e.g. golden.yaml) instead of extracting.")] = None,
    simulator: BackendOpt = "embedded",
    ego: EgoOpt = "ego",
    ads: AdsOpt = None,
    ads_param: AdsParamOpt = [],  # noqa: B006
    dt: DtOpt = 0.1,
    horizon: HorizonOpt = 20.0,
    carla_host: CarlaHostOpt = "127.0.0.1",
    carla_port: CarlaPortOpt = 2000,
    map_mode: MapOpt = "generated",
    carla_maps: Annotated[Optional[Path], typer.Option("--carla-maps", help="Folder of CARLA .xodr towns.")] = None,
    rules: RulesOpt = None,
    allow_imports: AllowImportsOpt = False,
    sampler: SamplerOpt = None,
    report: Annotated[bool, typer.Option("--report/--no-report", help="Write OUT/report.html.")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Summary as JSON on stdout.")] = False,
) -> None:
    """report -> extract -> validate -> render -> sample -> simulate -> monitor -> report, offline by default."""
    from crashscene.campaign import CampaignError
    from crashscene.cli.campaign_commands import build_config, print_summary
    from crashscene.pipeline.run import run_case
    from crashscene.report import ReportError

    try:
        config = build_config(n, seed, mode, "local", workers, None, resume, chunk_size, extractor, dsl,
                              simulator, ego, map_mode, carla_maps, rules, ads=ads,
                              ads_params=parse_ads_params(ads_param), dt=dt, horizon=horizon, carla_host=carla_host,
                              carla_port=carla_port, allow_imports=allow_imports, sampler=sampler)
        llm = {k: str(v) for k, v in (("model", model), ("base_url", base_url), ("model_path", model_path)) if v}
        config = config.model_copy(update={"llm": llm})
        result = run_case(case_dir, out, config, report=report, quiet=as_json)
    except (CampaignError, ReportError) as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    except KeyboardInterrupt:
        typer.echo(f"interrupted; continue with: crashscene run {case_dir} -n {n} --out {out} --resume", err=True)
        raise typer.Exit(130) from None
    print_summary(result.summary, as_json)
    if result.report and not as_json:
        typer.echo(f"report: {result.report}")
    raise typer.Exit(0 if result.summary.complete else 1)
