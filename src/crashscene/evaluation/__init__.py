"""Extraction accuracy: extracted scenarios scored against golden files (`crashscene eval`).

`score` compares predicted and golden DSL field by field (dsl.md section 4);
`folds` splits the bundled cases into deterministic folds and marks those no
extraction rule was written from (held out).
"""
from crashscene.evaluation.folds import assign_folds, evaluate_folds
from crashscene.evaluation.score import EvalError, EvalResult, evaluate, evaluate_dirs

__all__ = ["EvalError", "EvalResult", "assign_folds", "evaluate", "evaluate_dirs", "evaluate_folds"]
