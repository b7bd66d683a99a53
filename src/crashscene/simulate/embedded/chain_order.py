"""Written rear-ends between actors starting in one lane, in reproduce mode: each striker starts behind what it
strikes, in the written order along the lane.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from crashscene.simulate.embedded.stations import START_GAP, START_MARGIN, same_lane

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan


def order_chain(plan: VariationPlan) -> None:
    """Written rear-ends between actors starting in one lane put each striker behind what it strikes: when
    the sampled order along the lane says otherwise, the actors of the chain take the same stations in
    the written order (the last struck in front), spaced by their lengths."""
    cols = plan.ctx.columns
    roles = [c.role for c in cols]
    behind: set[tuple[int, int]] = set()
    for striking, struck, klass, *_ in plan.ctx.contacts:
        if klass == "rear_end" and striking in roles and struck in roles:
            a, b = roles.index(striking), roles.index(struck)
            if same_lane(plan.route, plan.d0, a, b):
                behind.add((a, b))
    if not behind or all(plan.s0[a] < plan.s0[b] for a, b in behind):
        return
    chain = sorted({i for pair in behind for i in pair})
    order: list[int] = []
    while len(order) < len(chain):  # the written order, the sampled one between unrelated actors
        free = [i for i in chain if i not in order
                and not any(b == i and a not in order for a, b in behind)]
        if not free:
            return  # the contacts contradict each other
        order.append(min(free, key=lambda i: plan.s0[i]))
    stations = sorted(float(plan.s0[i]) for i in chain)
    for k in range(len(order) - 2, -1, -1):  # from the front: each far enough behind the one ahead
        room = (plan.length[order[k]] + plan.length[order[k + 1]]) / 2 + START_GAP
        stations[k] = min(stations[k], stations[k + 1] - room)
    if stations[0] < START_MARGIN:
        return
    for i, s in zip(order, stations):
        if s != plan.s0[i]:
            plan.s0[i] = s
            plan.moved[i] = True
