"""The monitor: the California Vehicle Code rulebook, collision classes and per-variation verdicts.

`evaluate(tables, scenario, rulebook)` works on the trace tables of
`crashscene.traces` from any backend; `monitor_run(run_dir)` re-evaluates a
stored run. Rules are small classes registered by code (`register_rule`);
thresholds come from a `Rulebook` (defaults of rules.md, YAML overrides).
"""
from crashscene.geometry import classify_contact as classify
from crashscene.monitor.check_traces import evaluate
from crashscene.monitor.collisions import COLLISION_CLASSES
from crashscene.monitor.context import EvalContext
from crashscene.monitor.errors import (
           MonitorError,
           RegistryError,
           RulebookError,
           TraceError,
)
from crashscene.monitor.result import MonitorResult
from crashscene.monitor.rulebook import Rulebook, load_rulebook
from crashscene.monitor.rules import (
           Rule,
           RuleOutcome,
           RuleParams,
           register_rule,
           registered_rules,
           unregister_rule,
)
from crashscene.monitor.run_folder import monitor_run
from crashscene.monitor.verdicts import VERDICTS, ExpectedCollision, expected_collision

__all__ = ["COLLISION_CLASSES", "VERDICTS", "EvalContext", "ExpectedCollision", "MonitorError", "MonitorResult",
           "RegistryError", "Rule", "RuleOutcome", "RuleParams", "Rulebook", "RulebookError", "TraceError",
           "classify", "evaluate", "expected_collision", "load_rulebook", "monitor_run", "register_rule",
           "registered_rules", "unregister_rule"]
