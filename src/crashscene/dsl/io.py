"""Read and write scenario files: safe YAML in, canonical YAML out.

Reading is defensive (size cap, alias-expansion cap, no Python tags) and every
failure becomes a `DslError` with file, field path, line, value and allowed
values. Writing emits the canonical form of the golden files: canonical key
order, flow style for positions and sign sets, free text double-quoted, so
load -> dump -> load is the identity and golden files round-trip byte for byte.
"""
from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from crashscene.dsl.errors import Diagnostic, DslError
from crashscene.dsl.model import Actor, Contact, Environment, OracleEntry, Position, RoadNetwork, Scenario
from crashscene.dsl.normalize import canonical_key
from crashscene.dsl.tokens import fold

MAX_BYTES = 1_000_000  # [bytes] a scenario is a few kB; anything larger is not one
MAX_NODES = 20_000  # YAML nodes after alias expansion (guards against "billion laughs")


# ---------------------------------------------------------------- reading


def load_file(path: str | Path) -> Scenario:
    """Load and schema-validate one scenario file."""
    path = Path(path)
    source = str(path)
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise DslError([Diagnostic(f"cannot read file: {exc.strerror}", file=source)]) from None
    if path.is_dir():
        raise DslError([Diagnostic("is a directory, not a scenario file", file=source)])
    if size > MAX_BYTES:
        raise DslError([Diagnostic(f"file is {size} bytes; a scenario file is at most {MAX_BYTES} bytes",
                                   file=source)])
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DslError([Diagnostic(f"not UTF-8 text (byte {exc.start}); is this a YAML file?",
                                   file=source)]) from None
    return loads(text, source=source)


def loads(text: str, source: str | None = None) -> Scenario:
    """Parse and schema-validate scenario YAML text; `source` names it in errors."""
    raw, lines = parse_yaml(text, source)
    return from_raw(raw, source=source, lines=lines)


def from_raw(raw: Any, source: str | None = None, lines: dict[str, int] | None = None) -> Scenario:
    """Validate an already-parsed tree (a YAML document, or an LLM's JSON)."""
    lines = lines or {}
    if not isinstance(raw, dict):
        kind = "empty document" if raw is None else f"a {type(raw).__name__}"
        raise DslError([Diagnostic(f"a scenario is a mapping with environment, road_network, actors, "
                                   f"oracle; got {kind}", file=source, line=lines.get(""))])
    try:
        return Scenario.model_validate(raw)
    except ValidationError as exc:
        raise DslError([_diagnostic(err, source, lines) for err in exc.errors()]) from None


def parse_yaml(text: str, source: str | None = None) -> tuple[Any, dict[str, int]]:
    """Safe-load YAML text; returns the tree and a map field path -> 1-based line."""
    if len(text.encode("utf-8", errors="replace")) > MAX_BYTES:
        raise DslError([Diagnostic(f"text is larger than {MAX_BYTES} bytes; not a scenario", file=source)])
    if "\x00" in text:
        raise DslError([Diagnostic("contains NUL bytes; binary data, not YAML", file=source)])
    try:
        loader = yaml.SafeLoader(text)
    except yaml.YAMLError as exc:
        raise DslError([Diagnostic(f"not valid YAML: {exc}", file=source)]) from None
    try:
        node = loader.get_single_node()
        if node is None:
            raise DslError([Diagnostic("file is empty; a scenario needs environment, road_network, actors, "
                                       "oracle", file=source)])
        _check_size(node, source)
        lines: dict[str, int] = {}
        _line_map(node, "", "top", lines, source)
        raw = loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        problem = exc.problem or exc.context or "invalid YAML"
        raise DslError([Diagnostic(f"not valid YAML: {problem}", file=source, line=line)]) from None
    except yaml.YAMLError as exc:
        raise DslError([Diagnostic(f"not valid YAML: {exc}", file=source)]) from None
    except RecursionError:
        raise DslError([Diagnostic("YAML nests too deeply", file=source)]) from None
    finally:
        loader.dispose()
    return raw, lines


def _check_size(root: yaml.Node, source: str | None) -> None:
    """Count nodes as an alias-expanding reader would see them; refuse bombs and cycles."""
    count = 0
    stack: list[tuple[yaml.Node, int]] = [(root, 0)]
    while stack:
        node, depth = stack.pop()
        count += 1
        if count > MAX_NODES or depth > 64:
            raise DslError([Diagnostic(f"YAML expands to more than {MAX_NODES} nodes or nests deeper than 64 "
                                       f"(anchors and aliases?); not a scenario", file=source,
                                       line=node.start_mark.line + 1)])
        if isinstance(node, yaml.SequenceNode):
            stack.extend((child, depth + 1) for child in node.value)
        elif isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                stack.append((key, depth + 1))
                stack.append((value, depth + 1))


_CHILD_SECTION = {("top", "environment"): "environment", ("top", "road_network"): "road_network",
                  ("top", "actors"): "actors", ("actors", "*"): "actor", ("actor", "position"): "position",
                  ("top", "oracle"): "oracle_list", ("oracle_list", "*"): "oracle",
                  ("top", "collisions"): "contact_list", ("contact_list", "*"): "contact"}
_LIST_ITEMS = {"oracle_list": "oracle", "contact_list": "contact"}


def _line_map(node: yaml.Node, path: str, section: str, out: dict[str, int], source: str | None = None) -> None:
    """Fill field path -> line; refuse a key written twice in one mapping (YAML would keep the last silently),
    also when two spellings normalise to the same key ("road_type" and "Road type")."""
    out.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for key_node, value_node in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else "?"
            if section in ("top", "environment", "road_network", "actors", "actor", "position", "oracle", "contact"):
                key = canonical_key(section, key)
            child = f"{path}.{key}" if path else str(key)
            line = key_node.start_mark.line + 1
            if key in seen:
                raise DslError([Diagnostic(f"key written twice, on lines {seen[key]} and {line}; keep one",
                                           path=child, file=source, line=line)])
            seen[key] = line
            next_section = _CHILD_SECTION.get((section, "*" if section == "actors" else key), "")
            out.setdefault(child, line)
            _line_map(value_node, child, next_section, out, source)
    elif isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            next_section = _LIST_ITEMS.get(section, "")
            _line_map(item, f"{path}[{index}]", next_section, out, source)


def _loc_path(loc: tuple[Any, ...]) -> str:
    parts: list[str] = []
    for item in loc:
        if isinstance(item, int):
            parts.append(f"[{item}]")
        else:
            parts.append(("." if parts else "") + str(item))
    return "".join(parts)


def _line_for(path: str, lines: dict[str, int]) -> int | None:
    while path:
        if path in lines:
            return lines[path]
        shorter = re.sub(r"(\.[^.\[\]]*|\[[0-9]+\])$", "", path)
        path = "" if shorter == path else shorter
    return lines.get("")


def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model class that owns the last element of `loc`, for listing allowed fields."""
    model: type[BaseModel] | None = Scenario
    nested = {"environment": Environment, "road_network": RoadNetwork, "position": Position}
    for index, item in enumerate(loc[:-1]):
        if item in nested:
            model = nested[item]
        elif index >= 1 and loc[index - 1] == "actors":
            model = Actor
        elif loc[index - 1:index] == ("oracle",) and isinstance(item, int):
            model = OracleEntry
        elif loc[index - 1:index] == ("collisions",) and isinstance(item, int):
            model = Contact
        elif isinstance(item, int) or loc[index - 1:index] == ("actors",):
            continue
        elif item not in ("actors", "oracle", "collisions"):
            model = None
    return model


def _diagnostic(err: dict[str, Any], source: str | None, lines: dict[str, int]) -> Diagnostic:
    loc = tuple(err["loc"])
    path = _loc_path(loc)
    kind = err["type"]
    value = err.get("input")
    allowed: list[str] = []
    message = err["msg"]
    if kind in ("enum", "literal_error"):
        expected = err.get("ctx", {}).get("expected", "")
        allowed = re.findall(r"'([^']*)'|([0-9]+)", expected)
        allowed = [a or b for a, b in allowed]
        message = "unknown value"
    elif kind == "missing":
        message = "required field is missing"
        value = None
    elif kind == "extra_forbidden":
        model = _model_at(loc)
        allowed = [field.alias or name for name, field in model.model_fields.items()] if model else []
        message = "unknown field"
        value = loc[-1]
    elif kind == "value_error":
        message = str(err.get("ctx", {}).get("error", message))
        match = re.search(r"; allowed: (.*)$", message)
        if match:
            allowed = [part.strip() for part in match.group(1).split(",")]
            message = message[: match.start()]
    elif kind in ("dict_type", "model_type"):
        message = f"must be a mapping, not a {type(value).__name__}"
    elif kind == "list_type":
        message = f"must be a list, not a {type(value).__name__}"
    if isinstance(value, (dict, list)) and kind not in ("dict_type", "model_type", "list_type"):
        value = None
    return Diagnostic(message=message, path=path, file=source, line=_line_for(path, lines), value=value,
                      allowed=allowed)


# ---------------------------------------------------------------- writing

_PLAIN = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")
_PATH_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\[\]]*$")
_YAML_SPECIAL = {"y", "n", "yes", "no", "true", "false", "on", "off", "null", "~"}


_UNPRINTABLE = re.compile("[^\t\n\r\x20-\x7e\xa0-\ud7ff\ue000-\ufeff\uff00-\ufffd\U00010000-\U0010ffff]|\ufeff")


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group(0))
    return f"\\u{code:04x}" if code <= 0xFFFF else f"\\U{code:08x}"


def _quoted(text: str) -> str:
    """A double-quoted YAML scalar: JSON escapes, plus escapes for what YAML may not carry raw
    (C0/C1 controls, DEL, NEL and the Unicode line separators that YAML would fold)."""
    return _UNPRINTABLE.sub(_escape, json.dumps(text, ensure_ascii=False))


def _word(text: str) -> str:
    """An identifier-like scalar: plain when YAML reads it back as exactly this string (a trailing newline is not)."""
    plain = _PLAIN.match(text) and fold(text) not in _YAML_SPECIAL
    if plain:
        try:
            plain = yaml.safe_load(text) == text
        except yaml.YAMLError:
            plain = False
    return text if plain else _quoted(text)


def _number(value: float | int) -> str:
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def dumps(scenario: Scenario) -> str:
    """The canonical YAML text of a scenario."""
    out: list[str] = [f"dsl_version: {scenario.dsl_version}"]
    if scenario.scenario_id is not None:
        out.append(f"scenario_id: {_word(scenario.scenario_id)}")
    if scenario.summary is not None:
        out.append(f"summary: {_quoted(scenario.summary)}")
    env = scenario.environment
    out += ["environment:", f"  weather: {env.weather.value}", f"  time_of_day: {env.time_of_day.value}",
            f"  road_surface: {env.road_surface.value}"]
    road = scenario.road_network
    out += ["road_network:", f"  road_type: {road.road_type.value}", f"  number_of_ways: {road.number_of_ways}",
            f"  number_of_lanes: {road.number_of_lanes}", f"  road_marker: {road.road_marker.value}",
            f"  traffic_signs: [{', '.join(sign.value for sign in road.traffic_signs)}]"]
    if road.speed_limit_mph is not None:
        out.append(f"  speed_limit_mph: {road.speed_limit_mph}")
    if road.curve_direction is not None:
        out.append(f"  curve_direction: {road.curve_direction.value}")
    out.append("actors:")
    for name, actor in scenario.actors.items():
        out.append(f"  {name}:")
        if actor.label is not None:
            out.append(f"    label: {_word(actor.label)}")
        out += [f"    type: {actor.type.value}", f"    behavior: {actor.behavior.value}"]
        pos = actor.position
        parts = [f"reference: {pos.reference}", f"relation: {pos.relation.value}"]
        if pos.heading is not None:
            parts.append(f"heading: {pos.heading.value}")
        out.append(f"    position: {{{', '.join(parts)}}}")
        if actor.speed_mph is not None:
            out.append(f"    speed_mph: {_number(actor.speed_mph)}")
    if not scenario.oracle:
        out.append("oracle: []")
    else:
        out.append("oracle:")
        for entry in scenario.oracle:
            out += [f"  - code: {entry.code}", f"    violation: {entry.violation}", f"    actor: {entry.actor}",
                    f"    description: {_quoted(entry.description)}"]
    if scenario.collisions is not None:
        out.append("collisions:" + ("" if scenario.collisions else " []"))
        for contact in scenario.collisions:
            out.append(f"  - {{striking: {contact.striking}, struck: {contact.struck}, "
                       f"striking_area: {contact.striking_area.value}, struck_area: {contact.struck_area.value}, "
                       f"class: {contact.class_.value}}}")
    if scenario.evidence:
        out.append("evidence:")
        for key, quote in scenario.evidence.items():
            key_text = key if _PATH_KEY.match(key) else _quoted(key)
            out.append(f"  {key_text}: {_quoted(quote)}")
    return "\n".join(out) + "\n"


def dump_file(scenario: Scenario, path: str | Path) -> None:
    Path(path).write_text(dumps(scenario), encoding="utf-8")
