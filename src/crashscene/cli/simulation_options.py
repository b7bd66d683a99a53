"""Typed CLI options shared by `simulate`, `run` and `campaign` (one spelling, one help text each)."""
from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

# --simulator is the older spelling of --backend in `run` and `campaign`: kept as an alias (flags are contracts)
BackendOpt = Annotated[str, typer.Option("--backend", "--simulator", help="Simulation backend: embedded, newtonian, "
                                         "carla, an installed plugin's name, or 'package.module:Class'.")]
AdsOpt = Annotated[Optional[str], typer.Option("--ads", help="User ADS driver 'package.module:Class' "
                                               "(see crashscene.simulate.drivers.base).")]
AdsParamOpt = Annotated[list[str], typer.Option("--ads-param", help="ADS parameter KEY=VALUE (repeatable).")]
DtOpt = Annotated[float, typer.Option("--dt", help="Time step [s].")]
HorizonOpt = Annotated[float, typer.Option("--horizon", help="Simulated time per variation [s].")]
CarlaHostOpt = Annotated[str, typer.Option("--carla-host", help="CARLA server host.")]
CarlaPortOpt = Annotated[int, typer.Option("--carla-port", help="CARLA server port.")]
ModeOpt = Annotated[str, typer.Option("--mode", help="reproduce (re-enact the crash), test (ego = ADS under test), "
                                                     "or both.")]  # `run` and `campaign`
AllowImportsOpt = Annotated[bool, typer.Option("--allow-imports", help="Let the --rules file's `imports:` import "
                                               "Python modules (runs their code).")]
MapOpt = Annotated[str, typer.Option("--map", help="generated or carla.")]
# `run` and `campaign`
EgoOpt = Annotated[str, typer.Option("--ego", help="DSL role driven by the ADS under test.")]
RulesOpt = Annotated[Optional[Path], typer.Option("--rules", help="YAML rulebook overriding the monitor's thresholds.")]
SamplerOpt = Annotated[Optional[str], typer.Option("--sampler", help="Scene sampler: compiled (numpy) or scenic (the "
                                                   "reference) (default: compiled; scenic for newtonian and carla).")]
ExtractorOpt = Annotated[str, typer.Option("--extractor", help="Extraction backend: rules (offline), openai, local.")]
LlmModelOpt = Annotated[Optional[str], typer.Option("--model", help="LLM for --extractor openai (default gpt-4o-mini).")]
BaseUrlOpt = Annotated[Optional[str], typer.Option("--base-url", help="OpenAI-compatible endpoint for --extractor "
                                                   "openai.")]
ModelPathOpt = Annotated[Optional[Path], typer.Option("--model-path", help="GGUF file for --extractor local.")]


def parse_ads_params(values: list[str]) -> dict[str, float | int | str | bool]:
    """--ads-param KEY=VALUE items -> {key: value} (numbers and booleans typed)."""
    params: dict[str, float | int | str | bool] = {}
    for item in values:
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise typer.BadParameter(f"{item!r}: expected KEY=VALUE", param_hint="--ads-param")
        value: float | int | str | bool = raw
        if raw.lower() in ("true", "false"):
            value = raw.lower() == "true"
        else:
            for cast in (int, float):
                try:
                    value = cast(raw)
                    break
                except ValueError:
                    pass
        params[key] = value
    return params

