"""VariationPlan.snapshot / restore: a planning step tried and dropped leaves the plan's rows as they were."""
from __future__ import annotations

import numpy as np

from crashscene.simulate.embedded.plan import READ_ONLY_ROWS, VariationPlan


def _plan() -> VariationPlan:
    n = 3
    return VariationPlan(ctx=None, scene=None, draws=None, route=np.arange(n), speed=np.full(n, 20.0),
                         length=np.full(n, 4.5), width=np.full(n, 1.8), entry_control=np.zeros((n, 2), dtype=int),
                         lane_width=3.5, s0=np.array([10.0, 40.0, 80.0]), d0=np.zeros(n), lateral_target=np.zeros(n),
                         planned=np.full(n, 20.0), speeds=np.full(n, 20.0), scale=np.ones(n), hold=np.zeros(n),
                         trigger=np.full(n, np.inf), skids=np.full((n, 3), np.nan), moved=np.zeros(n, dtype=bool),
                         drifted=np.zeros(n))


def test_restore_brings_back_every_row_a_planning_step_changed():
    plan = _plan()
    kept = plan.snapshot()
    plan.s0[1], plan.moved[1], plan.speeds[2], plan.scale[2] = 35.0, True, 15.0, 0.75
    plan.skids[0] = (0.5, 0.1, 1.0)
    plan.d0 += 3.5
    plan.restore(kept)
    again = _plan()
    for name in kept:
        np.testing.assert_array_equal(getattr(plan, name), getattr(again, name), err_msg=name)


def test_a_snapshot_is_a_copy_of_the_changeable_rows_only():
    plan = _plan()
    kept = plan.snapshot()
    assert not set(kept) & set(READ_ONLY_ROWS)
    arrays = {name for name, value in vars(plan).items() if isinstance(value, np.ndarray)}
    assert set(kept) == arrays - set(READ_ONLY_ROWS)  # every array row the plan holds, found from its annotations
    plan.s0[0] = -1.0
    assert kept["s0"][0] == 10.0  # a copy, not a view
    s0 = plan.s0
    plan.restore(kept)
    assert plan.s0 is s0  # restored in place: callers holding the row see it
