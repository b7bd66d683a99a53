"""The rulebook: which rules run, with which thresholds; defaults from rules.md, overridable from YAML.

A rulebook file::

    imports: [my_company.rules]      # optional, needs --allow-imports: modules that register extra rules
    rules:
      CVC_21703: {min_headway: 1.5}  # override a threshold
      CVC_22349: {enabled: false}    # switch a rule off
      CVC_22108: {}                  # a user rule registered by an imported module

Every error names the file, the rule code, the parameter, the bad value and
what is allowed. A rulebook is data that may be shared: its `imports` run
code, so they are refused unless the caller opts in (`allow_imports`,
`--allow-imports` on the command line).
"""
from __future__ import annotations

import hashlib
import importlib
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from crashscene.monitor.errors import RulebookError
from crashscene.monitor.rules import Rule, RuleParams, registered_rules

TOP_LEVEL_KEYS = ("imports", "rules")


class Rulebook(BaseModel):
    """Per-code parameters (codes not listed run with their defaults)."""

    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)

    params: dict[str, RuleParams] = Field(default_factory=dict)
    imports: list[str] = Field(default_factory=list)
    source: str | None = None

    def rules(self) -> list[Rule]:
        """Instances of every enabled registered rule, built-ins in rules.md order, then user rules."""
        out = []
        for code, cls in registered_rules().items():
            params = self.params.get(code) or cls.Params()
            if params.enabled:
                out.append(cls(params))
        return out

    def defaults(self) -> dict[str, dict[str, Any]]:
        """Effective parameters of every registered rule (for `--show-rules` and reports)."""
        return {rule_cls.code: (self.params.get(code) or rule_cls.Params()).model_dump(mode="json")
                for code, rule_cls in registered_rules().items()}

    @classmethod
    def from_mapping(cls, data: Any, source: str = "<rulebook>", allow_imports: bool = False) -> Rulebook:
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise RulebookError(f"{source}: a rulebook is a mapping with keys {', '.join(TOP_LEVEL_KEYS)} "
                                f"(got {type(data).__name__})")
        unknown = [k for k in data if k not in TOP_LEVEL_KEYS]
        if unknown:
            raise RulebookError(f"{source}: unknown key {unknown[0]!r}; allowed: {', '.join(TOP_LEVEL_KEYS)}")
        imports = data.get("imports") or []
        if not isinstance(imports, list) or not all(isinstance(m, str) for m in imports):
            raise RulebookError(f"{source}: imports: expected a list of module names (got {imports!r})")
        if imports and not allow_imports:
            raise RulebookError(f"{source}: imports: {', '.join(imports)}: importing Python modules from a rulebook "
                                f"runs their code; allowed only with --allow-imports (allow_imports=True)")
        for module in imports:
            try:
                importlib.import_module(module)
            except Exception as exc:  # any import failure is the user's module: say which one
                raise RulebookError(f"{source}: imports: cannot import {module!r}: {exc}") from exc
        rules = data.get("rules") or {}
        if not isinstance(rules, dict):
            raise RulebookError(f"{source}: rules: expected a mapping of rule code -> parameters (got {rules!r})")
        registry = registered_rules()
        params: dict[str, RuleParams] = {}
        for code, values in rules.items():
            if code not in registry:
                raise RulebookError(f"{source}: rules.{code}: unknown rule code; allowed: {', '.join(registry)}")
            if values is None:
                values = {}
            if not isinstance(values, dict):
                raise RulebookError(f"{source}: rules.{code}: expected a mapping of parameter -> value "
                                    f"(got {values!r}); allowed parameters: {_names(registry[code].Params)}")
            params[code] = _validate(registry[code].Params, values, source, code)
        return cls(params=params, imports=list(imports), source=source)


def rulebook_yaml(rulebook: Rulebook | None = None) -> str:
    """The effective rulebook as an editable YAML file, every parameter commented with its meaning."""
    rulebook = rulebook or Rulebook()
    lines = ["# crashscene rulebook: thresholds of the monitored California Vehicle Code checks.",
             "# Edit values, set enabled: false to skip a rule, list modules registering extra rules under imports.",
             f"imports: {yaml.safe_dump(rulebook.imports, default_flow_style=True).strip()}", "rules:"]
    for code, cls in registered_rules().items():
        params = rulebook.params.get(code) or cls.Params()
        lines.append(f"  {code}:  # {cls.violation}: {cls.summary}".rstrip())
        for name, field in cls.Params.model_fields.items():
            value = yaml.safe_dump(getattr(params, name), default_flow_style=True).strip()
            value = value.removesuffix("\n...").removesuffix("...").strip()
            comment = f"  # {field.description}" if field.description else ""
            lines.append(f"    {name}: {value}{comment}")
    return "\n".join(lines) + "\n"


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key written twice in one mapping (plain YAML keeps the last one silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if isinstance(key, (str, int, float, bool)) and key in seen:
                raise RulebookError(f"{self.name}:{line}: key {key!r} written twice, on lines {seen[key]} and "
                                    f"{line}; keep one")
            seen[key] = line
        return super().construct_mapping(node, deep=deep)


def load_rulebook(path: str | Path, allow_imports: bool = False) -> Rulebook:
    """Read a rulebook YAML file (`imports` only with `allow_imports`)."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise RulebookError(f"{path}: cannot read rulebook: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise RulebookError(f"{path}: not a rulebook: not UTF-8 text (byte {exc.start}); a rulebook is a YAML "
                            f"file like the output of `crashscene rules`") from None
    if "\x00" in text:
        raise RulebookError(f"{path}: not a rulebook: binary data (NUL bytes); a rulebook is a YAML file")
    loader = _UniqueKeyLoader(text)
    loader.name = str(path)
    try:
        data = loader.get_single_data()
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        raise RulebookError(f"{where}: not valid YAML: {getattr(exc, 'problem', exc)}") from exc
    finally:
        loader.dispose()
    return Rulebook.from_mapping(data, source=str(path), allow_imports=allow_imports)


def rulebook_digest(path: str | Path | None) -> str | None:
    """sha256 of a rulebook file's bytes (None without a file): what a resumed campaign compares."""
    if path is None:
        return None
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as exc:
        raise RulebookError(f"{path}: cannot read rulebook: {exc.strerror or exc}") from exc


def _names(model: type[BaseModel]) -> str:
    return ", ".join(model.model_fields)


def _allowed(model: type[BaseModel], name: str) -> str:
    field = model.model_fields.get(name)
    if field is None:
        return _names(model)
    bounds = []
    for meta in field.metadata:
        for attr, sign in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            value = getattr(meta, attr, None)
            if value is not None:
                bounds.append(f"{sign} {value}")
    kind = getattr(field.annotation, "__name__", str(field.annotation))
    text = f"{kind} {' and '.join(bounds)}".strip()
    if field.description:
        text += f" ({field.description})"
    return text


def _validate(model: type[RuleParams], values: dict, source: str, code: str) -> RuleParams:
    try:
        return model.model_validate(values)
    except ValidationError as exc:
        err = exc.errors()[0]
        name = str(err["loc"][0]) if err["loc"] else "?"
        if err["type"] == "extra_forbidden":
            raise RulebookError(f"{source}: rules.{code}.{name}: unknown parameter; allowed: {_names(model)}") from None
        raise RulebookError(f"{source}: rules.{code}.{name}: {err['msg']} (got {err.get('input')!r}); "
                            f"allowed: {_allowed(model, name)}") from None
