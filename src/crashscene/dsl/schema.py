"""JSON Schema of the canonical DSL, shared by `crashscene schema` and the LLM's structured output."""
from __future__ import annotations

import json
from typing import Any

from crashscene.dsl.model import Scenario


def json_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a canonical scenario."""
    schema = Scenario.model_json_schema(mode="validation")
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "Extended Scenic DSL scenario, version 1"
    return schema


def json_schema_text() -> str:
    return json.dumps(json_schema(), indent=2, sort_keys=True) + "\n"
