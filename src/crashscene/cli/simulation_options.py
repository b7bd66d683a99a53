"""Typed CLI options shared by `simulate`, `run` and `campaign` (one spelling, one help text each)."""
from __future__ import annotations

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

