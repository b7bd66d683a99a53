"""Score extracted scenarios against golden files (dsl.md section 4).

Every scored field is one `FieldCheck` (case, component, field, gold, pred,
correct). From the checks come per-component and overall accuracy, the
extensions (road_surface, curve_direction, speed_mph, collisions and
collision_areas) reported apart, a
per-field confusion table (gold value -> predicted value -> count) and the
per-case diffs. Oracle precision counts predicted entries (code, actor) that
match no golden entry as errors.

Directory layout (`evaluate_dirs`): each directory holds `<case>.yaml` (or
`.yml`) files, or case folders `<case>/` holding `golden.yaml`, else
`scenario.yaml`, else exactly one `*.yaml`. The case id is the file stem or the
folder name. A prediction that does not load or validate scores 0 on every
field of its case and records the error. Cases present on one side only are
an error, unless `allow_missing` (missing predictions then score 0, extra
predictions are ignored and listed).
"""
from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field

from crashscene.dsl import DslError, Scenario, load_file

COMPONENTS = ("environment", "road_network", "actors", "oracle")
EXTENSIONS = ("road_surface", "curve_direction", "speed_mph", "collisions", "collision_areas")
ACTOR_FIELDS = ("type", "behavior", "position.reference", "position.relation", "position.heading")
CASE_FILE_NAMES = ("golden.yaml", "scenario.yaml")


class EvalError(Exception):
    """The evaluation inputs are unusable: missing directory, unmatched cases, unreadable golden file."""


class FieldCheck(BaseModel):
    """One scored field of one case."""

    case: str
    component: str  # environment | road_network | actors | oracle | extension
    field: str  # e.g. road_network.road_type, actors.npc1.behavior, oracle[CVC_21650@npc1]
    gold: Any = None
    pred: Any = None
    correct: bool


class Score(BaseModel):
    correct: int = 0
    total: int = 0

    @property
    def accuracy(self) -> float | None:
        return self.correct / self.total if self.total else None

    def add(self, ok: bool) -> None:
        self.correct += int(ok)
        self.total += 1

    def to_json(self) -> dict[str, Any]:
        return {"correct": self.correct, "total": self.total,
                "accuracy": round(self.accuracy, 4) if self.accuracy is not None else None}


class OraclePrecision(BaseModel):
    matched: int = 0  # predicted entries that match a golden entry (code and actor)
    predicted: int = 0

    @property
    def precision(self) -> float | None:
        return self.matched / self.predicted if self.predicted else None


class CaseResult(BaseModel):
    case: str
    score: Score = Field(default_factory=Score)
    error: str | None = None  # the prediction could not be loaded
    diffs: list[FieldCheck] = Field(default_factory=list)  # the wrong fields only


class EvalResult(BaseModel):
    """Everything `crashscene eval` reports."""

    components: dict[str, Score]
    overall: Score
    oracle_precision: OraclePrecision
    extensions: dict[str, Score]
    confusion: dict[str, dict[str, dict[str, int]]]  # field -> gold -> pred -> count
    fields: dict[str, Score] = Field(default_factory=dict)  # per field (actor fields pooled over roles)
    cases: list[CaseResult]
    ignored_predictions: list[str] = Field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        precision = self.oracle_precision.precision
        return {
            "overall": self.overall.to_json(),
            "components": {name: score.to_json() for name, score in self.components.items()},
            "oracle_precision": {"matched": self.oracle_precision.matched,
                                 "predicted": self.oracle_precision.predicted,
                                 "precision": round(precision, 4) if precision is not None else None},
            "extensions": {name: score.to_json() for name, score in self.extensions.items()},
            "fields": {name: score.to_json() for name, score in self.fields.items()},
            "confusion": self.confusion,
            "cases": [{"case": c.case, **c.score.to_json(), "error": c.error,
                       "diffs": [{"field": d.field, "gold": d.gold, "pred": d.pred} for d in c.diffs]}
                      for c in self.cases],
            "ignored_predictions": self.ignored_predictions,
        }


# ---------------------------------------------------------------- scoring one case


def score_case(case: str, gold: Scenario, pred: Scenario | None) -> tuple[list[FieldCheck], OraclePrecision]:
    """All field checks of one case (extensions included) and its oracle-precision counts."""
    checks: list[FieldCheck] = []

    def check(component: str, field: str, gold_value: Any, pred_value: Any) -> None:
        checks.append(FieldCheck(case=case, component=component, field=field, gold=gold_value, pred=pred_value,
                                 correct=pred is not None and gold_value == pred_value))

    env, road = gold.environment, gold.road_network
    p_env = pred.environment if pred else None
    p_road = pred.road_network if pred else None
    for name in ("weather", "time_of_day"):
        check("environment", f"environment.{name}", _token(getattr(env, name)),
              _token(getattr(p_env, name)) if p_env else None)
    for name in ("road_type", "number_of_ways", "number_of_lanes", "road_marker", "speed_limit_mph"):
        check("road_network", f"road_network.{name}", _token(getattr(road, name)),
              _token(getattr(p_road, name)) if p_road else None)
    check("road_network", "road_network.traffic_signs", _signs(road.traffic_signs),
          _signs(p_road.traffic_signs) if p_road else None)

    check("actors", "actors.count", len(gold.actors), len(pred.actors) if pred else None)
    for role, actor in gold.actors.items():
        other = pred.actors.get(role) if pred else None
        for name in ACTOR_FIELDS:
            check("actors", f"actors.{role}.{name}", _token(_attr(actor, name)),
                  _token(_attr(other, name)) if other else None)

    gold_entries = Counter((entry.code, entry.actor) for entry in gold.oracle)
    pred_entries = Counter((entry.code, entry.actor) for entry in pred.oracle) if pred else Counter()
    for (code, actor), count in sorted(gold_entries.items()):
        hits = min(count, pred_entries.get((code, actor), 0))
        for index in range(count):
            checks.append(FieldCheck(case=case, component="oracle", field=f"oracle[{code}@{actor}]",
                                     gold=f"{code}@{actor}", pred=f"{code}@{actor}" if index < hits else None,
                                     correct=index < hits))
    precision = OraclePrecision(matched=sum((pred_entries & gold_entries).values()),
                                predicted=sum(pred_entries.values()))

    check("extension", "environment.road_surface", _token(env.road_surface),
          _token(p_env.road_surface) if p_env else None)
    check("extension", "road_network.curve_direction", _token(road.curve_direction),
          _token(p_road.curve_direction) if p_road else None)
    for role, actor in gold.actors.items():
        other = pred.actors.get(role) if pred else None
        if actor.speed_mph is not None or (other is not None and other.speed_mph is not None):
            check("extension", f"actors.{role}.speed_mph", actor.speed_mph, other.speed_mph if other else None)
    if gold.collisions is not None:
        predicted = (pred.collisions or []) if pred else []
        for index, contact in enumerate(gold.collisions):
            other = predicted[index] if index < len(predicted) else None
            check("extension", f"collisions[{index}]", _contact(contact), _contact(other) if other else None)
            check("extension", f"collisions[{index}].collision_areas", _areas(contact),
                  _areas(other) if other else None)
    return checks, precision


def _contact(contact: Any) -> str:
    """A contact as dsl.md section 4 scores it: the same striking and struck actors and the same class."""
    return f"{contact.striking}->{contact.struck}:{_token(contact.class_)}"


def _areas(contact: Any) -> str:
    return f"{_token(contact.striking_area)}->{_token(contact.struck_area)}"


def _extension_name(field: str) -> str:
    """`actors.npc1.speed_mph` -> speed_mph, `collisions[0]` -> collisions, `collisions[0].collision_areas` ->
    collision_areas."""
    last = field.rsplit(".", 1)[-1]
    return "collisions" if last.startswith("collisions[") else last


def _attr(obj: Any, dotted: str) -> Any:
    for part in dotted.split("."):
        obj = getattr(obj, part, None)
    return obj


def _token(value: Any) -> Any:
    return value.value if hasattr(value, "value") else value


def _signs(signs: list) -> str:
    return "[" + ", ".join(_token(sign) for sign in signs) + "]"


# ---------------------------------------------------------------- aggregating


def evaluate(pairs: dict[str, tuple[Scenario, Scenario | None]],
             errors: dict[str, str] | None = None) -> EvalResult:
    """Score every case: `pairs` maps case id -> (golden, predicted or None when it failed to load)."""
    errors = errors or {}
    components = {name: Score() for name in COMPONENTS}
    extensions = {name: Score() for name in EXTENSIONS}
    overall = Score()
    precision = OraclePrecision()
    confusion: dict[str, dict[str, dict[str, int]]] = {}
    fields: dict[str, Score] = {}
    cases: list[CaseResult] = []
    for case in sorted(pairs):
        gold, pred = pairs[case]
        checks, case_precision = score_case(case, gold, pred)
        precision.matched += case_precision.matched
        precision.predicted += case_precision.predicted
        result = CaseResult(case=case, error=errors.get(case))
        for item in checks:
            if item.component == "extension":
                extensions[_extension_name(item.field)].add(item.correct)
            else:
                components[item.component].add(item.correct)
                overall.add(item.correct)
                result.score.add(item.correct)
            if not item.correct:
                result.diffs.append(item)
            fields.setdefault("oracle" if item.component == "oracle" else _confusion_key(item.field),
                              Score()).add(item.correct)
            if item.component != "oracle":
                key = _confusion_key(item.field)
                row = confusion.setdefault(key, {}).setdefault(_cell(item.gold), {})
                row[_cell(item.pred)] = row.get(_cell(item.pred), 0) + 1
        cases.append(result)
    return EvalResult(components=components, overall=overall, oracle_precision=precision, extensions=extensions,
                      confusion={key: confusion[key] for key in sorted(confusion)},
                      fields={key: fields[key] for key in sorted(fields)}, cases=cases)


def _confusion_key(field: str) -> str:
    parts = field.split(".")
    if parts[0].startswith("collisions["):
        return "collisions" + ("." + parts[1] if len(parts) > 1 else "")  # pooled over positions
    if parts[0] == "actors" and len(parts) > 2:
        return "actors." + ".".join(parts[2:])  # pooled over roles: actors.behavior, actors.position.heading
    return field


def _cell(value: Any) -> str:
    return "(absent)" if value is None else str(value)


# ---------------------------------------------------------------- directories


def case_files(directory: Path | str) -> dict[str, Path]:
    """Map case id -> scenario file for a directory of `<case>.yaml` files or `<case>/` folders."""
    directory = Path(directory)
    if not directory.is_dir():
        raise EvalError(f"{directory}: not a directory; expected <case>.yaml files or <case>/golden.yaml folders")
    found: dict[str, Path] = {}
    for entry in sorted(directory.iterdir()):
        if entry.is_file() and entry.suffix in (".yaml", ".yml"):
            found[entry.stem] = entry
        elif entry.is_dir():
            path = _folder_file(entry)
            if path is not None:
                found[entry.name] = path
    return found


def _folder_file(folder: Path) -> Path | None:
    for name in CASE_FILE_NAMES:
        if (folder / name).is_file():
            return folder / name
    candidates = sorted(folder.glob("*.yaml")) + sorted(folder.glob("*.yml"))
    return candidates[0] if len(candidates) == 1 else None


def evaluate_dirs(gold_dir: Path | str, pred_dir: Path | str, allow_missing: bool = False) -> EvalResult:
    """Load both directories, match cases by id and score them."""
    pairs, errors, extra = load_pairs(gold_dir, pred_dir, allow_missing)
    result = evaluate(pairs, errors)
    result.ignored_predictions = extra
    return result


def load_pairs(gold_dir: Path | str, pred_dir: Path | str, allow_missing: bool = False
               ) -> tuple[dict[str, tuple[Scenario, Scenario | None]], dict[str, str], list[str]]:
    """Case id -> (golden, predicted or None), the load errors per case, and predictions without a golden file."""
    gold_files = case_files(gold_dir)
    pred_files = case_files(pred_dir)
    if not gold_files:
        raise EvalError(f"{gold_dir}: no golden files (<case>.yaml or <case>/golden.yaml)")
    missing = sorted(set(gold_files) - set(pred_files))
    extra = sorted(set(pred_files) - set(gold_files))
    if (missing or extra) and not allow_missing:
        parts = []
        if missing:
            parts.append(f"no prediction in {pred_dir} for {len(missing)} golden case(s): {_names(missing)}")
        if extra:
            parts.append(f"no golden file in {gold_dir} for {len(extra)} predicted case(s): {_names(extra)}")
        raise EvalError("; ".join(parts) + " (use --allow-missing to score missing predictions as 0)")
    pairs: dict[str, tuple[Scenario, Scenario | None]] = {}
    errors: dict[str, str] = {}
    for case, path in gold_files.items():
        try:
            gold = load_file(path)
        except DslError as exc:
            raise EvalError(f"golden file does not validate:\n{exc}") from None
        pred = None
        if case in pred_files:
            try:
                pred = load_file(pred_files[case])
            except DslError as exc:
                errors[case] = str(exc)
        else:
            errors[case] = "no prediction"
        pairs[case] = (gold, pred)
    return pairs, errors, extra


def _names(cases: list[str], limit: int = 8) -> str:
    shown = ", ".join(cases[:limit])
    return shown + (f", ... ({len(cases) - limit} more)" if len(cases) > limit else "")


# ---------------------------------------------------------------- text report


def format_result(result: EvalResult, diffs: bool = True, confusion: bool = True) -> str:
    """A plain-text report: accuracy table, oracle precision, extensions, per-case diffs, confusion."""
    lines = [f"{'component':<14} {'correct':>7} {'total':>6} {'accuracy':>9}"]
    for name, score in [*result.components.items(), ("overall", result.overall)]:
        lines.append(f"{name:<14} {score.correct:>7} {score.total:>6} {_pct(score.accuracy):>9}")
    precision = result.oracle_precision
    lines.append(f"oracle precision: {precision.matched}/{precision.predicted} = {_pct(precision.precision)}")
    lines.append("per field: " + ", ".join(f"{name} {_pct(score.accuracy)}" for name, score in result.fields.items()
                                           if score.correct < score.total) + " (others 100%)")
    lines.append("extensions (not in overall): " + ", ".join(
        f"{name} {score.correct}/{score.total} ({_pct(score.accuracy)})" for name, score in result.extensions.items()))
    if diffs:
        lines.append("")
        lines.append("per case:")
        for case in result.cases:
            lines.append(f"  {case.case}: {case.score.correct}/{case.score.total} ({_pct(case.score.accuracy)})"
                         + (f"  ERROR: {case.error.splitlines()[0]}" if case.error else ""))
            for diff in case.diffs:
                if case.error is None:
                    note = "  (extension, not scored)" if diff.component == "extension" else ""
                    lines.append(f"      {diff.field}: gold {_cell(diff.gold)} | pred {_cell(diff.pred)}{note}")
    if confusion:
        lines.append("")
        lines.append("confusion (gold -> pred: count), fields with errors only:")
        for field, rows in result.confusion.items():
            wrong = {gold: preds for gold, preds in rows.items() if any(p != gold for p in preds)}
            if not wrong:
                continue
            lines.append(f"  {field}")
            for gold, preds in sorted(wrong.items()):
                cells = ", ".join(f"{pred}: {count}" for pred, count in sorted(preds.items(), key=lambda kv: -kv[1]))
                lines.append(f"      {gold} -> {cells}")
    if result.ignored_predictions:
        lines.append(f"ignored predictions without a golden file: {_names(result.ignored_predictions)}")
    return "\n".join(lines)


def _pct(value: float | None) -> str:
    return "n/a" if value is None else f"{100 * value:.1f}%"
