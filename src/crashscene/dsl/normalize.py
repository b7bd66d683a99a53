"""Normalise human spellings of a raw scenario tree into canonical keys and tokens.

Readers accept the paper's and TARGET's spellings ("Road network", "Ego
vehicle", "Other actor 1", "T-intersection", "not mentioned") and the compact
oracle form `- CVC_21453: red_light`. Values that are not recognised are left
as they are, so that validation reports the value the user wrote.
"""
from __future__ import annotations

import re
from typing import Any

from crashscene.dsl.tokens import ALIASES, CODE_PATTERN, actor_key, fold

_KEYS = {
    "top": {"dsl_version": "dsl_version", "version": "dsl_version", "scenario_id": "scenario_id",
            "id": "scenario_id", "summary": "summary", "environment": "environment",
            "road_network": "road_network", "road": "road_network", "actors": "actors",
            "oracle": "oracle", "oracles": "oracle", "collisions": "collisions", "contacts": "collisions",
            "crash_sequence": "collisions", "evidence": "evidence"},
    "environment": {"weather": "weather", "time_of_day": "time_of_day", "time": "time_of_day",
                    "lighting": "time_of_day", "road_surface": "road_surface", "surface": "road_surface"},
    "road_network": {"road_type": "road_type", "number_of_ways": "number_of_ways", "ways": "number_of_ways",
                     "number_of_lanes": "number_of_lanes", "lanes": "number_of_lanes",
                     "road_marker": "road_marker", "road_markers": "road_marker", "road_marking": "road_marker",
                     "road_markings": "road_marker", "traffic_signs": "traffic_signs",
                     "traffic_sign": "traffic_signs", "traffic_controls": "traffic_signs",
                     "speed_limit_mph": "speed_limit_mph", "speed_limit": "speed_limit_mph",
                     "curve_direction": "curve_direction"},
    "actor": {"label": "label", "type": "type", "vehicle_type": "type", "behavior": "behavior",
              "behaviour": "behavior", "position": "position", "speed_mph": "speed_mph", "speed": "speed_mph"},
    "position": {"reference": "reference", "relation": "relation", "heading": "heading",
                 "direction": "heading"},
    "oracle": {"code": "code", "violation": "violation", "actor": "actor", "description": "description"},
    "contact": {"striking": "striking", "striking_actor": "striking", "struck": "struck", "struck_actor": "struck",
                "striking_area": "striking_area", "struck_area": "struck_area", "class": "class",
                "collision_class": "class", "configuration": "class"},
}

_WORD_NUMBERS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
                 "one_way": 1, "two_way": 2, "single": 1}


def canonical_key(section: str, key: Any) -> Any:
    """The canonical name of `key` inside `section`, or the key unchanged when unknown."""
    if not isinstance(key, str):
        return key
    if section == "actors":
        return actor_key(key)
    return _KEYS[section].get(fold(key), key)


def token(field: str, value: Any) -> Any:
    """Canonical token of an enum-valued field, or the value unchanged when unrecognised."""
    if not isinstance(value, str):
        return value
    folded = fold(value)
    return ALIASES.get(field, {}).get(folded, folded)


def code_token(value: Any) -> Any:
    """'CVC 21453', 'cvc21453', '21453' -> 'CVC_21453'."""
    if isinstance(value, int):
        return f"CVC_{value}"
    if not isinstance(value, str):
        return value
    match = re.fullmatch(r"\s*(?:cvc)?[\s_\-]*([0-9]+[a-z]?)\s*", value.lower())
    return f"CVC_{match.group(1)}" if match else value


def _number(value: Any) -> Any:
    if isinstance(value, str):
        folded = fold(value)
        if folded.isdigit():
            return int(folded)
        return _WORD_NUMBERS.get(folded, value)
    return value


def _mapping(section: str, raw: Any) -> Any:
    if not isinstance(raw, dict):
        return raw
    return {canonical_key(section, key): value for key, value in raw.items()}


def _signs(raw: Any) -> Any:
    if raw is None:
        return []
    if isinstance(raw, str):
        if fold(raw) in ("none", "not_mentioned", "no", "no_signs", ""):
            return []
        raw = [part for part in re.split(r"[,;]| and ", raw) if part.strip()]
    if isinstance(raw, list):
        return [token("sign", item) for item in raw]
    return raw


def _position(raw: Any) -> Any:
    raw = _mapping("position", raw)
    if not isinstance(raw, dict):
        return raw
    out = dict(raw)
    if isinstance(out.get("reference"), str):
        ref = out["reference"]
        out["reference"] = actor_key(ref) if actor_key(ref) != fold(ref) else token("reference", ref)
    for field in ("relation", "heading"):
        if field in out:
            out[field] = token(field, out[field])
    return out


def _actor(raw: Any) -> Any:
    raw = _mapping("actor", raw)
    if not isinstance(raw, dict):
        return raw
    out = dict(raw)
    for field in ("type", "behavior"):
        if field in out:
            out[field] = token(field, out[field])
    if "position" in out:
        out["position"] = _position(out["position"])
    if "label" in out and out["label"] is not None and not isinstance(out["label"], str):
        out["label"] = str(out["label"])
    return out


def _oracle_entry(raw: Any) -> Any:
    if not isinstance(raw, dict):
        return raw
    out: dict[Any, Any] = {}
    for key, value in raw.items():
        folded = canonical_key("oracle", key)
        compact = code_token(key) if isinstance(key, str) and folded not in _KEYS["oracle"].values() else None
        if compact is not None and CODE_PATTERN.match(compact):
            # Compact form: `CVC_21453: red_light` beside description (and maybe actor).
            out["code"] = compact
            out["violation"] = token("violation", value)
            out.setdefault("actor", "ego")
        else:
            out[folded] = value
    if "code" in out:
        out["code"] = code_token(out["code"])
    if isinstance(out.get("actor"), str):
        out["actor"] = actor_key(out["actor"])
    if isinstance(out.get("violation"), str):
        out["violation"] = fold(out["violation"])
    return out


def _oracle(raw: Any) -> Any:
    if raw is None or (isinstance(raw, str) and fold(raw) in ("none", "not_mentioned", "")):
        return []
    if isinstance(raw, dict):  # a mapping of code -> violation
        raw = [{key: value} for key, value in raw.items()]
    if isinstance(raw, list):
        return [_oracle_entry(item) for item in raw]
    return raw


def _contact(raw: Any) -> Any:
    raw = _mapping("contact", raw)
    if not isinstance(raw, dict):
        return raw
    out = dict(raw)
    for field in ("striking", "struck"):
        if isinstance(out.get(field), str):
            out[field] = actor_key(out[field])
    for field in ("striking_area", "struck_area"):
        if field in out:
            out[field] = token("area", out[field])
    if "class" in out:
        out["class"] = token("class", out["class"])
    return out


def _collisions(raw: Any) -> Any:
    if isinstance(raw, str) and fold(raw) in ("none", "no_contact", ""):
        return []
    if isinstance(raw, list):
        return [_contact(item) for item in raw]
    return raw


def normalize(raw: Any) -> Any:
    """Canonical keys and tokens for a raw scenario tree; non-mappings pass through for validation."""
    raw = _mapping("top", raw)
    if not isinstance(raw, dict):
        return raw
    out = dict(raw)
    env = _mapping("environment", out.get("environment"))
    if isinstance(env, dict):
        env = {key: token(key, value) if key in ("weather", "time_of_day", "road_surface") else value
               for key, value in env.items()}
    if "environment" in out:
        out["environment"] = env
    road = _mapping("road_network", out.get("road_network"))
    if isinstance(road, dict):
        road = dict(road)
        for field in ("road_type", "road_marker", "curve_direction"):
            if field in road:
                road[field] = token(field, road[field])
        for field in ("number_of_ways", "number_of_lanes", "speed_limit_mph"):
            if field in road:
                road[field] = _number(road[field])
        if "traffic_signs" in road:
            road["traffic_signs"] = _signs(road["traffic_signs"])
    if "road_network" in out:
        out["road_network"] = road
    actors = _mapping("actors", out.get("actors"))
    if isinstance(actors, dict):
        actors = {key: _actor(value) for key, value in actors.items()}
    if "actors" in out:
        out["actors"] = actors
    if "oracle" in out:
        out["oracle"] = _oracle(out["oracle"])
    if "collisions" in out:
        out["collisions"] = _collisions(out["collisions"])
    return out
