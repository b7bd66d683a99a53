"""The built-in rulebook: importing this package registers every rule module in it.

Each module of this package declares its rules (`@register_rule`); they are
imported here by discovery, so a new rule is one new module. User rules
register themselves the same way from any module; a rulebook file can name
such modules under `imports:`.
"""
import importlib
import pkgutil

from crashscene.monitor.rules.base import (
                                           Disposition,
                                           Rule,
                                           RuleOutcome,
                                           RuleParams,
                                           codes_with,
                                           dispositions_of,
                                           monitored_codes,
                                           register_rule,
                                           registered_rules,
                                           rule_class,
                                           unregister_rule,
)

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    importlib.import_module(f"{__name__}.{_module}")

# The built-in codes in rulebook order (rules.md), as declared by the rule classes (`rank`).
BUILTIN_ORDER = tuple(code for code, cls in registered_rules().items() if cls.__module__.startswith(__name__ + "."))

__all__ = ["BUILTIN_ORDER", "Disposition", "Rule", "RuleOutcome", "RuleParams", "codes_with", "dispositions_of",
           "monitored_codes", "register_rule", "registered_rules", "rule_class", "unregister_rule"]
