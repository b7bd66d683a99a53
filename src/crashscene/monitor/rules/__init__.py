"""The built-in rulebook: importing this package registers the 12 checks of rules.md.

User rules register themselves the same way (`@register_rule`) from any module;
a rulebook file can name such modules under `imports:`.
"""
from crashscene.monitor.rules import following, lanes, right_of_way, signals, speed  # noqa: F401  (register)
from crashscene.monitor.rules.base import (
                                           Rule,
                                           RuleOutcome,
                                           RuleParams,
                                           register_rule,
                                           registered_rules,
                                           rule_class,
                                           unregister_rule,
)

BUILTIN_ORDER = ("CVC_21453", "CVC_22450", "CVC_21800", "CVC_21801", "CVC_21802", "CVC_22350", "CVC_22349",
                 "CVC_21460", "CVC_21650", "CVC_22107", "CVC_21703", "CVC_21803")

__all__ = ["BUILTIN_ORDER", "Rule", "RuleOutcome", "RuleParams", "register_rule", "registered_rules", "rule_class",
           "unregister_rule"]
