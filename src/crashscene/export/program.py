"""What a rendered Scenic program samples: its parameter ranges and blueprint pools, read from the program text.

The export declares exactly what Scenic draws, so it reads the program `render`
wrote (one source of truth) rather than re-deriving the ranges: every
`param NAME = VerifaiRange(low, high)` (uniform [low, high]) or `param NAME = number`
(a constant), and every `_bp_ROLE = Uniform('bp1', 'bp2', ...)` (a uniform choice of
vehicle model).
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

from crashscene.export.errors import ExportError

_PARAM = re.compile(r"^param (?P<name>[A-Za-z][A-Za-z0-9_]*) = (?P<value>[^#\n]+?)\s*(#.*)?$", re.M)
_RANGE = re.compile(r"^VerifaiRange\((?P<low>[-+0-9.eE]+), (?P<high>[-+0-9.eE]+)\)$")
_POOL = re.compile(r"^_bp_(?P<role>[A-Za-z0-9_]+) = Uniform\(\*(?P<pool>\[.*\])\)$", re.M)


@dataclass(frozen=True)
class SampledParameter:
    """A numeric program parameter: uniform on [low, high]; low == high is a constant."""

    name: str
    low: float
    high: float
    unit: str  # from the program's comment, e.g. "m/s"

    @property
    def sampled(self) -> bool:
        return self.high > self.low


@dataclass(frozen=True)
class ProgramSampling:
    parameters: list[SampledParameter]
    blueprint_pools: dict[str, list[str]]  # role -> models drawn uniformly


def read_program(path: Path) -> ProgramSampling:
    """Parameters (upper-case-suffixed actor parameters) and blueprint pools of a rendered program."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ExportError(f"{path}: cannot read the rendered program: {exc}") from exc
    params = []
    for match in _PARAM.finditer(text):
        name, value = match["name"], match["value"].strip()
        if not re.search(r"_[A-Z][A-Z_]*$", name) or name.startswith("cs_"):
            continue  # scene settings (map, weather, cs_*) are not actor parameters
        unit = (match.group(3) or "").lstrip("# ").split(" ")[0].strip("[]")
        rng = _RANGE.match(value)
        try:
            low, high = (float(rng["low"]), float(rng["high"])) if rng else (float(value), float(value))
        except ValueError:
            raise ExportError(f"{path}: parameter {name} = {value!r} is neither a number nor VerifaiRange(low, high); "
                              "re-render the scenario with this crashscene version") from None
        params.append(SampledParameter(name, low, high, unit))
    pools = {}
    for match in _POOL.finditer(text):
        pool = ast.literal_eval(match["pool"])
        if not pool or not all(isinstance(p, str) for p in pool):
            raise ExportError(f"{path}: blueprint pool of {match['role']} is not a list of model names: {pool!r}")
        pools[match["role"]] = list(pool)
    if not params:
        raise ExportError(f"{path}: no sampled parameters found; not a program written by `crashscene render`")
    return ProgramSampling(params, pools)
