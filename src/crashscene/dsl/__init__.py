"""The Extended Scenic DSL: models, reading and writing, validation, JSON Schema."""
from crashscene.dsl.errors import Diagnostic, DslError, Severity
from crashscene.dsl.io import dump_file, dumps, from_raw, load_file, loads
from crashscene.dsl.model import Actor, Contact, Environment, OracleEntry, Position, RoadNetwork, Scenario
from crashscene.dsl.schema import json_schema
from crashscene.dsl.validate import validate, validate_file, validate_text

__all__ = ["Actor", "Contact", "Diagnostic", "DslError", "Environment", "OracleEntry", "Position", "RoadNetwork",
           "Scenario", "Severity", "dump_file", "dumps", "from_raw", "json_schema", "load_file", "loads",
           "validate", "validate_file", "validate_text"]
