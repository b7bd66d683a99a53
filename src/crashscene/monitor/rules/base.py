"""The rule interface and the registry of rules by code.

A rule is a small class, the one declaration of everything about its code:
its CVC code and violation token, its unit, its place in the rulebook
(`rank`, the rules.md row), the trace columns it reads (`columns`), the
guidance the extraction prompt shows (`guide`), the driver traits that inject
it in reproduce mode (`disposition`, a set of `Disposition`), a pydantic
`Params` model holding its thresholds (defaults from rules.md), and an
`evaluate(ctx)` returning one `RuleOutcome` of (variation, actor) arrays.
Registering a class by its code is all it takes to add a rule: the rulebook
(YAML overrides, `crashscene rules`), the monitor, the reports, the DSL's
monitored codes, the extraction prompt and the reproduce-mode drivers all
derive their lists from this registry. For example, CVC 22108 (signal for
100 ft before turning), assuming a backend that records a `turn_signal` flag::

    from pydantic import Field
    from crashscene.monitor import Rule, RuleOutcome, RuleParams, register_rule

    class SignalParams(RuleParams):
        min_distance: float = Field(default=30.5, gt=0, description="[m] signal this far before the turn")

    @register_rule
    class TurnSignal(Rule):
        code, violation, unit = "CVC_22108", "no_turn_signal", "m"
        summary = "turn signal on for the last 100 ft before a turn"
        columns = ("t", "maneuver", "stop_line_dist", "turn_signal")
        Params = SignalParams

        def evaluate(self, ctx):
            out = RuleOutcome.empty(ctx.shape, self.params.min_distance)
            ...  # fill out.applicable, violated, first_t, measured, robustness from ctx.arrays
            return out.finalize()

Put it in an importable module and name that module under `imports:` in a
rulebook file (`crashscene monitor RUN --rules rules.yaml`).
"""
from __future__ import annotations

import math
import re
from abc import ABC, abstractmethod
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from crashscene.monitor.errors import RegistryError
from crashscene.traces import TRACE_SCHEMA

if TYPE_CHECKING:
    from crashscene.monitor.arrays import TraceArrays
    from crashscene.monitor.context import EvalContext

CODE_RE = re.compile(r"^CVC_[0-9]+[A-Za-z]?$")
TOKEN_RE = re.compile(r"^[a-z][a-z0-9_]*$")


class Disposition(StrEnum):
    """What a reproduce-mode driver charged with a rule's code does (the traits a rule injects)."""

    NO_YIELD = "no_yield"            # takes the right of way: enters junctions without yielding
    RUNS_RED = "runs_red"            # does not stop for a red signal
    RUNS_STOP = "runs_stop"          # does not stop at a stop sign
    SPEEDING = "speeding"            # cruises above the (condition-adjusted) limit
    CARELESS = "careless"            # too fast for the conditions: ignores curve speed and weather
    INATTENTIVE = "inattentive"      # reacts late to the vehicle ahead
    TAILGATES = "tailgates"          # keeps a short headway and closes in on the vehicle ahead
    NO_GAP_CHECK = "no_gap_check"    # changes lanes without checking the gap in the target lane


class RuleParams(BaseModel):
    """Thresholds of one rule; subclasses add fields with units in their descriptions."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    enabled: bool = Field(default=True, description="evaluate this rule")


@dataclass
class RuleOutcome:
    """One rule's result for every (variation, actor); all arrays (V, A)."""

    applicable: np.ndarray     # bool
    violated: np.ndarray       # bool (only where applicable)
    first_t: np.ndarray        # [s] time of the first violation, NaN otherwise
    measured: np.ndarray       # the measured value, in the rule's unit
    threshold: np.ndarray      # the threshold it is compared with, in the rule's unit
    robustness: np.ndarray     # signed margin in the rule's unit, negative when violated
    note: np.ndarray | None = None  # object array of str/None: advisories, exemptions used

    @classmethod
    def empty(cls, shape: tuple[int, int], threshold: float = np.nan) -> RuleOutcome:
        return cls(applicable=np.zeros(shape, dtype=bool), violated=np.zeros(shape, dtype=bool),
                   first_t=np.full(shape, np.nan), measured=np.full(shape, np.nan),
                   threshold=np.full(shape, float(threshold)), robustness=np.full(shape, np.inf),
                   note=np.full(shape, None, dtype=object))

    def finalize(self) -> RuleOutcome:
        """Make the arrays consistent: no violation where not applicable, robustness sign matches."""
        self.violated &= self.applicable
        self.first_t = np.where(self.violated, self.first_t, np.nan)
        self.robustness = np.where(self.applicable, self.robustness, np.nan)
        self.robustness = np.where(self.violated, np.minimum(self.robustness, -0.0), self.robustness)
        self.robustness = np.where(self.applicable & ~self.violated & (self.robustness <= 0), 0.0, self.robustness)
        self.measured = np.where(self.applicable, self.measured, np.nan)
        if self.note is None:
            self.note = np.full(self.applicable.shape, None, dtype=object)
        return self


class Rule(ABC):
    """One monitored traffic rule."""

    code: ClassVar[str]
    violation: ClassVar[str]
    unit: ClassVar[str]
    summary: ClassVar[str] = ""
    rank: ClassVar[float] = math.inf  # place in the rulebook (rules.md row); user rules follow in registration order
    columns: ClassVar[tuple[str, ...]] = ()  # trace columns (traces.TRACE_SCHEMA) evaluate reads
    guide: ClassVar[str] = ""  # when the code applies, in the words of the extraction prompt ("" = not prompted)
    disposition: ClassVar[frozenset[Disposition]] = frozenset()  # traits injected in reproduce mode
    Params: ClassVar[type[RuleParams]] = RuleParams

    def __init__(self, params: RuleParams | None = None):
        self.params = params if params is not None else self.Params()

    @abstractmethod
    def evaluate(self, ctx: EvalContext) -> RuleOutcome:
        """Evaluate every actor of every variation of the batch in `ctx`."""

    def past_judging(self, arrays: TraceArrays, upset: np.ndarray, grace: int) -> np.ndarray | None:
        """(V,) the variations whose whole traces this rule reads, past the end of each actor's judging (an
        upsetting contact at step `upset` (V, A), -1 none, plus `grace` steps: `crashscene.monitor.judging`);
        the monitor keeps a copy of them in `ctx.whole`. None (the default): the judged traces are enough."""
        return None


_REGISTRY: dict[str, type[Rule]] = {}


def register_rule(cls: type[Rule] | None = None, *, replace: bool = False):
    """Class decorator registering a rule by its `code` (use `replace=True` to override a built-in)."""

    def wrap(rule_cls: type[Rule]) -> type[Rule]:
        code = getattr(rule_cls, "code", None)
        if not isinstance(code, str) or not CODE_RE.match(code):
            raise RegistryError(f"{rule_cls.__qualname__}: code {code!r} is not of the form CVC_<digits>")
        token = getattr(rule_cls, "violation", None)
        if not isinstance(token, str) or not TOKEN_RE.match(token):
            raise RegistryError(f"{rule_cls.__qualname__}: violation token {token!r} is not snake_case")
        if not isinstance(getattr(rule_cls, "unit", None), str):
            raise RegistryError(f"{rule_cls.__qualname__}: missing `unit` (e.g. 's', 'm/s', 'm')")
        if not (isinstance(rule_cls.Params, type) and issubclass(rule_cls.Params, RuleParams)):
            raise RegistryError(f"{rule_cls.__qualname__}: Params must subclass RuleParams")
        columns = rule_cls.columns
        if not isinstance(columns, tuple) or not all(isinstance(c, str) and TOKEN_RE.match(c) for c in columns):
            raise RegistryError(f"{rule_cls.__qualname__}: columns must be a tuple of trace column names "
                                f"(e.g. {', '.join(TRACE_SCHEMA.names[3:6])}), got {columns!r}")
        bad = [d for d in rule_cls.disposition if not isinstance(d, Disposition)]
        if bad:
            raise RegistryError(f"{rule_cls.__qualname__}: disposition {bad} is not a set of Disposition "
                                f"({', '.join(d.value for d in Disposition)})")
        existing = _REGISTRY.get(code)
        if existing is not None and existing is not rule_cls and not replace:
            same = existing.__module__ == rule_cls.__module__ and existing.__qualname__ == rule_cls.__qualname__
            if not same:
                raise RegistryError(f"{code} is already registered by {existing.__module__}.{existing.__qualname__}; "
                                    f"pass replace=True to override it")
        _REGISTRY[code] = rule_cls
        return rule_cls

    return wrap(cls) if cls is not None else wrap


def unregister_rule(code: str) -> None:
    """Remove a rule from the registry (tests, plugins that withdraw a rule)."""
    _REGISTRY.pop(code, None)


def registered_rules() -> dict[str, type[Rule]]:
    """Code -> rule class, built-ins first in rulebook order (`rank`), then user rules in registration order."""
    return dict(sorted(_REGISTRY.items(), key=lambda item: item[1].rank))


def monitored_codes() -> dict[str, str]:
    """Code -> violation token of every registered rule, in rulebook order."""
    return {code: cls.violation for code, cls in registered_rules().items()}


def dispositions_of(codes) -> frozenset[Disposition]:
    """The driver traits injected by these oracle codes (codes of no registered rule inject none)."""
    out: set[Disposition] = set()
    for code in codes:
        cls = _REGISTRY.get(code)
        if cls is not None:
            out |= cls.disposition
    return frozenset(out)


def codes_with(trait: Disposition) -> frozenset[str]:
    """Codes whose rule injects `trait`."""
    return frozenset(code for code, cls in _REGISTRY.items() if trait in cls.disposition)


def rule_class(code: str) -> type[Rule]:
    try:
        return _REGISTRY[code]
    except KeyError:
        raise RegistryError(f"unknown rule {code!r}; registered: {', '.join(_REGISTRY)}") from None
