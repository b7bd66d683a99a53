"""Timing plans of an embedded batch, per variation: when each actor starts, how fast it cruises and when its
manoeuvre triggers, so that the paths conflict as the report says (see `timing` for the kinematics), and the
signal phase that gives the anchor its green.

`VariationPlan.build` runs the named steps, each in a module of its own: lateral manoeuvres (`lateral`, a clip
of the vehicle ahead in `clip`), junction arrivals (`arrivals`); in reproduce mode also the written crash
sequence beyond its first contact: a chain of rear-ends in the written order along their lane (`chain_order`),
a car knocked aside (`knock`), a cascade, where a third vehicle meets a car the first impact pushes or
deflects (`cascade_plan`, `meetings`), and a chain of pushes (`pushchain`).

Every draw comes from the variation's own generator in a fixed order, so a plan depends only on
(scenario, seed, variation index).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from crashscene.geometry import clip_scalar
from crashscene.monitor.rules import Disposition
from crashscene.render.plan import LATERAL_BEHAVIORS, LEAD_TIME, SIGNAL_GREEN, SKID_ROTATION
from crashscene.scene import SampledScene
from crashscene.simulate.drivers.behaviors import OVER_LIMIT, SPEEDING_CODES, speed_factor
from crashscene.simulate.embedded import pushchain, signals, timing, touch
from crashscene.simulate.embedded import skid as skid_plan
from crashscene.simulate.embedded.arrivals import plan_junction, stop_dist
from crashscene.simulate.embedded.cascade_plan import plan_cascade
from crashscene.simulate.embedded.chain_order import order_chain
from crashscene.simulate.embedded.knock import knock_aside
from crashscene.simulate.embedded.lateral import enter_wrong_way, plan_lateral, skids_toward
from crashscene.simulate.embedded.stations import shift_start, start_back
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS
from crashscene.units import MPH

if TYPE_CHECKING:
    from crashscene.simulate.embedded.setup import ActorColumn


@dataclass(frozen=True)
class PlanContext:
    """What the plans of every variation of a batch share."""

    columns: list[ActorColumn]
    anchor: int  # actor column every junction conflict is timed against (the ADS, or the ego in reproduce mode)
    arrays: RouteArrays
    classes: dict[frozenset[str], str]  # written contact class per actor pair (DSL `collisions`)
    strikers: dict[frozenset[str], str]  # striking role of the first written contact per pair
    first_pair: frozenset[str] | None  # the two roles of the first written contact
    reproduce: bool
    runs_red: bool  # the anchor's driver runs red lights (its signal phase is planned red)
    cond: float  # [-] condition factor on the posted limit
    default_limit: float  # [m/s] the DSL's posted limit, NaN if none
    friction: float  # [-] tyre-road friction coefficient
    skid_paths: skid_plan.SkidPaths  # candidate skids (at this friction and the simulator's step), by speed
    contacts: tuple[tuple[str, str, str, str, str], ...] = ()  # the written sequence, in order: (striking,
    # struck, class, striking area, struck area)
    lanes_beside: np.ndarray | None = None  # (n_lanes, 2) same-direction lanes left and right of each map lane


@dataclass
class Draws:
    """A variation's random draws, taken from its generator in one fixed order."""

    offset: np.ndarray  # (A,) [s] arrival offset at the conflict point
    lead: np.ndarray  # (A,) [s] lead time of a lateral manoeuvre
    trigger: np.ndarray  # (A,) [s] trigger time of a manoeuvre with no partner
    green: float  # [s] green remaining for the anchor's axis
    spin: np.ndarray  # (A,) sign of an unplanned loss of control
    rotation: np.ndarray  # (A,) [-] where in its range a planned skid's rotation falls
    cascade: np.ndarray  # (A,) [-] how late in its window a later contact's striker arrives

    @classmethod
    def take(cls, rng: np.random.Generator, n_a: int) -> Draws:
        return cls(offset=rng.normal(timing.ARRIVAL_OFFSET_MEAN, timing.ARRIVAL_OFFSET_SD, n_a),
                   lead=rng.uniform(*LEAD_TIME, n_a), trigger=rng.uniform(1.0, 4.0, n_a),
                   green=rng.uniform(*SIGNAL_GREEN), spin=rng.choice([-1.0, 1.0], n_a),
                   rotation=rng.uniform(*SKID_ROTATION, n_a), cascade=rng.uniform(0.0, 1.0, n_a))


READ_ONLY_ROWS = ("route", "speed", "length", "width", "entry_control")  # a plan's start rows from its scene


@functools.cache
def _changeable_rows(cls: type) -> tuple[str, ...]:
    """The array fields of a plan class (annotated np.ndarray) but READ_ONLY_ROWS: what `snapshot` copies (found
    once per class; a followon dry run snapshots tens of thousands of times a case)."""
    return tuple(f.name for f in fields(cls) if f.type in ("np.ndarray", np.ndarray) and f.name not in READ_ONLY_ROWS)


@dataclass
class VariationPlan:
    """One variation's timing plan, (A,) arrays over its actors: where each actor starts (`s0`, `d0`), the
    cruise speed it plans (`planned`) and its timing scale on it (`scale`), how long it is held at its start
    (`hold`), when its manoeuvre triggers (`trigger`) and where it steers to (`lateral_target`), a planned
    skid (`skids`: spin rate [rad/s], drift [rad], hold [s]), which actors the plan moved along their route
    (`moved`) or already started drifting across (`drifted` [m]); the signal `phase` [s] and the anchor's
    nominal arrival at its first conflict (`conflict_time` [s]).

    Built by `VariationPlan.build` in named steps; every draw comes from the variation's own generator in a
    fixed order, so a plan depends only on (scenario, seed, variation index).
    """

    ctx: PlanContext
    scene: SampledScene
    draws: Draws
    route: np.ndarray  # (A,) route index (read only)
    speed: np.ndarray  # (A,) [m/s] sampled speed (read only)
    length: np.ndarray  # (A,) [m] (read only)
    width: np.ndarray  # (A,) [m] (read only)
    entry_control: np.ndarray  # (R, J) control code of each junction entry of each route (read only)
    lane_width: float  # [m] median start lane width
    s0: np.ndarray
    d0: np.ndarray
    lateral_target: np.ndarray
    planned: np.ndarray  # [m/s] the cruise speed each driver will hold, before its timing scale
    speeds: np.ndarray  # [m/s] the speed the plan expects of each actor (planned, slowed where the plan slows it)
    scale: np.ndarray
    hold: np.ndarray
    trigger: np.ndarray
    skids: np.ndarray  # (A, 3)
    moved: np.ndarray
    drifted: np.ndarray
    phase: float = 0.0
    conflict_time: float = math.inf
    arrival_anchor: float | None = None  # [s] the anchor's planned arrival at its conflict point (first asked)
    anchor_speed: float = 0.0  # [m/s] the anchor's planned speed
    anchor_stop: float | None = None  # [m] distance to the stop line the anchor stops at first, None if none
    touch_at: tuple[float, float] | None = None  # [m] the first written contact's meeting stations on the striker's
    # and the struck actor's routes when `touch.class_meeting` moved it (sync.Meeting, with no struck offset)
    pull_out: touch.Waiting | None = None  # a moved first meeting whose one actor stops at its line first
    slap_offset: float | None = None  # [m] the struck offset (struck_offset's terms) a side slap follows (slap)

    @classmethod
    def build(cls, ctx: PlanContext, scene: SampledScene, rng: np.random.Generator, route: np.ndarray,
              s0: np.ndarray, d0: np.ndarray, speed: np.ndarray, length: np.ndarray, width: np.ndarray,
              entry_control: np.ndarray, lateral_target: np.ndarray, lane_width: float) -> VariationPlan:
        """The plan of one variation from its scene's start rows (copied, never changed)."""
        n_a = len(ctx.columns)
        plan = cls(ctx=ctx, scene=scene, draws=Draws.take(rng, n_a), route=route, speed=speed, length=length,
                   width=width, entry_control=entry_control, lane_width=lane_width, s0=s0.copy(), d0=d0.copy(),
                   lateral_target=lateral_target.copy(), planned=np.zeros(n_a), speeds=np.zeros(n_a),
                   scale=np.ones(n_a), hold=np.zeros(n_a), trigger=np.full(n_a, np.inf),
                   skids=np.full((n_a, 3), np.nan), moved=np.zeros(n_a, dtype=bool), drifted=np.zeros(n_a))
        if ctx.reproduce:
            order_chain(plan)
        plan.plan_speeds()  # draws nothing: the draws above are the variation's first, as always
        plan.anchor_speed = float(plan.speeds[ctx.anchor])
        plan.anchor_stop = plan.stop_dist(ctx.anchor)
        for a, col in enumerate(ctx.columns):
            offset = plan.arrival_offset(a)
            if col.is_ads:
                continue
            if col.behavior in LATERAL_BEHAVIORS:
                plan_lateral(plan, a)
            elif col.behavior in ("decelerate", "stop"):
                plan.trigger[a] = plan.param(a, ("TRIGGER_TIME", "MANEUVER_TIME"), plan.draws.trigger[a])
            elif a != ctx.anchor and col.behavior != "static":
                if ctx.reproduce and col.behavior == "go_forward":
                    enter_wrong_way(plan, a)
                plan_junction(plan, a, offset)
        if ctx.reproduce:
            knock_aside(plan)
            plan_cascade(plan)
            pushchain.place_chain(plan)
        plan.plan_signal_phase()
        return plan

    def snapshot(self) -> dict[str, np.ndarray]:
        """Copies of the per-actor rows planning may change (every array field but the scene's start rows, which
        are read only), for `restore`: a planning step tried and dropped leaves the plan as it was."""
        return {name: getattr(self, name).copy() for name in _changeable_rows(type(self))}

    def restore(self, snapshot: dict[str, np.ndarray]) -> None:
        """The rows `snapshot` copied, back as they were then."""
        for name, value in snapshot.items():
            getattr(self, name)[:] = value

    def param(self, a: int, names: tuple[str, ...], default: float) -> float:
        """Actor a's sampled scene parameter (`scene_param`), else `default`."""
        return scene_param(self.scene.params, self.ctx.columns[a].role, names, default)

    def lead_time(self, a: int) -> float:
        """[s] how long before meeting its partner actor a's lateral manoeuvre is under way: its sampled
        `LEAD_TIME` (a search declares it), else its draw."""
        return self.param(a, ("LEAD_TIME",), self.draws.lead[a])

    def plan_speeds(self) -> None:
        """The cruise speed each driver will hold (`_planned_speed`)."""
        ctx = self.ctx
        self.planned[:] = [_planned_speed(ctx.arrays, self.route[a], self.s0[a], self.speed[a], ctx.columns[a],
                                          ctx.cond, ctx.default_limit) for a in range(len(ctx.columns))]
        self.speeds[:] = self.planned

    def arrival_offset(self, a: int) -> float:
        """[s] actor a's arrival after the anchor at their conflict point: sampled, else drawn (narrowed in
        reproduce mode)."""
        offset = clip_scalar(self.draws.offset[a], -timing.ARRIVAL_OFFSET_MAX, timing.ARRIVAL_OFFSET_MAX)
        offset = self.param(a, ("ARRIVAL_OFFSET",), offset)
        if self.ctx.reproduce:
            offset *= timing.REPRODUCE_OFFSET_SCALE
        return offset

    def shift_start(self, a: int, shift: float) -> float | None:
        """`stations.shift_start` on this variation's rows."""
        return shift_start(self.ctx.arrays, a, self.route, self.s0, shift, self.length, self.d0)

    def start_back(self, a: int, dist: float) -> float | None:
        """`stations.start_back` on this variation's rows."""
        return start_back(self.ctx.arrays, a, self.route, self.s0, dist, self.length, self.d0)

    def stop_dist(self, a: int) -> float | None:
        """`arrivals.stop_dist` of actor a from its planned start."""
        return stop_dist(self.ctx.arrays, self.route[a], self.s0[a], self.entry_control, self.ctx.columns[a])

    def contact_area(self, a: int, b: int) -> str | None:
        """Actor a's area in its first written contact with b, None when none is written."""
        ra, rb = self.ctx.columns[a].role, self.ctx.columns[b].role
        for striking, struck, _, striking_area, struck_area in self.ctx.contacts:
            if {striking, struck} == {ra, rb}:
                return striking_area if striking == ra else struck_area
        return None

    def plan_signal_phase(self) -> None:
        """Green for the anchor's axis at its nominal arrival at its first junction (red when it runs it)."""
        ctx = self.ctx
        ra = self.route[ctx.anchor]
        entries = ctx.arrays.entry_s[ra]
        ahead = entries[np.isfinite(entries) & (entries > self.s0[ctx.anchor])]
        t_junction = (ahead[0] - self.s0[ctx.anchor]) / self.anchor_speed if len(ahead) else 5.0
        green = float(self.scene.params.get("SIGNAL_GREEN_REMAINING", self.draws.green))
        self.phase = float(signals.phase_for(np.array(t_junction), np.array(green), ctx.runs_red))


def prepare_skids(ctx: PlanContext, route: np.ndarray, s0: np.ndarray, speed: np.ndarray) -> None:
    """Integrates at once the candidate skids of every actor of a batch that may lose control
    (`lateral._plan_skid`), at the cruise speed it plans; route, s0, speed (V, A) start rows."""
    n_a = len(ctx.columns)
    skidding = [a for a in range(n_a) if any(skids_toward(ctx, a, b) for b in range(n_a) if b != a)]
    ctx.skid_paths.prepare([_planned_speed(ctx.arrays, route[v, a], s0[v, a], speed[v, a], ctx.columns[a], ctx.cond,
                                           ctx.default_limit) for v in range(route.shape[0]) for a in skidding])


def scene_param(params: dict, role: str, names: tuple[str, ...], default: float) -> float:
    """A sampled scene parameter `<role>_<NAME>` (ego's spelled EGO_<NAME>), else `default`."""
    for name in names:
        for key in (f"{role}_{name}", f"{role.upper()}_{name}"):
            if key in params:
                try:
                    return float(params[key])
                except (TypeError, ValueError):
                    break
    return float(default)


def mph(value: float | None) -> float:
    return value * MPH if value else math.nan


def _planned_speed(arrays: RouteArrays, r: int, s0: float, speed: float, col: ActorColumn, cond: float,
                   default_limit: float) -> float:
    """The cruise speed [m/s] the actor's driver will hold (capped at the condition-adjusted limit unless speeding),
    never above what its vehicle can reach (`VehicleLimits.speed_max`: the simulator clips its speed there, so a plan
    timed at a faster cruise, a speeding truck's, would arrive late)."""
    limit = arrays.speed_limit[r, min(int(s0 / ROUTE_DS), arrays.speed_limit.shape[1] - 1)]
    if np.isnan(limit):
        limit = default_limit
    if col.dispositions & SPEEDING_CODES:
        # already speeding at the start, as the driver means to (drivers.behaviors: limit + OVER_LIMIT)
        fast = speed * speed_factor(col.dispositions)
        if np.isfinite(limit) and speed > 0:
            factor = cond if Disposition.CARELESS in col.traits else 1.0
            fast = max(fast, limit * factor + OVER_LIMIT)
        cruise = max(fast, 0.5)
    else:
        cruise = max(min(speed, limit * cond) if np.isfinite(limit) else speed, 0.5)
    return min(cruise, col.limits.speed_max)
