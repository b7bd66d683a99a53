"""Held-out extraction accuracy: every bundled case scored only by rules written from other cases (issue 11).

`evaluate_held_out` extracts each case of a folder of case folders (report, sketch and `golden.yaml`) with
the rules backend twice: with every rule on (the bundled figure), and with every recorded rule whose
sources include the case switched off (`crashscene.extract.rule_sources`; with `folds`, every rule written
from any case of the case's fold, `crashscene.evaluation.folds.assign_folds`). The second pass is the held-out
figure, scored per field like `crashscene eval`. It also measures each recorded rule on its own (`RuleEffect`):
the fields it wins or loses on its source cases and on the others. A rule that wins only on its sources fits
them; one that wins elsewhere generalises to cases it was not written from.

What it proves, and what not: every rule of the extractor is recorded (`rule_sources`). The first round's
rules whose wording is the spec's (`CONVENTION_RULES`), the rules session 5's extended test admits
(`SPEC_QUOTED_CONVENTIONS`: dsl.md's and the rulebook's words) and the later rules written from synthetic narratives
stay on everywhere: they rest on no case. The first round's case-written rules are off for every case they fire on
(`measure_sources`), so for them the figure is a lower bound: a case is scored as if the rule had never been
written. New reports remain the only full measure.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

from pydantic import BaseModel

from crashscene.dsl import DslError, Scenario, dumps, load_file
from crashscene.evaluation.folds import assign_folds
from crashscene.evaluation.score import EvalError, EvalResult, _pct, evaluate, score_case
from crashscene.extract.case_input import Report, load_report
from crashscene.extract.errors import ExtractError
from crashscene.extract.rule_sources import RULE_SOURCES, rules_written_from
from crashscene.extract.rules import extract_rules
from crashscene.extract.sketch import SketchFact


class RuleEffect(BaseModel):
    """What one recorded rule changes: scored fields won (+) or lost (-) per case, on its sources and elsewhere."""

    rule: str
    sources: list[str]
    on_sources: dict[str, int]  # case -> fields won by the rule (negative: lost); only cases it changes
    elsewhere: dict[str, int]

    @property
    def verdict(self) -> str:
        won_elsewhere = sum(v for v in self.elsewhere.values() if v > 0)
        if any(v < 0 for v in self.elsewhere.values()):
            return f"loses {-sum(v for v in self.elsewhere.values() if v < 0)} elsewhere, wins {won_elsewhere}"
        if won_elsewhere:
            return "generalises"
        if any(v > 0 for v in self.on_sources.values()):
            return "fits its sources only"
        return "no scored effect"


class HeldOutResult(BaseModel):
    """The bundled figure, the held-out figure, the rules each case was extracted without, each rule's effect."""

    folds: int | None
    bundled: EvalResult
    held_out: EvalResult
    off: dict[str, list[str]]
    effects: list[RuleEffect]

    def to_json(self) -> dict:
        def headline(result: EvalResult) -> dict:
            full = result.to_json()
            return {key: full[key] for key in ("overall", "components", "oracle_precision", "extensions", "fields")}

        return {"folds": self.folds, "bundled": headline(self.bundled), "held_out": headline(self.held_out),
                "off": self.off,
                "rules": [{**e.model_dump(), "verdict": e.verdict} for e in self.effects],
                "held_out_cases": [{"case": c.case, **c.score.to_json(),
                                    "diffs": [{"field": d.field, "gold": d.gold, "pred": d.pred} for d in c.diffs]}
                                   for c in self.held_out.cases]}


def _inputs(cases_dir: Path) -> dict[str, tuple[Scenario, Report, list[SketchFact]]]:
    """Case id -> (golden, report, sketch facts) for every case folder holding a golden.yaml."""
    from crashscene.extract.pipeline import _facts

    cases_dir = Path(cases_dir)
    if not cases_dir.is_dir():
        raise EvalError(f"--gold {cases_dir}: not a folder of case folders (<case>/golden.yaml and its report)")
    out = {}
    for folder in sorted(p for p in cases_dir.iterdir() if (p / "golden.yaml").is_file()):
        try:
            golden = load_file(folder / "golden.yaml")
            report = load_report(folder)
        except (DslError, ExtractError) as exc:
            raise EvalError(f"{folder}: cannot be held out: {exc}") from None
        out[folder.name] = (golden, report, _facts(report, []))
    if not out:
        raise EvalError(f"--gold {cases_dir}: no <case>/golden.yaml folders; --held-out extracts each case's report "
                        "and needs it beside its golden file")
    return out


def _extract(report: Report, facts: list[SketchFact], off: frozenset[str]) -> tuple[Scenario | None, str | None]:
    try:
        return extract_rules(report, facts, off=off), None
    except ExtractError as exc:
        return None, str(exc)


def _correct(case: str, gold: Scenario, pred: Scenario | None) -> int:
    """Scored fields right, extensions (the crash sequence) included."""
    checks, _ = score_case(case, gold, pred)
    return sum(item.correct for item in checks)


def evaluate_held_out(cases_dir: Path, folds: int | None = None,
                      sources: Mapping[str, tuple[str, ...]] = RULE_SOURCES) -> HeldOutResult:
    """Extract and score every case with all rules on, then with the rules written from it (or its fold) off."""
    inputs = _inputs(cases_dir)
    fold_of = assign_folds(inputs, folds) if folds else None
    bundled, held, off_by_case = {}, {}, {}
    bundled_errors, held_errors = {}, {}
    for case, (golden, report, facts) in inputs.items():
        pred, error = _extract(report, facts, frozenset())
        bundled[case] = (golden, pred)
        if error:
            bundled_errors[case] = error
        peers = [c for c in inputs if fold_of[c] == fold_of[case]] if fold_of else [case]
        off = rules_written_from(peers, sources)
        off_by_case[case] = sorted(off)
        pred_off, error = _extract(report, facts, off) if off else (pred, error)
        held[case] = (golden, pred_off)
        if error:
            held_errors[case] = error
    effects = []
    for rule, written_from in sources.items():
        on_sources, elsewhere = {}, {}
        for case, (golden, report, facts) in inputs.items():
            pred = bundled[case][1]
            without, _ = _extract(report, facts, frozenset({rule}))
            if pred is not None and without is not None and dumps(pred) == dumps(without):
                continue
            delta = _correct(case, golden, pred) - _correct(case, golden, without)
            (on_sources if case in written_from else elsewhere)[case] = delta
        effects.append(RuleEffect(rule=rule, sources=sorted(written_from), on_sources=on_sources, elsewhere=elsewhere))
    return HeldOutResult(folds=folds, bundled=evaluate(bundled, bundled_errors), held_out=evaluate(held, held_errors),
                         off=off_by_case, effects=effects)


def _dump(report: Report, facts: list[SketchFact], off: frozenset[str]) -> str:
    pred, error = _extract(report, facts, off)
    return dumps(pred) if pred is not None else f"error: {error}"


def measure_sources(cases_dir: Path, rules: Iterable[str]) -> dict[str, tuple[str, ...]]:
    """The bundled cases each of `rules` fires on: those whose extraction (evidence included) changes when the rule
    alone is switched off from the full extractor, or when it alone is switched on with all of `rules` off (so two
    rules that each cover the other's cases both count them). The record of the first round's case-written rules
    (`rule_sources.ROUND_ONE_SOURCES`) is this measurement."""
    inputs = _inputs(cases_dir)
    rules = sorted(rules)
    all_off = frozenset(rules)
    found: dict[str, list[str]] = {rule: [] for rule in rules}
    for case, (_, report, facts) in inputs.items():
        on, off = _dump(report, facts, frozenset()), _dump(report, facts, all_off)
        for rule in rules:
            if _dump(report, facts, frozenset({rule})) != on or _dump(report, facts, all_off - {rule}) != off:
                found[rule].append(case)
    return {rule: tuple(cases) for rule, cases in found.items()}


def format_held_out(result: HeldOutResult) -> str:
    """Bundled and held-out figures side by side, per component and per field, then each rule's effect."""
    how = (f"each case extracted with every rule written from a case of its fold (--folds {result.folds}) off"
           if result.folds else "each case extracted with every rule written from it off")
    lines = [f"held out: {how}; rules written from dsl.md (conventions, synthetic narratives) stay on",
             f"{'':<34} {'bundled':>8} {'held out':>9}"]
    rows = [("overall", result.bundled.overall, result.held_out.overall),
            *((name, result.bundled.components[name], result.held_out.components[name])
              for name in result.bundled.components),
            *((name, score, result.held_out.fields[name]) for name, score in result.bundled.fields.items()
              if "." in name and not name.startswith(("collisions", "environment.road_surface",
                                                      "road_network.curve_direction"))),
            *((f"{name} (extension)", score, result.held_out.extensions[name])
              for name, score in result.bundled.extensions.items() if score.total)]
    for name, bundled, held in rows:
        lines.append(f"{name:<34} {_pct(bundled.accuracy):>8} {_pct(held.accuracy):>9}")
    lines.append(f"{'oracle precision':<34} {_pct(result.bundled.oracle_precision.precision):>8} "
                 f"{_pct(result.held_out.oracle_precision.precision):>9}")
    lines.append("")
    lines.append("recorded rules (fields won + / lost - when the rule is on, per case it changes):")
    for effect in result.effects:
        inside = ", ".join(f"{c} {d:+d}" for c, d in effect.on_sources.items()) or "-"
        outside = ", ".join(f"{c} {d:+d}" for c, d in effect.elsewhere.items()) or "-"
        lines.append(f"  {effect.rule} [{effect.verdict}]: on its {len(effect.sources)} sources: {inside}; "
                     f"elsewhere: {outside}")
    lost = [c for c in result.held_out.cases if c.diffs]
    if lost:
        lines.append("")
        lines.append("held-out diffs (scored fields):")
        for case in lost:
            wrong = [d for d in case.diffs if d.component != "extension"]
            if wrong:
                lines.append(f"  {case.case}: " + "; ".join(f"{d.field} {d.gold}->{d.pred}" for d in wrong))
    return "\n".join(lines)
