"""Draw scenes from a compiled sampling plan (`sampler.json`) with numpy: Scenic's distribution without its interpreter.

The plan (written by `crashscene.render.sampling_plan`) names the program's
parameters, actors and candidate-placement arguments. Here the candidates are
enumerated once by the very function the program calls
(`scenic_support.candidates`, on Scenic's parse of the same map), then every
attempt of every variation is evaluated at once: a uniform candidate, uniform
parameters and blueprints, arc lengths by placement rule, positions and
headings by the same shapely arc-length lookups as the program's helpers, and
Scenic's built-in requirements (each car's footprint inside road-or-shoulder,
no two footprints intersecting). A rejected attempt is redrawn, as Scenic does.

Determinism: variation i draws its attempts, in order, from its own generator
seeded by `SeedSequence([seed, i])`; the first accepted attempt is its scene.
So scene i depends only on (plan, seed, i), whatever the batch it is drawn in.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from crashscene.geometry import wrap_angle
from crashscene.render.errors import SampleError
from crashscene.render.sampling_plan import PLAN_FORMAT, SAMPLING_PLAN_NAME, program_digest
from crashscene.scene import SampledActor, SampledScene

CLAMP_MARGIN = 3.0  # [m] routes are read no closer than this to their ends (scenic_support._clamp)
HEADING_SPAN = 1.0  # [m] half-span of the chord a heading is measured on (scenic_support._r_heading)
FIRST_ATTEMPTS = 2  # attempts per variation in the first round; later rounds quadruple it


class PlanError(ValueError):
    """The sampling plan is missing, malformed or stale (raised as SampleError by `crashscene.render.sample`)."""


@dataclass
class _Routes:
    """Every distinct route of every candidate, as arrays indexed by route number."""

    lines: np.ndarray  # shapely LineStrings (object array)
    length: np.ndarray  # [m]
    anchor: np.ndarray  # [m] arc length of the route's anchor
    starts: np.ndarray  # [m] arc length where each lane of the route starts, +inf padded: (routes, max lanes)
    lane_uids: list[list[str]]
    lanes_text: list[str]  # comma-joined lane uids


def load_plan(program: Path) -> dict[str, Any]:
    """The plan beside `program`, checked against the program's text."""
    program = Path(program)
    path = program.parent / SAMPLING_PLAN_NAME
    if not path.is_file():
        raise PlanError(f"{path}: no compiled sampling plan beside {program.name} (re-render it with "
                        "crashscene render, or sample with --sampler scenic)")
    try:
        plan = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise PlanError(f"{path}: unreadable sampling plan: {exc}") from exc
    if plan.get("format") != PLAN_FORMAT:
        raise PlanError(f"{path}: format {plan.get('format')!r}; allowed: {PLAN_FORMAT} (re-render the scenario)")
    if plan.get("program_sha256") != program_digest(program.read_text(encoding="utf-8")):
        raise PlanError(f"{path}: written for another version of {program.name} (the program was edited or "
                        "re-rendered without it); re-render, or sample with --sampler scenic")
    return plan


class CompiledSampler:
    """Scenes of one rendered program on one map; construct once, call `scenes` for any index range."""

    def __init__(self, program: Path, map_path: Path | None = None):
        import shapely

        from crashscene.cache import pickled

        self.plan = plan = load_plan(program)
        self.map_path = Path(map_path) if map_path is not None else Path(program).parent / plan["map"]
        self.actors = plan["actors"]
        self.roles = [a["role"] for a in self.actors]
        # the candidate routes and the drivable region depend only on the map and the candidate spec: computed
        # once per (map, spec, code), so a later run skips Scenic altogether
        spec = plan["candidates"]
        inputs = [self.map_path.read_bytes(), json.dumps([spec, self.roles], sort_keys=True).encode()]
        self.combo_routes, self.routes, self.passed, self.region = pickled(
            "sampler-candidates", inputs, lambda: _candidates(self.map_path, spec, self.roles))
        shapely.prepare(self.region)
        self.param_names = [p["name"] for p in plan["params"]]
        self.low = np.array([p["low"] for p in plan["params"]], dtype=float)
        self.high = np.array([p["high"] for p in plan["params"]], dtype=float)
        self.column = {name: k for k, name in enumerate(self.param_names)}
        self.width = 1 + len(self.param_names) + len(self.actors)  # uniforms per attempt: candidate, params, blueprints
        self.last_attempts = np.zeros(0, dtype=np.int64)  # attempts each scene of the last call took

    # ------------------------------------------------------------------ drawing

    def scenes(self, first: int, n: int, seed: int, digest: str, map_file: str,
               max_attempts: int = 2000, pinned: np.ndarray | None = None) -> list[SampledScene | None]:
        """Scenes for variation indices first .. first+n-1.

        `pinned`: (n, P) values of the plan's parameters (in plan order) held fixed for every attempt of each
        scene (a search's points); every other choice is drawn as without it, and a scene no attempt could place
        with its values is None instead of an error."""
        indices = np.arange(first, first + n)
        if pinned is not None:
            pinned = np.asarray(pinned, dtype=float)
            if pinned.shape != (n, len(self.param_names)):
                raise SampleError(f"pinned values of shape {pinned.shape}; expected ({n}, {len(self.param_names)}) "
                                  f"for the parameters {', '.join(self.param_names)}")
        generators = [np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFFFFFF,
                                                                                   int(i)])))
                      for i in indices]
        chosen: dict[int, dict[str, np.ndarray]] = {}
        self.last_attempts = np.zeros(n, dtype=np.int64)  # acceptance rate = n / sum
        pending = list(range(n))
        used = 0
        block = FIRST_ATTEMPTS
        while pending:
            if used >= max_attempts:
                if pinned is not None:  # the rest are rejected scenes (None)
                    break
                raise SampleError(f"scene {int(indices[pending[0]])} (seed {seed}) could not be sampled: no "
                                  f"attempt out of {max_attempts} met the requirements (cars on the road, "
                                  "none overlapping)")
            block = min(block, max_attempts - used)
            draws = np.concatenate([generators[k].random((block, self.width)) for k in pending])
            attempt = self.evaluate(draws, None if pinned is None else np.repeat(pinned[pending], block, axis=0))
            ok = attempt["ok"].reshape(len(pending), block)
            still = []
            for row, k in enumerate(pending):
                hits = np.flatnonzero(ok[row])
                if hits.size:
                    at = row * block + int(hits[0])
                    chosen[k] = {key: value[at] for key, value in attempt.items()}
                    self.last_attempts[k] = used + int(hits[0]) + 1
                else:
                    still.append(k)
            pending = still
            used += block
            block *= 4
        return [self._scene(chosen[k], int(indices[k]), seed, digest, map_file) if k in chosen else None
                for k in range(n)]

    def evaluate(self, u: np.ndarray, values: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Every attempt at once from uniforms `u` (attempts, width): placements and whether they are valid.
        `values`: (attempts, P) parameter values to use instead of those `u` draws."""
        import shapely

        m = len(u)
        k_combo = np.minimum((u[:, 0] * len(self.passed)).astype(np.int64), len(self.passed) - 1)
        if values is None:
            values = self.low + (self.high - self.low) * u[:, 1:1 + len(self.param_names)]
        out: dict[str, np.ndarray] = {"values": values}
        s_of: dict[str, np.ndarray] = {}
        boxes = []
        ego_route = self.combo_routes[k_combo, self.roles.index("ego")]
        for j, actor in enumerate(self.actors):
            role, kind = actor["role"], actor["placement"]
            route = self.combo_routes[k_combo, j]
            dist = values[:, self.column[actor["prefix"] + "_INIT_DIST"]]
            front = actor["along"] == "front"
            if kind == "anchor":
                s = (self.routes.anchor[ego_route] + self.passed[k_combo] + dist) if front \
                    else self.routes.anchor[ego_route] - dist
            elif kind == "follow":
                s = s_of[actor["ref"]] + (dist + actor["gap"]) * (1.0 if front else -1.0)
            elif kind in ("side_left", "side_right", "oncoming"):
                along = values[:, self.column[actor["prefix"] + "_SIDE_OFFSET"]] if kind != "oncoming" \
                    else actor["oncoming_sign"] * dist
                ref = self.roles.index(actor["ref"])
                target = self._point(self.combo_routes[k_combo, ref], s_of[actor["ref"]] + along)
                s = shapely.line_locate_point(self.routes.lines[route], target)
            else:  # approach
                s = self.routes.anchor[route] - dist
            s_of[role] = s
            clamped = self._clamp(route, s)
            xy = shapely.get_coordinates(shapely.line_interpolate_point(self.routes.lines[route], clamped))
            heading = self._heading(route, clamped)
            lane = (self.routes.starts[route] <= clamped[:, None]).sum(axis=1) - 1
            pool = len(actor["blueprints"])
            if "model_param" in actor:  # a search's program: the parameter's integer part (program.py's _model)
                bp = np.clip(values[:, self.column[actor["model_param"]]].astype(np.int64), 0, pool - 1)
            else:
                bp = np.minimum((u[:, 1 + len(self.param_names) + j] * pool).astype(np.int64), pool - 1)
            dims = np.asarray(actor["dims"], dtype=float)[bp]
            out.update({f"{role}.x": xy[:, 0], f"{role}.y": xy[:, 1], f"{role}.heading": heading,
                        f"{role}.route": route, f"{role}.lane": lane, f"{role}.bp": bp})
            boxes.append(_footprints(xy, heading, dims[:, 0], dims[:, 1]))
        ok = np.ones(m, dtype=bool)
        for j, box in enumerate(boxes):
            ok &= shapely.contains(self.region, box)
            for other in boxes[:j]:
                ok &= ~shapely.intersects(box, other)
        out["ok"] = ok
        return out

    # ------------------------------------------------------------------ route lookups (scenic_support's, vectorised)

    def _clamp(self, route: np.ndarray, s: np.ndarray) -> np.ndarray:
        return np.minimum(np.maximum(s, CLAMP_MARGIN), np.maximum(CLAMP_MARGIN, self.routes.length[route] - CLAMP_MARGIN))

    def _point(self, route: np.ndarray, s: np.ndarray):
        import shapely

        return shapely.line_interpolate_point(self.routes.lines[route], self._clamp(route, s))

    def _heading(self, route: np.ndarray, clamped: np.ndarray) -> np.ndarray:
        """Scenic heading [rad] (0 = +y, counter-clockwise) of the chord around each arc length."""
        import shapely

        lines = self.routes.lines[route]
        a = shapely.get_coordinates(shapely.line_interpolate_point(lines, np.maximum(0.0, clamped - HEADING_SPAN)))
        b = shapely.get_coordinates(shapely.line_interpolate_point(
            lines, np.minimum(self.routes.length[route], clamped + HEADING_SPAN)))
        return np.arctan2(-(b[:, 0] - a[:, 0]), b[:, 1] - a[:, 1])

    # ------------------------------------------------------------------ scenes

    def _scene(self, att: dict[str, Any], index: int, seed: int, digest: str, map_file: str) -> SampledScene:
        plan = self.plan
        town = plan.get("carla_map")
        params: dict[str, float | int | str] = {"carla_map": town} if town else {}
        params.update((name, value) for name, value in plan["constants"])
        if not town:
            params["carla_map"] = self.map_path.stem  # the CARLA model names the town after the map file
        params["record"] = ""
        values = [float(v) for v in att["values"]]
        params.update(zip(self.param_names, values))
        if "npc1_INIT_DIST" in params:
            params.setdefault("NPC_INIT_DIST", params["npc1_INIT_DIST"])
        actors = []
        for actor in self.actors:
            role = actor["role"]
            route = int(att[f"{role}.route"])
            bp = int(att[f"{role}.bp"])
            speed = params[actor["prefix"] + "_SPEED"]
            actors.append(SampledActor(
                role=role, label=actor["label"], type=actor["type"], blueprint=actor["blueprints"][bp],
                behavior=actor["behavior"], x=float(att[f"{role}.x"]), y=float(att[f"{role}.y"]),
                yaw=wrap_angle(float(att[f"{role}.heading"]) + math.pi / 2),
                speed=max(0.0, speed), length=actor["dims"][bp][0], width=actor["dims"][bp][1],
                lane_id=self.routes.lane_uids[route][int(att[f"{role}.lane"])],
                route_intent=actor["route_intent"], reference=actor["reference"], relation=actor["relation"],
                heading_relation=actor["heading_relation"],
                dispositions=[c for c in actor["dispositions"].split(",") if c],
                properties={"placement": actor["placement"], "maneuver": actor["maneuver"],
                            "controlled_by": actor["controlled_by"], "target_speed": speed,
                            "route_lanes": self.routes.lanes_text[route]}))
        return SampledScene(index=index, seed=seed, scenario_hash=digest, map_file=map_file, params=params,
                            actors=actors)


def _candidates(map_path: Path, spec: dict[str, Any], roles: list[str]):
    """(candidate x actor -> route number, the routes, crossing lengths, the drivable region polygons) of the
    map: Scenic's road network and `render.scenic_support.candidates`, as the Scenic program does."""
    from scenic.domains.driving.roads import Network

    from crashscene.render import scenic_support

    network = Network.fromFile(str(map_path))
    combos = scenic_support.candidates(network, spec["actors"], spec["topology"], spec["hint"], spec["curve_sign"],
                                       spec["ego_roads"], spec["map_name"], spec["room"])
    combo_routes, routes, passed = _tabulate(combos, roles)
    region = network.drivableRegion.union(network.shoulderRegion)
    return combo_routes, routes, passed, getattr(region, "footprint", region).polygons


def _tabulate(combos: list[Any], roles: list[str]) -> tuple[np.ndarray, _Routes, np.ndarray]:
    """(candidate x actor -> route number, the routes, each candidate's junction crossing length [m])."""
    numbers: dict[int, int] = {}
    routes = []
    table = np.empty((len(combos), len(roles)), dtype=np.int64)
    for k, combo in enumerate(combos):
        for j, role in enumerate(roles):
            route = combo.routes[role]
            if id(route) not in numbers:
                numbers[id(route)] = len(routes)
                routes.append(route)
            table[k, j] = numbers[id(route)]
    width = max(len(r.starts) for r in routes)
    starts = np.full((len(routes), width), np.inf)
    for i, r in enumerate(routes):
        starts[i, :len(r.starts)] = r.starts
    lines = np.empty(len(routes), dtype=object)
    lines[:] = [r.line for r in routes]
    table_routes = _Routes(lines=lines, length=np.array([r.length for r in routes], dtype=float),
                           anchor=np.array([r.anchor for r in routes], dtype=float), starts=starts,
                           lane_uids=[[lane.uid for lane in r.lanes] for r in routes],
                           lanes_text=[",".join(lane.uid for lane in r.lanes) for r in routes])
    return table, table_routes, np.array([c.passed for c in combos], dtype=float)


def _footprints(xy: np.ndarray, heading: np.ndarray, length: np.ndarray, width: np.ndarray):
    """Oriented rectangles (shapely polygons) of cars at `xy` facing Scenic `heading` [rad]."""
    import shapely

    fx, fy = -np.sin(heading), np.cos(heading)  # forward unit vector (Scenic: 0 = +y)
    lx, ly = -fy, fx  # left
    hl, hw = 0.5 * length, 0.5 * width
    corners = []
    for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1), (1, 1)):
        corners.append(np.stack([xy[:, 0] + a * hl * fx + b * hw * lx, xy[:, 1] + a * hl * fy + b * hw * ly], axis=1))
    return shapely.polygons(np.stack(corners, axis=1))
