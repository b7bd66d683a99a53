"""Traffic control of an embedded batch: which junction entries are signalised, stop- or yield-controlled,
which signal group each approach belongs to, and who must yield to whom at a conflict point.

Derived per variation from that variation's own layout and the DSL (a device controls the approach of the
actors that reference it, else the ego's; a traffic light signalises every approach).
"""
from __future__ import annotations

import math

import numpy as np

from crashscene.dsl import Scenario
from crashscene.geometry import clip_scalar, wrap_angle
from crashscene.scene import SampledScene
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS


def entry_controls(scenario: Scenario, scene: SampledScene, arrays: RouteArrays, route0: np.ndarray,
                    s0: np.ndarray, anchor: int) -> tuple[np.ndarray, np.ndarray]:
    """CONTROL code and signal group of every junction entry of every route (from variation 0's layout)."""
    signs = {str(s) for s in scenario.road_network.traffic_signs}
    n_r, n_j = arrays.entry_s.shape
    control = np.zeros((n_r, n_j), dtype=np.int8)
    group = np.zeros((n_r, n_j), dtype=np.int8)

    def first_entry(a: int) -> int | None:
        r = int(route0[a])
        # entry_s is padded with inf past a route's last entry: a road without a junction has no entry at all
        ahead = np.nonzero(np.isfinite(arrays.entry_s[r]) & (arrays.entry_s[r] > s0[a] - 1.0))[0]
        return int(ahead[0]) if len(ahead) else None

    ego_col = next((a for a, act in enumerate(scene.actors) if act.role == "ego"), anchor)
    junctions: set[int] = set()
    roads: dict[str, set[str]] = {"stop_sign": set(), "yield_sign": set()}
    for a, actor in enumerate(scene.actors):
        j = first_entry(a)
        if j is None:
            continue
        r = int(route0[a])
        junctions.add(int(arrays.entry_junction[r, j]))
        if actor.reference in roads:
            roads[actor.reference].add(arrays.entry_road[r][j])
    for sign, controlled in roads.items():
        if sign in signs and not controlled:
            j = first_entry(ego_col)
            if j is not None:
                controlled.add(arrays.entry_road[int(route0[ego_col])][j])
    # the anchor's approach heading at each junction defines signal group 0
    anchor_heading: dict[int, float] = {}
    ra = int(route0[anchor])
    for j in range(n_j):
        if arrays.entry_junction[ra, j] >= 0:
            anchor_heading.setdefault(int(arrays.entry_junction[ra, j]),
                                      heading_at(arrays, ra, arrays.entry_s[ra, j] - 2.0))
    for r in range(n_r):
        for j in range(n_j):
            junction = int(arrays.entry_junction[r, j])
            if junction < 0 or junction not in junctions:
                continue
            road = arrays.entry_road[r][j]
            if "traffic_light" in signs:
                control[r, j] = 1
            elif road in roads["stop_sign"]:
                control[r, j] = 2
            elif road in roads["yield_sign"]:
                control[r, j] = 3
            heading = heading_at(arrays, r, arrays.entry_s[r, j] - 2.0)
            ref = anchor_heading.get(junction, heading)
            group[r, j] = 0 if abs(math.cos(heading - ref)) > 0.7 else 1
    return control, group


def heading_at(arrays: RouteArrays, r: int, s: float) -> float:
    k = int(clip_scalar(s / ROUTE_DS, 0, arrays.yaw.shape[1] - 1))
    return float(arrays.yaw[r, k])


def control_tables(scenario: Scenario, scenes: list[SampledScene], arrays: RouteArrays, route: np.ndarray,
                    s0: np.ndarray, anchor: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per variation, the (R, J) control and signal-group tables its own layout implies (memoised by layout)."""
    cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    out = []
    for v, scene in enumerate(scenes):
        firsts = []
        for a in range(route.shape[1]):
            entries = arrays.entry_s[route[v, a]]
            ahead = np.nonzero(np.isfinite(entries) & (entries > s0[v, a] - 1.0))[0]
            firsts.append(int(ahead[0]) if len(ahead) else -1)
        key = (tuple(int(r) for r in route[v]), tuple(firsts), tuple(a.reference for a in scene.actors))
        if key not in cache:
            cache[key] = entry_controls(scenario, scene, arrays, route[v], s0[v], anchor)
        out.append(cache[key])
    return out


def priorities(arrays: RouteArrays, route: np.ndarray, tables: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """(V, A, A): actor a must yield to actor b at their conflict point."""
    n_v, n_a = route.shape
    cache: dict[tuple[int, int, int], bool] = {}
    out = np.zeros((n_v, n_a, n_a), dtype=bool)
    for v in range(n_v):
        control = tables[v][0]
        for a in range(n_a):
            for b in range(n_a):
                if a == b:
                    continue
                key = (int(route[v, a]), int(route[v, b]), id(control))
                if key not in cache:
                    cache[key] = _must_yield(arrays, key[0], key[1], control)
                out[v, a, b] = cache[key]
    return out


def _must_yield(arrays: RouteArrays, ra: int, rb: int, entry_control: np.ndarray) -> bool:
    cs = arrays.conflict_s[ra, rb]
    if np.isnan(cs):
        return False
    ja = entry_before(arrays, ra, cs)
    jb = entry_before(arrays, rb, arrays.conflict_s[rb, ra])
    if ja is None or jb is None:
        return False  # the conflict is not at a junction (merges are handled by the lane-change gap check)
    ca, cb = int(entry_control[ra, ja]), int(entry_control[rb, jb])
    minor_a, minor_b = ca in (2, 3), cb in (2, 3)
    if minor_a != minor_b:
        return minor_a
    ha = heading_at(arrays, ra, arrays.entry_s[ra, ja] - 2.0)
    hb = heading_at(arrays, rb, arrays.entry_s[rb, jb] - 2.0)
    rel = wrap_angle(hb - ha)
    oncoming = abs(rel) > 2.4
    a_left = arrays.entry_maneuver[ra, ja] in (2, 4)
    b_left = arrays.entry_maneuver[rb, jb] in (2, 4)
    if a_left and oncoming and not b_left:
        return True  # a left turn yields to oncoming traffic
    if ca == 1 and cb == 1:
        return False  # signals separate the other movements
    if oncoming:
        return False
    return rel > 0.6  # b travels to a's left, i.e. comes from a's right: yield to the right


def entry_before(arrays: RouteArrays, r: int, s: float) -> int | None:
    """The junction entry at or before station s, if s lies within that junction (or just before it)."""
    entries = arrays.entry_s[r]
    idx = np.nonzero(entries <= s + 3.0)[0]
    if len(idx) == 0:
        return None
    j = int(idx[-1])
    k = int(clip_scalar(s / ROUTE_DS, 0, arrays.junction.shape[1] - 1))
    if arrays.junction[r, k] < 0 and s - entries[j] > 3.0:
        return None
    return j
