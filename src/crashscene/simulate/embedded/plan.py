"""Timing plans of an embedded batch, per variation: when each actor starts, how fast it cruises and when its
manoeuvre triggers, so that the paths conflict as the report says (see `timing` for the kinematics), and the
signal phase that gives the anchor its green. In reproduce mode also the written crash sequence beyond its
first contact: the actors of a chain of rear-ends in the written order along their lane, a wrong-way driver in
its head-on partner's lane, and a cascade, where a third vehicle meets a car the first impact pushes or
deflects (`cascade`).

Every draw comes from the variation's own generator in a fixed order, so a plan depends only on
(scenario, seed, variation index).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from crashscene.geometry import wrap_angle
from crashscene.monitor.rules import Disposition
from crashscene.render.plan import LATERAL_BEHAVIORS, LEAD_TIME, SIGNAL_GREEN, SKID_ROTATION
from crashscene.scene import SampledScene
from crashscene.simulate.drivers.behaviors import (
    DECELERATE_RATE,
    DECELERATE_TO,
    OVER_LIMIT,
    SPEEDING_CODES,
    speed_factor,
)
from crashscene.simulate.embedded import cascade, followon, lockstep, pushchain, signals, slap, swerve, timing, touch
from crashscene.simulate.embedded import skid as skid_plan
from crashscene.simulate.embedded.control import entry_before
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS
from crashscene.units import MPH

if TYPE_CHECKING:
    from crashscene.simulate.embedded.setup import ActorColumn

VEER_BEHAVIORS = ("change_lane_left", "change_lane_right", "cross_centerline", "overtake")
DRIFT_BEHAVIORS = VEER_BEHAVIORS + ("leave_road",)  # lateral manoeuvres a driver steers (not a loss of control)
SYNC_SLACK = 0.8  # [s] an actor moved back to meet later is placed this much early (sync.Meeting slows it)
PULL_OUT_WAIT = 1.0  # [s] an actor pulling out to meet a written contact on its turn waits this long for its partner
START_MARGIN = 5.0  # [m] an actor moved back along its route stays this far from the route's start
CLIP_CLOSING = 3.0  # [m/s] a vehicle pulling out around the one ahead and clipping it comes up at least this fast
CLIP_SPEEDS = 5  # [-] partner speeds (down to the slowest of its range) a clip followed by a later contact tries
CLIP_PARTS = 8  # [-] a clip's partner may start within a step's closing further ahead, in this many parts
CLIP_STARTS = 8  # [-] pull-out starts (trigger steps) with the written clip a clip followed by a later contact tries
CHAIN_GAP = 4.0  # [m] at least this between the bumpers of actors reordered along their lane
SPEEDING_RUN = 2.0  # [s] a striker charged with speeding drives this long before its impact (rules: 1 s over)
CASCADE_SETTLE = 1.5  # [s] a striker steering to the corner it is to hit is there this long before the impact
CASCADE_LAG = 0.7  # [-] a steering driver follows its lateral reference this much slower than the reference moves
CASCADE_ACROSS = 0.9  # [-] at most this part of the way across is done before the scene starts
NEAR_ROUTE = 8.0  # [m] a pushed car further than this from a route's centre line cannot meet a car on it
CASCADE_WINDOW = 0.8  # [s] a later contact's striker arrives up to this long after the pushed car is in its path
CASCADE_CENTRAL = 2.0  # [deg] a later contact is timed where the predicted heading is this near its most central
SIDE_ALONG = 0.25  # [-] a sideswipe strikes a third car's side this part of its length ahead of its centre
STOP_DECEL = 4.0  # [m/s2] a stopping driver's braking (drivers.behaviors.DECELERATE_RATE)
STOP_NEAR_JUNCTION = 40.0  # [m] a stopping driver this close to a junction stops at its line
WRONG_WAY_LEFT = 0.4  # [lanes] a drift across several lanes starts this far short of the partner's lane
ADVANCE_MARGIN = 3.0  # [m] an actor advanced by its timing plan stays this far before its junction entry
KNOCK_HORIZON = 15.0  # [s] a knocked-aside car's first impact is looked for this long after the start
KNOCK_CLEAR = 0.5  # [m] ...and it passes the actors ahead of it in its lane this far clear


@dataclass(frozen=True)
class ClipTiming:
    """A pull-out clipping the vehicle ahead: its trigger [s] and simulator step [s], when after it they touch
    (`t_meet` [s]), its path (x, y, yaw every step after it, turning left; mirrored when `sign` is -1), the
    partner's centre ahead at the step [m] and its lateral offset from the striker's route [m]."""

    trigger: float
    t_step: float
    t_meet: float
    rows: tuple[np.ndarray, np.ndarray, np.ndarray]
    sign: float
    ahead: float
    lateral: float


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
            plan.order_chain()
        plan.plan_speeds()  # draws nothing: the draws above are the variation's first, as always
        plan.anchor_speed = float(plan.speeds[ctx.anchor])
        plan.anchor_stop = plan.stop_dist(ctx.anchor)
        for a, col in enumerate(ctx.columns):
            offset = plan.arrival_offset(a)
            if col.is_ads:
                continue
            if col.behavior in LATERAL_BEHAVIORS:
                plan.plan_lateral(a)
            elif col.behavior in ("decelerate", "stop"):
                plan.trigger[a] = plan.param(a, ("TRIGGER_TIME", "MANEUVER_TIME"), plan.draws.trigger[a])
            elif a != ctx.anchor and col.behavior != "static":
                if ctx.reproduce and col.behavior == "go_forward":
                    plan.enter_wrong_way(a)
                plan.plan_junction(a, offset)
        if ctx.reproduce:
            plan.knock_aside()
            plan.plan_cascade()
            pushchain.place_chain(plan)
        plan.plan_signal_phase()
        return plan

    # ---------------------------------------------------------------- shared steps
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
        offset = float(np.clip(self.draws.offset[a], -timing.ARRIVAL_OFFSET_MAX, timing.ARRIVAL_OFFSET_MAX))
        offset = self.param(a, ("ARRIVAL_OFFSET",), offset)
        if self.ctx.reproduce:
            offset *= timing.REPRODUCE_OFFSET_SCALE
        return offset

    def shift_start(self, a: int, shift: float) -> float | None:
        """`_shift_start` on this variation's rows."""
        return _shift_start(self.ctx.arrays, a, self.route, self.s0, shift, self.length, self.d0)

    def start_back(self, a: int, dist: float) -> float | None:
        """`_start_back` on this variation's rows."""
        return _start_back(self.ctx.arrays, a, self.route, self.s0, dist, self.length, self.d0)

    def stop_dist(self, a: int) -> float | None:
        """`stop_dist` of actor a from its planned start."""
        return stop_dist(self.ctx.arrays, self.route[a], self.s0[a], self.entry_control, self.ctx.columns[a])

    # ---------------------------------------------------------------- lateral manoeuvres
    def plan_lateral(self, a: int) -> None:
        """A lane change, centre-line crossing, overtake, loss of control or leaving the road, aimed at the
        partner's path: a sideswipe placed alongside, a sudden veer planned as a skid, else a trigger time."""
        ctx, col = self.ctx, self.ctx.columns[a]
        partner = self.lateral_partner(a)
        if partner is not None and not self.as_skid(a, partner) and self.as_skid(partner, a) \
                and self.lateral_partner(partner) == a:
            return  # the partner's loss of control is planned to meet it on its way: it holds its lane till then
        if partner is None:
            self.trigger[a] = self.param(a, ("TRIGGER_TIME", "MANEUVER_TIME"), self.draws.trigger[a])
            if col.behavior == "lose_control":
                self.lateral_target[a] = self.draws.spin[a]
            return
        other = self.scene.actors[partner]
        gap, lateral = _relative(ctx.arrays, self.route[a], self.s0[a], other.x, other.y)
        opposite = math.cos(other.yaw - self.scene.actors[a].yaw) < -0.3
        dist = self._lateral_distance(a, lateral, opposite)
        lead = self.lead_time(a)
        if col.behavior == "lose_control":
            lead = (lead - 1.4) / 1.2 * 0.6  # [-0.3, 0.3] s around reaching the partner's lane
        rate = timing.lateral_rate(col.behavior)
        p_col = ctx.columns[partner]
        if opposite and not p_col.is_ads and p_col.behavior not in LATERAL_BEHAVIORS and gap > 0:
            self._slow_oncoming(a, partner, gap, abs(dist) / rate + lead)
        contact = ctx.classes.get(frozenset((col.role, p_col.role)))
        if not opposite and contact in ("rear_end", "sideswipe") and col.behavior in VEER_BEHAVIORS \
                and self.contact_area(a, partner) in ("front", "left", "right") \
                and self._clip(a, partner, gap, contact, rate):
            return
        if contact == "sideswipe" and not opposite and col.behavior in ("change_lane_left", "change_lane_right") \
                and self._place_alongside(a, partner, gap, dist):
            return
        if self._plan_skid(a, partner, contact, gap, lateral, opposite):
            return
        if col.behavior == "lose_control":
            t_trig = timing.skid_trigger(gap, self.speeds[a], self.speeds[partner], lateral, timing.SPIN_RATE,
                                         opposite=opposite) - lead
        else:
            t_trig = timing.lateral_trigger(gap, self.speeds[a], self.speeds[partner], opposite, dist, lead, rate)
        if t_trig < 0 and col.behavior in ("cross_centerline", "overtake") and opposite:
            # too close for the whole manoeuvre: the actor is already drifting across at t = 0; several
            # lanes across (a wrong-way driver on a divided road), it has crossed all but the last part
            reach = max(abs(dist) * 0.6, abs(dist) - WRONG_WAY_LEFT * self.lane_width)
            shift = float(np.clip(-t_trig * rate, 0.0, reach)) * math.copysign(1.0, dist)
            self.d0[a] += shift
            self.drifted[a] = shift
        self.trigger[a] = max(0.0, t_trig)

    def lateral_partner(self, a: int) -> int | None:
        """The actor whose path actor a's lateral manoeuvre is aimed at: the anchor's written partner, else
        `_partner`."""
        partner = self.written_partner(a) if a == self.ctx.anchor else None
        return _partner(a, self.ctx.anchor, self.ctx.columns, self.scene) if partner is None else partner

    def as_skid(self, a: int, partner: int) -> bool:
        """Whether actor a's lateral manoeuvre toward `partner` is planned as a skid (`skids_toward`)."""
        return skids_toward(self.ctx, a, partner)

    def written_partner(self, a: int) -> int | None:
        """The other actor of actor a's first written contact, None when it has none."""
        roles = [c.role for c in self.ctx.columns]
        for striking, struck, *_ in self.ctx.contacts:
            if roles[a] in (striking, struck):
                other = struck if striking == roles[a] else striking
                return roles.index(other) if other in roles else None
        return None

    def contact_area(self, a: int, b: int) -> str | None:
        """Actor a's area in its first written contact with b, None when none is written."""
        ra, rb = self.ctx.columns[a].role, self.ctx.columns[b].role
        for striking, struck, _, striking_area, struck_area in self.ctx.contacts:
            if {striking, struck} == {ra, rb}:
                return striking_area if striking == ra else struck_area
        return None

    def _clip(self, a: int, partner: int, gap: float, contact: str, rate: float) -> bool:
        """Pulling out around the vehicle ahead and clipping it (a written rear-end or sideswipe with it): the
        manoeuvre is only partly done when it reaches the partner's rear, timed on its path (swerve.path) so that
        where they first touch the contact has the written class (skid.first_contact); when no start does,
        across by a drawn part of the overlap (a rear-end: still well behind it; a sideswipe: nearly clear).
        False when it does not close in."""
        reach = gap - (self.length[a] + self.length[partner]) / 2
        p_col = self.ctx.columns[partner]
        if reach <= 0 or p_col.is_ads:
            return False
        if self.speeds[a] - self.speeds[partner] < CLIP_CLOSING and p_col.behavior == "go_forward":
            # it came up on a slower vehicle ahead: the partner drives slower (within its range)
            self.scale[partner] = max(timing.SPEED_SCALE[0], (self.speeds[a] - CLIP_CLOSING) / self.speeds[partner])
            self.speeds[partner] = self.planned[partner] * self.scale[partner]
        closing = self.speeds[a] - self.speeds[partner]
        if closing < 0.5:
            return False
        if self.ctx.reproduce and self._clip_then_meet(a, partner, gap, contact, rate):
            return True
        timed = self._clip_on_path(a, partner, contact, rate, reach / closing)
        if timed is not None:
            self.trigger[a] = timed.trigger
            return True
        half = (self.width[a] + self.width[partner]) / 2
        u = (self.lead_time(a) - 0.8) / 1.2  # [0, 1)
        across = half * (0.15 + 0.35 * u) if contact == "rear_end" else half - 0.2 - 0.4 * u
        self.trigger[a] = max(0.0, reach / closing - across / rate)
        return True

    def _pull_out_path(self, a: int, rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Actor a's path steering to its lateral target (swerve.path), with other variations' (lockstep.run)."""
        limits = self.ctx.columns[a].limits
        offset = float(self.lateral_target[a] - self.d0[a])
        return lockstep.together(swerve.paths, [(float(self.speeds[a]), abs(offset), rate,
                                                 float(self.length[a]) * limits.wheelbase_ratio, limits.steer_rate,
                                                 limits.steer_max, self.ctx.skid_paths.dt)])[0]

    def _clip_on_path(self, a: int, partner: int, contact: str, rate: float, t_reach: float) -> ClipTiming | None:
        """The pull-out of actor a whose path (`_pull_out_path`) first touches the partner ahead (both at their
        planned speeds) with the written class, before a reaches it straight on (`t_reach` [s]): its trigger [s]
        and where they touch (`ClipTiming`); None if none."""
        found, path, relative = self._clip_searches(a, partner, contact, rate, [float(self.speeds[partner])],
                                                    [t_reach])
        return self._clip_timing(a, partner, found[0][0] if found[0] else None, path, relative)

    def _clip_searches(self, a: int, partner: int, contact: str, rate: float, partner_speeds: list[float],
                       t_reaches: list[float], count: int = 1
                       ) -> tuple[list, tuple[np.ndarray, np.ndarray, np.ndarray], tuple[float, float]]:
        """The first contacts (skid.contact_choices: up to `count` starts, the best first) of actor a's pull-out
        with the partner ahead at each of `partner_speeds` [m/s], each before a reaches it straight on (`t_reaches`
        [s]), searched at once; with a's path and the partner's place (gap, lateral [m]) relative to a's start."""
        other = self.scene.actors[partner]
        gap, lateral = _relative(self.ctx.arrays, self.route[a], self.s0[a], other.x, other.y, exact=True)
        offset = float(self.lateral_target[a] - self.d0[a])
        dt = self.ctx.skid_paths.dt
        path = self._pull_out_path(a, rate)
        wanted = skid_plan.Wanted(contact, self.contact_area(a, partner), self.contact_area(partner, a),
                                  skidder_first=a < partner)
        sign = 1.0 if offset >= 0 else -1.0
        found = skid_plan.contact_choices(path, sign, float(self.speeds[a]), gap, partner_speeds, False,
                                          lateral - float(self.d0[a]),
                                          skid_plan.Body(float(self.length[a]), float(self.width[a])),
                                          skid_plan.Body(float(self.length[partner]), float(self.width[partner])),
                                          skid_plan.CLASS_HEADING[contact], wanted, dt,
                                          latests=[t_reach - dt for t_reach in t_reaches], place=False,
                                          fine=CLIP_PARTS, count=count)
        return found, path, (gap, lateral)

    def _clip_timing(self, a: int, partner: int, found: tuple[int, float, float, float] | None,
                     path: tuple[np.ndarray, np.ndarray, np.ndarray], relative: tuple[float, float]
                     ) -> ClipTiming | None:
        """The `ClipTiming` of a first contact `found` by `_clip_searches` at the partner's present speed (its
        start moved as the contact needs); None if none or the partner cannot start there."""
        if found is None:
            return None
        gap, lateral = relative
        if found[3]:
            placed = self.shift_start(partner, found[3])
            if placed is None:
                return None
            self.s0[partner] = placed
            self.moved[partner] = True
        dt = self.ctx.skid_paths.dt
        offset = float(self.lateral_target[a] - self.d0[a])
        sign = 1.0 if offset >= 0 else -1.0
        t_step = found[1] + dt / 2 if found[1] > 0 else 0.0  # the simulator step the pull-out starts on
        ahead = gap + found[3] - (self.speeds[a] - self.speeds[partner]) * t_step
        return ClipTiming(found[1], t_step, found[2], tuple(q[0] for q in path), sign, float(ahead), float(lateral))

    def _clip_then_meet(self, a: int, partner: int, gap: float, contact: str, rate: float) -> bool:
        """A clip followed by a written contact of the striker with a third actor that drives freely straight on
        (the striker's own motion after the clip carries it there): the partner comes as much slower (within its
        range), and the pull-out starts on the one of its trigger steps whose first contact is the written clip
        (skid.contact_choices: up to CLIP_STARTS of them at each partner speed), that makes the striker's slide
        after the clip (cascade.clip_slides, the simulator's impact, upset and tyre model) meet the third actor with
        the written class, and the third actor is placed to meet it there (`_meet_at`); False when the sequence is
        another one or no such meeting is found."""
        found = self._after_clip(a, partner)
        if found is None:
            return False
        third, later = found
        ctx, cols = self.ctx, self.ctx.columns
        arrays, dt = ctx.arrays, ctx.skid_paths.dt
        lo = timing.SPEED_SCALE[0]
        best, best_score = None, (-1, -math.inf)
        saved = (self.scale[partner], self.speeds[partner], self.s0[partner], self.moved[partner])
        tried = []  # (scale, timing, the partner's shifted start) of each partner speed with a clip
        scales, t_reaches = [], []  # the partner speeds that close in, and when actor a reaches the partner
        for scale in np.linspace(float(self.scale[partner]), lo, CLIP_SPEEDS):
            closing = self.speeds[a] - self.planned[partner] * scale
            reach = gap - (self.length[a] + self.length[partner]) / 2
            if closing < 0.5 or reach <= 0:
                continue
            scales.append(scale)
            t_reaches.append(reach / closing)
        # every partner speed's first contact at once (actor a's path and the partner's place are the same)
        found, path, relative = (self._clip_searches(a, partner, contact, rate,
                                                     [float(self.planned[partner] * scale) for scale in scales],
                                                     t_reaches, CLIP_STARTS) if scales else ([], None, None))
        for scale, choices in zip(scales, found):
            for one in choices:
                self.scale[partner], self.speeds[partner] = scale, self.planned[partner] * scale
                timed = self._clip_timing(a, partner, one, path, relative)
                shifted = (self.s0[partner], self.moved[partner])
                self.s0[partner], self.moved[partner] = saved[2], saved[3]
                if timed is not None:
                    tried.append((scale, timed, shifted))
        me = (float(self.length[a]), float(self.width[a]), cols[a].limits.mass, cols[a].limits.wheelbase_ratio)
        them = (float(self.length[partner]), float(self.width[partner]), cols[partner].limits.mass,
                cols[partner].limits.wheelbase_ratio)
        # every partner speed's slide at once, with every other variation's (lockstep.run)
        slides = lockstep.together(cascade.clip_slides, [
            cascade.Clip(timed.rows, timed.sign, float(self.speeds[a]), float(self.d0[a]), timed.ahead,
                         float(self.planned[partner] * scale), timed.lateral, timed.t_meet, dt, me, them, ctx.friction)
            for scale, timed, _ in tried])
        slid = [(scale, timed, shifted, slide) for (scale, timed, shifted), slide in zip(tried, slides)
                if slide is not None]
        # where each slide starts: the striker's route at the clip's step
        px, py, pyaw = arrays.point(np.full(len(slid), self.route[a]),
                                    np.array([self.s0[a] + self.speeds[a] * timed.t_step for _, timed, _, _ in slid]))
        meetings = self._pushed_meetings(a, third, [slide[1] for *_, slide in slid],
                                         [(float(x), float(y), float(yaw)) for x, y, yaw in zip(px, py, pyaw)], later)
        for (scale, timed, shifted, (t_touch, _)), meeting in zip(slid, meetings):
            if meeting is None:
                continue
            score = (_matches(meeting, later), meeting[5])
            if score > best_score:
                best, best_score = (scale, timed, shifted, t_touch, meeting), score
        self.scale[partner], self.speeds[partner] = saved[0], saved[1]
        if best is None or best[4][2] != later[0]:
            return False
        scale, timed, shifted, t_touch, meeting = best
        if not self._place_third(third, meeting, later, timed.t_step + t_touch + (meeting[0] + 1) * cascade.DT,
                                 passing=(a,)):
            return False
        self.scale[partner], self.speeds[partner] = scale, self.planned[partner] * scale
        self.s0[partner], self.moved[partner] = shifted
        self.trigger[a] = timed.trigger
        return True

    def _after_clip(self, a: int, partner: int) -> tuple[int, tuple[str, str, str]] | None:
        """(third actor, (class, actor a's area, the third's)) of actor a's next written contact after its first one
        with `partner`, when it is with a third actor that drives freely straight on (not the ADS); else None."""
        cols, roles = self.ctx.columns, [c.role for c in self.ctx.columns]
        mine = [c for c in self.ctx.contacts if roles[a] in c[:2] and all(r in roles for r in c[:2])]
        if cols[a].is_ads or len(mine) < 2 or roles[partner] not in mine[0][:2]:
            return None
        striking, struck, *_ = mine[1]
        third = roles.index(striking if struck == roles[a] else struck)
        if third == partner or cols[third].is_ads or cols[third].behavior != "go_forward":
            return None
        return third, _later(mine[1], roles[a])

    def _lateral_distance(self, a: int, lateral: float, opposite: bool) -> float:
        """[m] how far actor a steers sideways to reach its partner's path (sets a skid's side)."""
        behavior = self.ctx.columns[a].behavior
        if behavior == "lose_control":
            self.lateral_target[a] = 1.0 if lateral >= 0 else -1.0
            return 2.5
        if behavior == "cross_centerline" and opposite and lateral > self.lateral_target[a] > 0:
            # several opposing lanes: drift as far as the oncoming partner's lane
            self.lateral_target[a] = lateral
            return lateral - self.d0[a]
        return self.lateral_target[a] - self.d0[a]

    def _slow_oncoming(self, a: int, partner: int, gap: float, needed: float) -> None:
        """Too close to swerve in time (`needed` [s]): the oncoming partner comes a little slower (within its
        range)."""
        closing = gap / needed
        if closing < self.speeds[a] + self.speeds[partner]:
            self.scale[partner] = max(timing.SPEED_SCALE[0], (closing - self.speeds[a]) / self.speeds[partner])
            self.speeds[partner] *= self.scale[partner]

    def _place_alongside(self, a: int, partner: int, gap: float, dist: float) -> bool:
        """A same-direction sideswipe: side by side when it reaches the partner's lane, so it starts where it
        will be alongside then; False when its route has no room."""
        rate = timing.lateral_rate(self.ctx.columns[a].behavior)
        t_trig = float(self.draws.trigger[a])
        touch = t_trig + max(abs(dist) - 0.5 * (self.width[a] + self.width[partner]), 0.0) / rate
        want_gap = (self.speeds[a] - self.speeds[partner]) * touch + (self.lead_time(a) - 1.4) * 1.5
        placed = self.shift_start(a, gap - want_gap)
        if placed is None:
            return False
        self.s0[a] = placed
        self.moved[a] = True
        self.trigger[a] = t_trig
        return True

    def _plan_skid(self, a: int, partner: int, contact: str | None, gap: float, lateral: float,
                   opposite: bool) -> bool:
        """A loss of control, or a lateral manoeuvre ending in an angle contact (a sudden veer), planned as a
        skid (skid.plan) into the partner; False when none fits."""
        if not self.as_skid(a, partner):
            return False
        rotation = self.param(a, ("SKID_ROTATION",), self.draws.rotation[a])  # sampled in a search, else drawn
        wanted = skid_plan.Wanted(contact, self.contact_area(a, partner), self.contact_area(partner, a),
                                  skidder_first=a < partner)
        skid = skid_plan.plan(self.ctx.skid_paths.get(self.speeds[a]), self.speeds[a], gap, self.speeds[partner],
                              opposite, lateral - self.d0[a],
                              skid_plan.Body(float(self.length[a]), float(self.width[a])),
                              skid_plan.Body(float(self.length[partner]), float(self.width[partner])),
                              skid_plan.rotation_for(contact, opposite, rotation), wanted,
                              self.ctx.skid_paths.dt, self._centre_line(a) if opposite else None)
        if skid is not None and skid.partner_shift:
            placed = self.shift_start(partner, skid.partner_shift)
            if placed is None:
                skid = None
            else:
                self.s0[partner] = placed
                self.moved[partner] = True
        if skid is None:
            return False
        self.skids[a] = (skid.spin_rate, skid.drift, skid.hold)
        self.trigger[a] = skid.trigger
        return True

    def _centre_line(self, a: int) -> float:
        """[m] the road's centre line from actor a's start, left positive (NaN on a one-way road)."""
        arrays = self.ctx.arrays
        return float(arrays.sample(arrays.centerline_offset, np.array(self.route[a]), np.array(self.s0[a]))) \
            - float(self.d0[a])

    def enter_wrong_way(self, a: int) -> None:
        """A vehicle going straight that meets its written head-on partner coming the other way in another
        lane, a partner that keeps its lane, drives against traffic in that lane (a wrong-way entry, by a
        ramp or a crossover before the scene): it starts at the partner's offset from its route and keeps it."""
        ctx, col = self.ctx, self.ctx.columns[a]
        for b, other in enumerate(ctx.columns):
            if b == a or ctx.classes.get(frozenset((col.role, other.role))) != "head_on" \
                    or other.behavior in LATERAL_BEHAVIORS:
                continue
            partner = self.scene.actors[b]
            if math.cos(partner.yaw - self.scene.actors[a].yaw) > -0.3:
                continue
            gap, lateral = _relative(ctx.arrays, self.route[a], self.s0[a], partner.x, partner.y)
            if gap <= 0 or abs(lateral - self.d0[a]) < self.lane_width / 2:
                continue
            shift = lateral - self.d0[a]
            self.d0[a] = lateral
            self.drifted[a] = shift
            self.lateral_target[a] = lateral
            return

    # ---------------------------------------------------------------- junction conflicts
    def plan_junction(self, a: int, offset: float) -> None:
        """Actor a's arrival at its conflict point with the anchor, at the anchor's arrival plus `offset` [s]
        (a written contact: when the striker's front meets the struck one's side): its speed scale and hold,
        a start further along or back on its approach, or else the anchor delayed."""
        ctx, col = self.ctx, self.ctx.columns[a]
        arrays, anchor = ctx.arrays, ctx.anchor
        r, ra = self.route[a], self.route[anchor]
        cs_a = arrays.conflict_s[r, ra]
        cs_e = arrays.conflict_s[ra, r]
        if np.isnan(cs_a) or cs_a <= self.s0[a] or cs_e <= self.s0[anchor]:
            return
        moved = self._class_meeting(a, cs_a, cs_e)
        if moved is not None:
            cs_a, cs_e = moved
        anchor_arrival = self._anchor_arrival(cs_e)
        target = anchor_arrival + self._meeting_offset(a, cs_a, cs_e, offset, None if moved is None else 0.0)
        # the first written contact's pair meets closed loop (sync.Meeting): place the free one a little early;
        # one that waits at its line to pull out (`touch_at`) is met by the other coming a little late instead
        slack = SYNC_SLACK if ctx.reproduce and ctx.first_pair == frozenset((col.role,
                                                                             ctx.columns[anchor].role)) else 0.0
        if self.pull_out is not None and {a, anchor} == {self.pull_out.actor, self.pull_out.partner}:
            slack = 0.0
            target += PULL_OUT_WAIT if self.pull_out.actor == anchor else -PULL_OUT_WAIT
        sc, hd, late = self._fit_arrival(a, cs_a, target, slack)
        if late > 0.1 and self.stop_dist(a) is None:
            late = self._advance_start(a, cs_a, sc, target, late)
        if late > 0.1:
            self._delay_anchor(cs_e, late, slack)
        self.scale[a], self.hold[a] = sc, hd
        self.conflict_time = min(self.conflict_time, self.arrival_anchor)

    def _anchor_arrival(self, cs_e: float) -> float:
        """[s] the anchor's nominal arrival at its conflict point cs_e [m] (the first one asked stays)."""
        if self.arrival_anchor is None:
            ctx = self.ctx
            anchor, anchor_col = ctx.anchor, ctx.columns[ctx.anchor]
            ra, va, anchor_stop = self.route[anchor], self.anchor_speed, self.anchor_stop
            if anchor_stop is None:
                lat_e = 2.0 if anchor_col.is_ads else 2.5
                self.arrival_anchor = ctx.arrays.travel_time(ra, self.s0[anchor], cs_e, va, lat_e, v0=va)
            else:
                v_eff = _effective_speed(ctx.arrays, ra, self.s0[anchor], cs_e, va, anchor_col)
                self.arrival_anchor = timing.arrival_time(cs_e - self.s0[anchor], v_eff, anchor_col.limits.accel_max,
                                                          stop_dist=anchor_stop)
        return self.arrival_anchor

    def _class_meeting(self, a: int, cs_a: float, cs_e: float) -> tuple[float, float] | None:
        """Reproduce mode, a written contact of actor a with the anchor whose class the routes' meeting point
        cannot give (`touch.needs_moving`: a turn into a lane meets almost aligned): (cs_a, cs_e) [m] moved to
        where the class happens on the paths they drive (`touch.class_meeting`), in `_meeting_offset`'s terms (the
        striker's front at the struck centre, no struck offset); None keeps the routes' meeting point."""
        ctx = self.ctx
        anchor = ctx.anchor
        pair = frozenset((ctx.columns[a].role, ctx.columns[anchor].role))
        striking, klass = ctx.strikers.get(pair), ctx.classes.get(pair)
        if not ctx.reproduce or striking is None:
            return None
        s_idx = a if striking == ctx.columns[a].role else anchor
        t_idx = anchor if s_idx == a else a
        cs = {a: cs_a, anchor: cs_e}
        if not touch.needs_moving(ctx.arrays, self.route[s_idx], cs[s_idx], self.route[t_idx], cs[t_idx], klass):
            return None

        lines = {i: (None if (stop := self.stop_dist(i)) is None else float(self.s0[i] + stop)) for i in cs}

        def mover(i: int) -> touch.Mover:
            rest = None if lines[i] is None else lines[i] - float(self.length[i]) / 2  # its front at its line
            return touch.Mover(int(self.route[i]), float(cs[i]), float(self.speeds[i]), rest, float(self.length[i]),
                               float(self.width[i]), ctx.columns[i].limits,
                               Disposition.NO_YIELD in ctx.columns[i].traits)

        met = touch.class_meeting(ctx.arrays, mover(s_idx), mover(t_idx),
                                  (klass, self.contact_area(s_idx, t_idx), self.contact_area(t_idx, s_idx)))
        if met is None:
            return None
        reach = float(self.length[s_idx] / 2 + self.width[t_idx] / 2)
        at = {s_idx: met.striker_s + reach, t_idx: met.struck_s}
        if pair == ctx.first_pair:
            self.touch_at = (at[s_idx], at[t_idx])
        waiting = [i for i in cs if lines[i] is not None]
        if pair == ctx.first_pair and len(waiting) == 1 and not ctx.columns[waiting[0]].is_ads:
            w = waiting[0]
            partner = t_idx if w == s_idx else s_idx
            front = (met.striker_s if partner == s_idx else met.struck_s) + float(self.length[partner]) / 2
            # released at the first step its partner is that near: on average half a step late
            tta = (met.struck_t if w == t_idx else met.striker_t) + ctx.skid_paths.dt / 2
            self.pull_out = touch.Waiting(w, partner, lines[w], front, tta, mover(w).rest,
                                          met.struck_v if w == t_idx else met.striker_v)
        return at[a], at[anchor]

    def _meeting_offset(self, a: int, cs_a: float, cs_e: float, offset: float, u: float | None = None) -> float:
        """[s] actor a's arrival after the anchor's: the turner first, and a written contact's striker's
        front at the struck one's side (`u` [m] past the striker's path, by default `struck_offset`)."""
        ctx, col = self.ctx, self.ctx.columns[a]
        arrays, anchor = ctx.arrays, ctx.anchor
        anchor_col = ctx.columns[anchor]
        r, ra = self.route[a], self.route[anchor]
        # a turning vehicle is struck on its side in its turn: it reaches the conflict point first
        turn_a = _turns_at(arrays, r, cs_a)
        turn_e = _turns_at(arrays, ra, cs_e)
        if turn_a and not turn_e:
            offset -= timing.TURNER_LEAD
        elif turn_e and not turn_a:
            offset += timing.TURNER_LEAD
        striking = ctx.strikers.get(frozenset((col.role, anchor_col.role)))
        if striking is None:
            return offset
        # the written contact says who strikes: the striker's front meets the middle of the struck one's side
        s_idx = a if striking == col.role else anchor
        t_idx = anchor if s_idx == a else a
        r_t, cs_t = (r, cs_a) if t_idx == a else (ra, cs_e)
        s_t0 = self.s0[t_idx]
        v_struck = _effective_speed(arrays, r_t, max(cs_t - 10.0, s_t0), cs_t, self.speeds[t_idx],
                                    ctx.columns[t_idx])
        r_s, cs_s = (ra, cs_e) if t_idx == a else (r, cs_a)
        if u is None and slap.slaps_after(ctx.contacts, ctx.columns[s_idx].role, ctx.columns[t_idx].role):
            u = self.slap_offset = slap.slap_offset(
                ctx.arrays, self._body(s_idx, cs_s, float(self.speeds[s_idx])),
                self._body(t_idx, cs_t, float(v_struck)), ctx.friction, ctx.skid_paths.dt)  # a side slap follows
        if u is None:
            u = struck_offset(arrays, r_t, cs_t, r_s, cs_s, float(self.length[t_idx]),
                              ctx.classes.get(frozenset((col.role, anchor_col.role))))
        side_hit = (self.length[s_idx] / 2 + self.width[t_idx] / 2) / max(self.speeds[s_idx], 1.0) \
            + u / max(v_struck, 1.0)
        jitter = offset - timing.ARRIVAL_OFFSET_MEAN * (timing.REPRODUCE_OFFSET_SCALE if ctx.reproduce else 1.0)
        return (side_hit if s_idx == a else -side_hit) + jitter

    def _body(self, i: int, meet: float, speed: float) -> slap.Body:
        """Actor i driving through station `meet` [m] of its route at `speed` [m/s] (slap)."""
        limits = self.ctx.columns[i].limits
        return slap.Body(touch.Mover(int(self.route[i]), meet, speed, None, float(self.length[i]),
                                     float(self.width[i]), limits), limits.mass)

    def _fit_arrival(self, a: int, cs_a: float, target: float, slack: float) -> tuple[float, float, float]:
        """(speed scale, hold [s], lateness [s]) that bring actor a to its conflict point cs_a [m] at `target`
        [s]: stopping at its line first and waiting there; or a cruise scale, a start further back, the
        slowest scale and a hold at its start."""
        ctx, col = self.ctx, self.ctx.columns[a]
        arrays, r = ctx.arrays, self.route[a]
        s_a, va_ = self.s0[a], self.speeds[a]
        stop = self.stop_dist(a)
        if stop is not None:
            v_eff = _effective_speed(arrays, r, s_a, cs_a, va_, col)
            sc, hd = timing.junction_plan(target, cs_a - s_a, v_eff, col.limits.accel_max, stop_dist=stop)
            # stopping at its line first, it can come late even when it does not wait at all (hd == 0)
            t_stop_go = timing.arrival_time(cs_a - s_a, v_eff, col.limits.accel_max, stop_dist=stop)
            return sc, hd, (max(0.0, t_stop_go - target) if hd == 0.0 else 0.0)
        t_at = self._travel_time(a, cs_a)
        lo, hi = timing.SPEED_SCALE
        if t_at(hi) > target:
            return hi, 0.0, t_at(hi) - target
        if t_at(lo) < target and (back := self.start_back(a, max(target - t_at(1.0) - slack, 0.0) * va_)) is not None:
            # far too early: it was further back along its approach, driving at its own speed
            self.s0[a] = back
            self.moved[a] = True
            return 1.0, 0.0, 0.0
        if t_at(lo) < target:
            lat_a = 2.0 if col.is_ads else 2.5
            return lo, max(0.0, target - arrays.travel_time(r, s_a, cs_a, va_ * lo, lat_a, v0=0.0)), 0.0
        # travel time is nearly proportional to 1/speed: two secant corrections suffice
        sc = float(np.clip(t_at(1.0) / target, lo, hi))
        for _ in range(2):
            sc = float(np.clip(sc * t_at(sc) / target, lo, hi))
        return sc, 0.0, 0.0

    def _travel_time(self, a: int, cs: float):
        """t_at(k, s_start, v_start): actor a's travel time [s] to station cs [m] at k times its planned speed."""
        arrays, r, va_ = self.ctx.arrays, self.route[a], self.speeds[a]
        lat_a = 2.0 if self.ctx.columns[a].is_ads else 2.5
        s_first = self.s0[a]

        def t_at(k: float, s_start: float = s_first, v_start: float | None = None) -> float:
            v_init = va_ * min(k, 1.0) if v_start is None else v_start
            return arrays.travel_time(r, s_start, cs, va_ * k, lat_a, v0=v_init)

        return t_at

    def _advance_start(self, a: int, cs_a: float, sc: float, target: float, late: float) -> float:
        """Even at its fastest actor a would come `late` [s]: it has already been driving for a while, so it
        starts further along its own approach (never closer than ADVANCE_MARGIN to the junction); returns what
        lateness is left."""
        arrays, r = self.ctx.arrays, self.route[a]
        t_at = self._travel_time(a, cs_a)
        va_ = self.speeds[a]
        entries = arrays.entry_s[r]
        first_entry = entries[np.isfinite(entries) & (entries > self.s0[a])]
        room = (first_entry[0] - self.s0[a] - ADVANCE_MARGIN) if len(first_entry) else 0.0
        if room <= 0:
            return late
        best = self.s0[a]
        for cand in np.linspace(self.s0[a], self.s0[a] + room, 12)[1:]:
            v_start = min(va_ * sc, max(float(arrays.curve_speed(np.array(r), np.array(cand),
                                                                 np.array(60.0), 2.5, 2.0)), 3.0))
            best = cand
            late = t_at(sc, cand, v_start) - target
            if late <= 0.05:
                break
        self.s0[a] = best
        self.moved[a] = True
        return late

    def _delay_anchor(self, cs_e: float, late: float, slack: float) -> None:
        """Reproduce mode: the scripted anchor comes `late` [s] later instead (slower, else it waits); also for
        an actor that must first stop at its line, which no advance along its approach fixes."""
        ctx = self.ctx
        anchor = ctx.anchor
        anchor_col = ctx.columns[anchor]
        if anchor_col.is_ads or anchor_col.behavior in ("static", "stop") or self.anchor_stop is not None \
                or self.hold[anchor] != 0.0:
            return
        arrays, ra, va = ctx.arrays, self.route[anchor], self.anchor_speed
        lat_e = 2.0 if anchor_col.is_ads else 2.5
        t_new = self.arrival_anchor + late
        lo, hi = timing.SPEED_SCALE[0], 1.0
        # ...placed a little early rather than late: on the way it can slow down to meet (sync), rarely speed up
        back = self.start_back(anchor, max(late - slack, 0.0) * va)
        if back is not None:
            # it started that much further back along its approach, at its own speed
            self.s0[anchor] = back
            self.moved[anchor] = True
        elif arrays.travel_time(ra, self.s0[anchor], cs_e, va * lo, lat_e, v0=va * lo) < t_new:
            self.scale[anchor] = lo
            t_rest = arrays.travel_time(ra, self.s0[anchor], cs_e, va * lo, lat_e, v0=0.0)
            self.hold[anchor] = max(0.0, t_new - t_rest)
        else:
            for _ in range(8):
                mid = (lo + hi) / 2
                t_mid = arrays.travel_time(ra, self.s0[anchor], cs_e, va * mid, lat_e, v0=va * mid)
                lo, hi = (lo, mid) if t_mid < t_new else (mid, hi)
            self.scale[anchor] = (lo + hi) / 2
        self.arrival_anchor = t_new

    # ---------------------------------------------------------------- later contacts
    def order_chain(self) -> None:
        """Written rear-ends between actors starting in one lane put each striker behind what it strikes: when
        the sampled order along the lane says otherwise, the actors of the chain take the same stations in
        the written order (the last struck in front), spaced by their lengths."""
        cols = self.ctx.columns
        roles = [c.role for c in cols]
        behind: set[tuple[int, int]] = set()
        for striking, struck, klass, *_ in self.ctx.contacts:
            if klass == "rear_end" and striking in roles and struck in roles:
                a, b = roles.index(striking), roles.index(struck)
                if _same_lane(self.route, self.d0, a, b):
                    behind.add((a, b))
        if not behind or all(self.s0[a] < self.s0[b] for a, b in behind):
            return
        chain = sorted({i for pair in behind for i in pair})
        order: list[int] = []
        while len(order) < len(chain):  # the written order, the sampled one between unrelated actors
            free = [i for i in chain if i not in order
                    and not any(b == i and a not in order for a, b in behind)]
            if not free:
                return  # the contacts contradict each other
            order.append(min(free, key=lambda i: self.s0[i]))
        stations = sorted(float(self.s0[i]) for i in chain)
        for k in range(len(order) - 2, -1, -1):  # from the front: each far enough behind the one ahead
            room = (self.length[order[k]] + self.length[order[k + 1]]) / 2 + CHAIN_GAP
            stations[k] = min(stations[k], stations[k + 1] - room)
        if stations[0] < START_MARGIN:
            return
        for i, s in zip(order, stations):
            if s != self.s0[i]:
                self.s0[i] = s
                self.moved[i] = True

    def knock_aside(self) -> None:
        """A striker that rear-ends a vehicle and then, later in the written sequence, rear-ends another one
        ahead of it in the same lane went past the first: it hits the first at a rear corner (its centre a
        fraction of that car's width off the car's, `_room_to_leave`), so that the eccentric impulse and the
        striker's continued push (a heavy striker keeps its driver, crashscene.upset) turn that car out of the lane
        and leave the way on to the next one open."""
        seq, roles = self.ctx.contacts, [c.role for c in self.ctx.columns]
        if not seq or seq[0][2] != "rear_end" or not all(r in roles for r in seq[0][:2]):
            return
        si, ti = roles.index(seq[0][0]), roles.index(seq[0][1])
        cols = self.ctx.columns
        if cols[si].is_ads or cols[si].behavior != "go_forward" or not _same_lane(self.route, self.d0, si, ti):
            return
        if not any(striking == roles[si] and struck != roles[ti] and klass == "rear_end" and struck in roles
                   and _same_lane(self.route, self.d0, ti, roles.index(struck))
                   and self.s0[roles.index(struck)] > self.s0[ti] for striking, struck, klass, *_ in seq[1:]):
            return
        drawn = 1.0 if self.draws.spin[si] > 0 else -1.0
        side, corner = self._room_to_leave(si, ti, drawn)
        target = float(self.d0[ti]) + side * corner * self.width[ti]
        self.drifted[si] += target - self.d0[si]
        self.d0[si] = target
        self.lateral_target[si] = target

    def _room_to_leave(self, si: int, ti: int, drawn: float) -> tuple[float, float]:
        """(side, corner) for the car knocked aside (ti, struck at that rear corner by si, its centre `corner` of
        ti's width off ti's): it leaves its lane only over some distance (cascade.pushed_paths, and carried on by
        a striker that keeps its driver), so the corner that takes it out of the way of the actors ahead of it in
        its lane soonest (`_lane_motion`) is chosen (the `drawn` side and cascade.CORNER when nothing is ahead
        in the way), and those actors start far enough further on that it is out of their lane before it reaches
        them."""
        cols = self.ctx.columns
        lane = [b for b in range(len(cols)) if _same_lane(self.route, self.d0, ti, b) and self.s0[b] > self.s0[ti]]
        default = (drawn, cascade.CORNER)
        times = np.arange(0.0, KNOCK_HORIZON, cascade.DT)
        s_s, _ = self._lane_motion(si, times)
        s_t, v_t = self._lane_motion(ti, times)
        hit = np.nonzero(s_s + (self.length[si] + self.length[ti]) / 2 >= s_t)[0]
        if not lane or len(hit) == 0 or hit[0] == 0:
            return default
        k1 = int(hit[0])
        choices = [default] + [(side, c) for side in (drawn, -drawn) for c in cascade.CORNERS if (side, c) != default]
        fwd, left, yaw = cascade.pushed_paths(float(self.speeds[si]), float(v_t[k1]),
                                              np.array([side * c for side, c in choices]), cols[si].limits.mass,
                                              cols[ti].limits.mass, float(self.length[si]), float(self.width[si]),
                                              float(self.length[ti]), float(self.width[ti]), self.ctx.friction,
                                              stepped=False)
        # a striker that keeps its driver (a heavy one, crashscene.upset) drives on and pushes it again: it is carried
        # on at least at the striker's speed while it is in the lane
        fwd = np.maximum(fwd, float(self.speeds[si]) * cascade.DT * np.arange(1, fwd.shape[1] + 1))
        reach_along = self.length[ti] / 2 * np.abs(np.cos(yaw)) + self.width[ti] / 2 * np.abs(np.sin(yaw))
        reach_across = self.length[ti] / 2 * np.abs(np.sin(yaw)) + self.width[ti] / 2 * np.abs(np.cos(yaw))
        deficit = np.zeros(len(choices))
        for b in lane:
            # until it is clear of b's footprint across the lane, its front stays behind b's rear
            clear = np.abs(left - (self.d0[b] - self.d0[ti])) - reach_across > self.width[b] / 2 + KNOCK_CLEAR
            s_b, _ = self._lane_motion(b, times[k1:k1 + fwd.shape[1]])
            rear_b = s_b - self.length[b] / 2 - s_t[k1]
            n = len(rear_b)
            short = fwd[:, :n] + reach_along[:, :n] + KNOCK_CLEAR - rear_b[None, :]
            before = ~np.logical_or.accumulate(clear[:, :n], axis=1)
            deficit = np.maximum(deficit, np.where(before, short, -np.inf).max(axis=1, initial=0.0))
        best = int(np.argmin(deficit))
        if deficit[best] > 0:
            for b in sorted(lane, key=lambda b: -self.s0[b]):  # the front one first: each makes room for the next
                placed = self.shift_start(b, float(deficit[best]))
                if placed is None:
                    break
                self.s0[b] = placed
                self.moved[b] = True
        return choices[best]

    def _lane_motion(self, a: int, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(station [m], speed [m/s]) of actor a at `times` [s] driving along its lane as its behaviour has it
        (its planned speed; a decelerating or stopping driver brakes from its trigger on); no car following."""
        v0, behavior = float(self.speeds[a]), self.ctx.columns[a].behavior
        if behavior == "static":
            return np.full(len(times), float(self.s0[a])), np.zeros(len(times))
        end = {"decelerate": DECELERATE_TO * v0, "stop": 0.0}.get(behavior, v0)
        rate = DECELERATE_RATE if behavior == "decelerate" else STOP_DECEL
        trig = float(self.trigger[a]) if np.isfinite(self.trigger[a]) else math.inf
        braking = np.clip(times - trig, 0.0, (v0 - end) / rate)
        speed = v0 - rate * braking
        s = self.s0[a] + v0 * np.minimum(times, trig) + (v0 * braking - rate * braking ** 2 / 2) \
            + end * np.maximum(times - trig - (v0 - end) / rate, 0.0)
        return s, speed

    def plan_cascade(self) -> None:
        """A written sequence that starts with an end-on contact (a rear-end into a stopped car, a head-on) and
        goes on with a third vehicle meeting the struck one, or the striker: the striker hits the struck car off
        its centre line, on the side that sends the one the third vehicle meets (the struck car pushed, the striker
        deflected: the impulse of cascade.pushed_paths, the simulator's impact model) so that the third vehicle
        meets it as the later contact's class says, and the third vehicle is placed to reach it just after it is
        in its path (or, with no room behind, slowed and held at its start; or beside it, when it comes alongside
        into its side: `_place_third`); a striker steering across (an overtake) is on its corner before the impact
        (`_settle_before`), one drifting (off the road, into the next lane) drifts into it (`_drift_into`)."""
        found = self._cascade_actors()
        if found is None:
            return
        si, ti, mover, xi, first_class, later = found
        head_on = first_class == "head_on"
        arrays, cols = self.ctx.arrays, self.ctx.columns
        impact = self._first_impact(si, ti, head_on)
        if impact is None:
            return
        t1, impact_s, v_t = impact
        px, py, pyaw = (float(q) for q in arrays.point(np.array(self.route[ti]), np.array(impact_s)))
        t_touch = self._touch_time(si, ti, t1, (px, py), head_on)
        x_actor = self.scene.actors[xi]
        _, lat_x = _relative(arrays, self.route[ti], self.s0[ti], x_actor.x, x_actor.y)
        preferred = -1.0 if lat_x - self.d0[ti] >= 0 else 1.0  # tried first; both sides are tried
        # a car standing still is pushed as predicted: the plan chooses how far off its centre line to hit it; one
        # that is moving (and braking for what it sees coming) is hit at the usual corner
        corners = cascade.CORNERS if v_t == 0.0 or head_on else (cascade.CORNER,)
        nxt = followon.next_contact(self, (si, ti, xi), mover, xi)  # a fourth contact after the third car's
        if nxt is not None and len(corners) > 1:
            corners = followon.CORNERS
        offsets = np.array([side * c for side in (preferred, -preferred) for c in corners])
        _, lat_s = _relative(arrays, self.route[si], self.s0[si], px, py)
        drifting = cols[si].behavior in LATERAL_BEHAVIORS and not head_on
        # every offset's push at once, with every other variation's (lockstep.run); a drifting striker comes at the
        # heading its drift has when it reaches that corner (`_drift_into`)
        approaches = [self._drift_approach(si, t1, lat_s + o * self.width[ti], t_touch) if drifting
                      else (0.0, 0.0, 0.0) for o in offsets]
        found = lockstep.together(cascade.pushes_moving if nxt is not None else cascade.pushes, [cascade.Push(
            float(self.speeds[si]), float(v_t), np.array([o + approach[2] / self.width[ti]]), cols[si].limits.mass,
            cols[ti].limits.mass,
            float(self.length[si]), float(self.width[si]), float(self.length[ti]), float(self.width[ti]),
            self.ctx.friction, head_on, (cols[si].limits.wheelbase_ratio, cols[ti].limits.wheelbase_ratio),
            self.ctx.skid_paths.dt, *approach[:2], lead=cascade.step_lead(t_touch, self.ctx.skid_paths.dt))
            for o, approach in zip(offsets, approaches)])
        fwd, left, yaw = (np.concatenate([one[0][q] for one in found]) for q in range(3))
        striker = tuple(np.concatenate([one[1][q] for one in found]) for q in range(3))
        rates = [tuple(np.concatenate([one[k][q] for one in found]) for q in range(3, 6))
                 for k in (0, 1)] if nxt is not None else None  # [m/s, m/s, rad/s] (forward, left, yaw rate)
        again = cascade.touch_again((fwd, left, yaw), striker, float(self.length[ti]), float(self.width[ti]),
                                    float(self.length[si]), float(self.width[si]))
        best, best_score = None, (-1, False, -math.inf)
        moving = (fwd, left, yaw) if mover == ti else striker
        meetings = self._pushed_meetings(mover, xi, [tuple(q[j] for q in moving) for j in range(len(offsets))],
                                         [(px, py, pyaw)] * len(offsets), later)
        # a striker drifting out of the lane ahead of it is no obstacle to a start behind it
        passing = (si,) if self.ctx.columns[si].behavior in LATERAL_BEHAVIORS else ()
        if nxt is not None:
            rate = rates[0] if mover == ti else rates[1]
            paths = [(*cascade.to_world(px, py, pyaw, moving[0][j], moving[1][j]), pyaw + moving[2][j],
                      *cascade.to_world(0.0, 0.0, pyaw, rate[0][j], rate[1][j]), rate[2][j])
                     for j in range(len(offsets))]
            alongs = followon.ALONGS if cascade.meeting_mode(later[0], later[2]) == "side" else (SIDE_ALONG,)
            choice = followon.choose(self, nxt, [(j, float(o), m, not again[j, m[0]]) for j, (o, m) in
                                                 enumerate(zip(offsets, meetings)) if m is not None],
                                     paths, t_touch, mover, xi, later, passing, alongs)
            if choice is not None:
                best = (choice.offset, *choice.meeting)
        for j, (offset, meeting) in enumerate(zip(offsets, meetings) if nxt is None else ()):
            if meeting is None:
                continue
            # the written class first, then the side of the moving car it names, then a push the striker does not
            # repeat before the meeting (a second push turns the struck car otherwise than predicted), then the
            # heading furthest inside the class's range (the least sensitive to what the plan does not foresee)
            score = (_matches(meeting, later), not again[j, meeting[0]], meeting[5])
            if score > best_score:
                best, best_score = (float(offset), *meeting), score
        if best is None:
            return
        side, k = best[:2]
        # (the options for a fourth contact were predicted from the exact time of the touch)
        along, t0 = (choice.along, t_touch) if nxt is not None else (SIDE_ALONG, t1)
        if not self._place_third(xi, best[1:], later, t0 + (k + 1) * cascade.DT, passing, along):
            return
        # the striker holds its centre off the struck car's centre line, toward the corner it hits (its own
        # left is the struck car's right when it comes the other way)
        offset = side * self.width[ti] * (-1.0 if head_on else 1.0)
        if cols[si].behavior in LATERAL_BEHAVIORS and head_on:
            self.lateral_target[si] += offset
            self._settle_before(si, t1)
        elif cols[si].behavior in LATERAL_BEHAVIORS:
            self._drift_into(si, t1, lat_s + offset)
        else:
            target = (self.lateral_target[si] if head_on else lat_s) + offset
            self.drifted[si] += target - self.d0[si]
            self.d0[si] = target
            self.lateral_target[si] = target
        if nxt is not None:  # the fourth actor, in the lane and at the time the chosen contact sends the car into
            followon.place(self, nxt, choice)

    def _touch_time(self, si: int, ti: int, t1: float, point: tuple[float, float], head_on: bool) -> float:
        """[s] when the first contact of a cascade happens (`_first_impact`'s time t1 [s], which measures the gap
        to the nearest route sample, ROUTE_DS): the gap to the struck car's centre `point` [m] measured exactly,
        closed at the striker's speed (both speeds, head-on)."""
        gap, _ = _relative(self.ctx.arrays, self.route[si], self.s0[si], *point)
        exact, _ = _relative(self.ctx.arrays, self.route[si], self.s0[si], *point, exact=True)
        closing = self.speeds[si] + (self.speeds[ti] if head_on else 0.0)
        return t1 + (exact - gap) / max(float(closing), 0.5)

    def _place_third(self, xi: int, meeting: tuple[int, float, str, str, float, float],
                     later: tuple[str, str, str], arrive: float, passing: tuple[int, ...] = (),
                     along: float = SIDE_ALONG) -> bool:
        """Actor xi placed to meet a moving actor at `arrive` [s] as `meeting` (`_pushed_meetings`) has it, as its
        written area says (cascade.meeting_mode): its front at the moving one, or (a sideswipe on its side) its
        side beside it, `along` of its length ahead of its centre (`_meet_at`); False when it cannot be."""
        return self._meet_at(xi, followon.third_reach(self, xi, meeting, later, along), arrive, passing)

    def _drift_into(self, a: int, t1: float, target: float) -> None:
        """Actor a drifts (its lateral manoeuvre, swerve.path) into the corner of a stopped car it strikes at t1 [s],
        its centre `target` [m] off its route then: the manoeuvre is under way its lead time before (less when that
        would start it outside its lane), from where it takes it to the corner."""
        k, rows, sign = self._drift_lead(a, t1, target)
        dt = self.ctx.skid_paths.dt
        across = np.abs(rows[1][0])  # [m] how far across it is every dt after its trigger
        lead = (k + 1) * dt if k >= 0 else 0.0
        shift = target - sign * (float(across[k]) if k >= 0 else 0.0) - self.d0[a]
        self.d0[a] += shift
        self.drifted[a] += shift
        self.trigger[a] = max(t1 - lead, 0.0)

    def _drift_approach(self, a: int, t1: float, target: float, touch: float) -> tuple[float, float, float]:
        """(heading off its route [rad], yaw rate [rad/s], how much further across [m] than `target` it is) of actor
        a drifting (`_drift_into`) into a corner `target` [m] off its route at t1 [s], as it touches at `touch` [s]:
        its driver starts the drift at the first simulator step at or after its trigger, so that it is where its
        drift is then, not where the plan's whole steps put it."""
        k, rows, sign = self._drift_lead(a, t1, target)
        if k < 0:
            return 0.0, 0.0, 0.0
        _, across, yaw = (q[0] for q in rows)
        dt = self.ctx.skid_paths.dt
        trigger = max(t1 - (k + 1) * dt, 0.0)
        start = math.ceil(trigger / dt - 1e-9) * dt  # [s] the step its driver sees the trigger at
        at = float(np.clip((touch - start) / dt - 1.0, -1.0, len(yaw) - 1.0))  # [steps of its path], -1: its start
        steps = np.arange(-1, len(yaw))
        heading = float(np.interp(at, steps, np.concatenate([[0.0], yaw])))
        j = int(np.clip(math.floor(at), 0, len(yaw) - 1))
        rate = float(yaw[j] - (yaw[j - 1] if j >= 1 else 0.0)) / dt
        further = float(np.interp(at, steps, np.concatenate([[0.0], across]))) - float(across[k])
        return sign * heading, sign * rate, sign * further

    def _drift_lead(self, a: int, t1: float, target: float) -> tuple[int, tuple[np.ndarray, ...], float]:
        """(the step of its path actor a is at when it strikes at t1 [s] (-1: it starts there), its drift path
        (swerve.path, turning left), the side it turns to) when it drifts into a corner `target` [m] off its route
        (`_drift_into`): its lead time, less when that would start it outside its lane."""
        rows = self._pull_out_path(a, timing.lateral_rate(self.ctx.columns[a].behavior))
        sign = 1.0 if self.lateral_target[a] >= self.d0[a] else -1.0
        across = np.abs(rows[1][0])  # [m] how far across it is every dt after its trigger
        room = max(self.lane_width - self.width[a], 0.0) / 2  # [m] its start stays within its lane
        k = int(round(min(self.lead_time(a), t1) / self.ctx.skid_paths.dt)) - 1
        while k > 0 and abs(target - sign * across[k] - self.d0[a]) > room:
            k -= 1
        return k, rows, sign

    def _meet_at(self, a: int, reach: float, arrive: float, passing: tuple[int, ...] = ()) -> bool:
        """Actor a covers `reach` [m] along its route by `arrive` [s]: it starts where that takes its own speed, else
        (no room behind) it drives slower and waits (`_arrive_later`); False when it cannot."""
        placed = _shift_start(self.ctx.arrays, a, self.route, self.s0, reach - self.speeds[a] * arrive, self.length,
                              self.d0, passing=passing)
        if placed is not None:
            self.s0[a] = placed
            self.moved[a] = True
            return True
        return self._arrive_later(a, reach, arrive)

    def _settle_before(self, a: int, t1: float) -> None:
        """Actor a steers across to its lateral target and is there CASCADE_SETTLE [s] before its impact at t1 [s]:
        it starts earlier, or is already part of the way across at the start (the corner it is to hit is further
        across than the partner's path its trigger was timed to)."""
        rate = CASCADE_LAG * timing.lateral_rate(self.ctx.columns[a].behavior)
        left = self.lateral_target[a] - self.d0[a]
        self.trigger[a] = float(np.clip(t1 - CASCADE_SETTLE - abs(left) / rate, 0.0, self.trigger[a]))
        short = abs(left) - max(t1 - CASCADE_SETTLE - self.trigger[a], 0.0) * rate
        if short > 0:
            shift = min(short, CASCADE_ACROSS * abs(left)) * math.copysign(1.0, left)
            self.d0[a] += shift
            self.drifted[a] += shift

    def _arrive_later(self, a: int, reach: float, arrive: float) -> bool:
        """Actor a, with no room to start further back, covers `reach` [m] in `arrive` [s] instead by driving
        slower (within its timing range) and, if that is not slow enough, waiting at its start; False when it
        cannot arrive in time."""
        if reach <= 0 or arrive <= 0:
            return False
        sc = reach / arrive / self.speeds[a]  # [-] on its planned speed
        if sc > timing.SPEED_SCALE[1]:
            return False
        sc = max(timing.SPEED_SCALE[0], sc)
        self.scale[a] *= sc
        self.speeds[a] *= sc
        self.hold[a] = max(0.0, arrive - reach / self.speeds[a])
        return True

    def _first_impact(self, si: int, ti: int, head_on: bool) -> tuple[float, float, float] | None:
        """(time [s], the struck actor's station [m], its speed [m/s]) of the first written contact: a rear-end
        into a stopped car (a striker charged with speeding starts far enough back to be seen speeding), or a
        head-on between two actors closing in; None when it cannot be told."""
        arrays = self.ctx.arrays
        v_s = self.speeds[si]
        l_sum = (self.length[si] + self.length[ti]) / 2
        if head_on:
            v_t = self.speeds[ti]
            other = self.scene.actors[si]
            gap, _ = _relative(arrays, self.route[ti], self.s0[ti], other.x, other.y)
            t1 = (gap - l_sum) / max(v_s + v_t, 0.5)
            return (t1, self.s0[ti] + v_t * t1, v_t) if t1 > 0 else None
        impact_s = self._stop_station(ti)
        if impact_s is None:
            return None
        px, py, _ = (float(q) for q in arrays.point(np.array(self.route[ti]), np.array(impact_s)))
        gap_s, _ = _relative(arrays, self.route[si], self.s0[si], px, py)
        t1 = (gap_s - l_sum) / max(v_s, 0.5)
        if 0 < t1 < SPEEDING_RUN and Disposition.SPEEDING in self.ctx.columns[si].traits:
            # a driver charged with speeding is seen speeding before it strikes: it started further back
            back = self.start_back(si, (SPEEDING_RUN - t1) * v_s)
            if back is not None:
                t1 = SPEEDING_RUN
                self.s0[si] = back
                self.moved[si] = True
        return (t1, impact_s, 0.0) if t1 > 0 else None

    def _pushed_meetings(self, ti: int, xi: int, paths: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                         poses: list[tuple[float, float, float]], later: tuple[str, str, str]
                         ) -> list[tuple[int, float, str, str, float, float] | None]:
        """Where the third actor xi meets actor ti moving along each `path` after an impact (cascade.pushed_paths,
        clip_slide: forward, left, yaw in the frame of its `pose`), all measured at once (each point as it would
        be alone): (step of the path, station on xi's route from its start [m] (negative: behind it, where it is
        then placed), the class of that contact, ti's area facing xi, its half extent across xi's path [m], how
        far [deg] its heading is inside the written class's range): the step where that contact has the `later`
        (class, ti's area, xi's area) written (xi met as cascade.meeting_mode says), else the one nearest a drawn
        moment in the window after ti enters xi's path (the first step it reaches xi's side, when it comes
        alongside into it); None for a path that never meets xi."""
        arrays = self.ctx.arrays
        if not paths:
            return []
        world = [cascade.to_world(px, py, pyaw, fwd, left) for (px, py, pyaw), (fwd, left, _) in zip(poses, paths)]
        sizes = [len(w[0]) for w in world]
        ends = np.cumsum(sizes)
        wx, wy = np.concatenate([w[0] for w in world]), np.concatenate([w[1] for w in world])
        yaw = np.concatenate([p[2] for p in paths])
        pyaw = lockstep.per_element((p[2] for p in poses), sizes)
        r = self.route[xi]
        xy = arrays.xy[r]
        # the nearest route point of each path point, among those within NEAR_ROUTE of its path's box: a path point
        # further than NEAR_ROUTE from xi's route cannot meet it, and any nearer one has its nearest among them
        k_route, dist = np.zeros(len(wx), dtype=np.intp), np.full(len(wx), np.inf)
        for end, size, (px, py) in zip(ends, sizes, world):
            near = np.nonzero((xy[:, 0] >= px.min() - NEAR_ROUTE) & (xy[:, 0] <= px.max() + NEAR_ROUTE)
                              & (xy[:, 1] >= py.min() - NEAR_ROUTE) & (xy[:, 1] <= py.max() + NEAR_ROUTE))[0]
            if len(near):  # else no point is near xi's route: it has no hit
                nearest, dist[end - size:end] = _nearest(xy[near], px, py)
                k_route[end - size:end] = near[nearest]
        ryaw = arrays.yaw[r, k_route]
        lat = -np.sin(ryaw) * (wx - xy[k_route, 0]) + np.cos(ryaw) * (wy - xy[k_route, 1])
        lat = np.where(dist <= NEAR_ROUTE, lat, np.inf)
        gap = k_route * ROUTE_DS - self.s0[xi]
        yaw_x = arrays.point(np.full(len(gap), r), self.s0[xi] + gap)[2]
        turned = pyaw + yaw
        rel = turned - yaw_x
        extent = self.length[ti] / 2 * np.abs(np.sin(rel)) + self.width[ti] / 2 * np.abs(np.cos(rel))
        # on its route far enough from its start for it to be placed further back to meet there
        hits = (np.abs(lat - self.d0[xi]) < self.width[xi] / 2 + extent - 0.3) \
            & (k_route * ROUTE_DS > START_MARGIN + self.length[xi])
        side = cascade.meeting_mode(later[0], later[2]) == "side"
        # the face of ti turned towards xi: xi comes from behind it, or (side) ti comes into xi's side
        toward = cascade.toward_third(yaw_x, later[2]) - math.pi if side else yaw_x
        out: list = []
        for end, size, (px, py, one_yaw) in zip(ends, sizes, poses):
            lo = end - size
            hit = np.nonzero(hits[lo:end])[0]
            if len(hit) == 0:
                out.append(None)
                continue
            at = lo + hit
            klass = cascade.contact_class(rel[at], side)
            area = cascade.facing_area(turned[at], toward[at])
            margin = cascade.class_margin(rel[at], later[0], side)
            # the steps with the written class and area (else the nearest to them), and among those the ones whose
            # heading is near the most central one: a struck car that spins fast is in the class's range only
            # briefly, and what the prediction does not foresee shifts the moment of contact
            # (then those where its centre is in xi's lane: it is in the path it meets xi in, not just reaching
            # into it; one coming alongside into xi's side touches it before it is in its lane)
            inside = side | (np.abs(lat[at] - self.d0[xi]) < self.lane_width / 2)
            # (class, area, inside) misses as one number ordered as the tuples are
            group = 4 * (klass != later[0]) + 2 * (area != later[1]) + ~inside
            best = group.min()
            central = margin[group == best].max() - CASCADE_CENTRAL
            # ...as soon as it reaches xi's side (later it would be inside xi's body), else at a drawn moment
            want = hit[0] + (0.0 if side else self.draws.cascade[xi] * CASCADE_WINDOW / cascade.DT)
            i = int(np.lexsort((np.abs(hit - want), margin < central, group))[0])  # the first of the smallest keys
            k = int(hit[i])
            out.append((k, float(gap[lo + k]), str(klass[i]), str(area[i]), float(extent[lo + k]), float(margin[i])))
        return out

    def _cascade_actors(self) -> tuple[int, int, int, int, str, tuple[str, str, str]] | None:
        """(striker, struck, the one of them that meets a third actor next, the third actor, first class, (later
        class, the mover's area in it, the third's)) of a written end-on first contact (a rear-end into a stopped
        car, a head-on) followed by a contact of either of its two actors with a third one that drives freely
        straight on (the struck car pushed into its path, or the striker deflected into it); else None."""
        seq = self.ctx.contacts
        cols = self.ctx.columns
        roles = [c.role for c in cols]
        if len(seq) < 2 or seq[0][2] not in ("rear_end", "head_on") \
                or not all(r in roles for c in seq for r in c[:2]):
            return None
        si, ti = roles.index(seq[0][0]), roles.index(seq[0][1])
        for later_contact in seq[1:]:
            striking, struck = later_contact[:2]
            pair = {striking, struck}
            if (roles[ti] in pair) != (roles[si] in pair):
                mover = ti if roles[ti] in pair else si
                xi = roles.index((pair - {roles[mover]}).pop())
                later = _later(later_contact, roles[mover])
                break
        else:
            return None
        if cols[si].is_ads or cols[xi].is_ads or cols[xi].behavior != "go_forward":
            return None
        # a rear-end into a stopped car, by a driver going straight on or drifting into it (not one whose loss of
        # control is planned as a skid)
        if seq[0][2] == "rear_end" and (cols[si].behavior not in ("go_forward", *DRIFT_BEHAVIORS)
                                        or cols[ti].behavior not in ("stop", "static")):
            return None
        if seq[0][2] == "head_on" and (cols[ti].is_ads or cols[ti].behavior != "go_forward"
                                       or cols[si].behavior not in ("go_forward", "overtake", "cross_centerline")):
            return None
        return si, ti, mover, xi, seq[0][2], later

    def _stop_station(self, a: int) -> float | None:
        """[m] where a stopping (or static) actor stands still: after its trigger and braking, or at its line."""
        v = self.speeds[a]
        if self.ctx.columns[a].behavior == "static":
            return float(self.s0[a])
        trig = self.trigger[a]
        if not np.isfinite(trig):
            return None
        s = self.s0[a] + v * trig + v * v / (2 * STOP_DECEL)
        entries = self.ctx.arrays.entry_s[self.route[a]]
        ahead = entries[np.isfinite(entries) & (entries > self.s0[a])]
        if len(ahead) and ahead[0] - self.s0[a] < s - self.s0[a] + STOP_NEAR_JUNCTION:
            s = min(s, ahead[0] - 1.0 - self.length[a] / 2)
        return float(s)

    # ---------------------------------------------------------------- signals
    def plan_signal_phase(self) -> None:
        """Green for the anchor's axis at its nominal arrival at its first junction (red when it runs it)."""
        ctx = self.ctx
        ra = self.route[ctx.anchor]
        entries = ctx.arrays.entry_s[ra]
        ahead = entries[np.isfinite(entries) & (entries > self.s0[ctx.anchor])]
        t_junction = (ahead[0] - self.s0[ctx.anchor]) / self.anchor_speed if len(ahead) else 5.0
        green = float(self.scene.params.get("SIGNAL_GREEN_REMAINING", self.draws.green))
        self.phase = float(signals.phase_for(np.array(t_junction), np.array(green), ctx.runs_red))


CLASS_RELATIVE = {"angle": math.pi / 2}  # [rad] relative heading at contact the class is judged by (rules.md)


def struck_offset(arrays: RouteArrays, r_t: int, cs_t: float, r_s: int, cs_s: float, length_t: float,
                  contact_class: str | None) -> float:
    """How far [m] past the striker's path the struck actor's centre is when the striker's front meets its side:
    where along its body the heading relative to the striker is closest to the class's (an angle contact: the
    part of a turn that is most nearly square to the striker); a quarter length behind the middle otherwise."""
    default = length_t / 4
    target = CLASS_RELATIVE.get(contact_class or "")
    if target is None:
        return default
    reach = max(length_t / 2 - 0.6, 0.0)
    u = np.linspace(-reach, reach, 9)
    n = arrays.yaw.shape[1] - 1
    k = np.clip(((cs_t + u) / ROUTE_DS).astype(int), 0, n)
    yaw_s = arrays.yaw[r_s, min(int(cs_s / ROUTE_DS), n)]
    rel = np.abs(wrap_angle(arrays.yaw[r_t, k] - yaw_s))
    miss = np.abs(rel - target) + 0.02 * np.abs(u - default)
    return float(u[int(np.argmin(miss))])


def skids_toward(ctx: PlanContext, a: int, partner: int) -> bool:
    """Whether actor a's lateral manoeuvre toward `partner` is planned as a skid: a loss of control, or a
    sudden veer (a lateral manoeuvre ending in an angle contact) toward a partner not losing control."""
    col, p_col = ctx.columns[a], ctx.columns[partner]
    if col.is_ads or col.behavior not in LATERAL_BEHAVIORS:
        return False
    contact = ctx.classes.get(frozenset((col.role, p_col.role)))
    return col.behavior == "lose_control" or (contact == "angle" and col.behavior in VEER_BEHAVIORS
                                              and p_col.behavior != "lose_control")


def prepare_skids(ctx: PlanContext, route: np.ndarray, s0: np.ndarray, speed: np.ndarray) -> None:
    """Integrates at once the candidate skids of every actor of a batch that may lose control
    (`VariationPlan._plan_skid`), at the cruise speed it plans; route, s0, speed (V, A) start rows."""
    n_a = len(ctx.columns)
    skidding = [a for a in range(n_a) if any(skids_toward(ctx, a, b) for b in range(n_a) if b != a)]
    ctx.skid_paths.prepare([_planned_speed(ctx.arrays, route[v, a], s0[v, a], speed[v, a], ctx.columns[a], ctx.cond,
                                           ctx.default_limit) for v in range(route.shape[0]) for a in skidding])


def _nearest(xy: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index, distance [m]) of the nearest of the points `xy` (K, 2) to each point (x, y) (N,): the first of
    the smallest `np.hypot` distances, as `argmin` over them all gives it. Only the few points whose squared
    distance is within rounding of the smallest are measured with `hypot` (a squared distance is off by a few
    ulps at most, so the nearest is always among them)."""
    dx, dy = xy[None, :, 0] - x[:, None], xy[None, :, 1] - y[:, None]
    squared = dx * dx + dy * dy
    rows, cols = np.nonzero(squared <= squared.min(axis=1, keepdims=True) * (1.0 + 1e-9) + 1e-300)
    dist = np.hypot(dx[rows, cols], dy[rows, cols])
    first = np.lexsort((cols, dist, rows))  # by point, then distance, then index
    take = first[np.r_[True, rows[first][1:] != rows[first][:-1]]] if len(rows) else rows  # each point's first
    if len(take) != len(x):  # a NaN point: every distance, as argmin takes them
        full = np.hypot(dx, dy)
        nearest = np.argmin(full, axis=1)
        return nearest, full[np.arange(len(x)), nearest]
    return cols[take], dist[take]


def _later(contact: tuple[str, str, str, str, str], mover: str) -> tuple[str, str, str]:
    """A written later contact (striking, struck, class, striking area, struck area) as a meeting plan reads it:
    (class, the area of the actor `mover` (the role a contact before set moving), the area of the other one)."""
    striking, struck, klass, striking_area, struck_area = contact
    return (klass, striking_area, struck_area) if striking == mover else (klass, struck_area, striking_area)


def _matches(meeting: tuple[int, float, str, str, float, float], later: tuple[str, str, str]) -> int:
    """How well a predicted meeting (`VariationPlan._pushed_meetings`) has the written later contact (class, area):
    2 for the class, plus 1 for the area."""
    return 2 * (meeting[2] == later[0]) + (meeting[3] == later[1])


def _same_lane(route: np.ndarray, d0: np.ndarray | None, a: int, b: int) -> bool:
    """Whether actors a and b start in the same lane (same route, lateral offsets within a lane); (A,) rows."""
    return b != a and route[b] == route[a] and (d0 is None or abs(d0[b] - d0[a]) < 2.0)


def _shift_start(arrays: RouteArrays, a: int, route: np.ndarray, s0: np.ndarray, shift: float,
                 length: np.ndarray, d0: np.ndarray | None = None, passing: tuple[int, ...] = ()) -> float | None:
    """Station `shift` [m] along actor a's route from its start (negative: back), if the route has room and
    no other actor on the same route is in the way; else None."""
    if shift < 0:
        return _start_back(arrays, a, route, s0, -shift, length, d0, passing)
    new = s0[a] + shift
    if new > arrays.length[route[a]] - 100.0:
        return None
    for b in range(len(route)):
        if _same_lane(route, d0, a, b) and s0[a] < s0[b] < new + (length[a] + length[b]) / 2 + 4.0:
            return None
    return float(new)


def _start_back(arrays: RouteArrays, a: int, route: np.ndarray, s0: np.ndarray, dist: float,
                length: np.ndarray, d0: np.ndarray | None = None, passing: tuple[int, ...] = ()) -> float | None:
    """Station `dist` [m] behind actor a's start on its route, if the route has room and no other actor on the
    same route is within a car length and a margin of the new start, or between the two (unless it is
    `passing`: leaving the lane); else None. (A,) rows of one variation."""
    new = s0[a] - dist
    if new < START_MARGIN:
        return None
    for b in range(len(route)):
        if _same_lane(route, d0, a, b) and (abs(s0[b] - new) < (length[a] + length[b]) / 2 + 4.0
                                            or (new < s0[b] < s0[a] and b not in passing)):
            return None
    return float(new)


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
    """The cruise speed [m/s] the actor's driver will hold (capped at the condition-adjusted limit unless speeding)."""
    limit = arrays.speed_limit[r, min(int(s0 / ROUTE_DS), arrays.speed_limit.shape[1] - 1)]
    if np.isnan(limit):
        limit = default_limit
    if col.dispositions & SPEEDING_CODES:
        # already speeding at the start, as the driver means to (drivers.behaviors: limit + OVER_LIMIT)
        fast = speed * speed_factor(col.dispositions)
        if np.isfinite(limit) and speed > 0:
            factor = cond if Disposition.CARELESS in col.traits else 1.0
            fast = max(fast, limit * factor + OVER_LIMIT)
        return max(fast, 0.5)
    return max(min(speed, limit * cond) if np.isfinite(limit) else speed, 0.5)


def _effective_speed(arrays: RouteArrays, r: int, s0: float, s1: float, speed: float, col: ActorColumn) -> float:
    """Average speed [m/s] from s0 to s1, slowing in curves as the driver will (not when careless)."""
    if s1 <= s0 or Disposition.CARELESS in col.traits:
        return speed
    lat = 2.0 if col.is_ads else 2.5
    return (s1 - s0) / max(arrays.travel_time(r, s0, s1, speed, lat), 1e-3)


def _turns_at(arrays: RouteArrays, r: int, s: float) -> bool:
    """Whether route r turns (left, right, U) at the junction containing station s."""
    j = entry_before(arrays, r, s)
    return j is not None and int(arrays.entry_maneuver[r, j]) in (2, 3, 4)


def stop_dist(arrays: RouteArrays, r: int, s0: float, entry_control: np.ndarray, col: ActorColumn) -> float | None:
    """Distance [m] to the stop line of a stop-controlled first junction the actor will stop at, else None."""
    entries = arrays.entry_s[r]
    idx = np.nonzero(entries > s0)[0]
    if len(idx) == 0 or entry_control[r, idx[0]] != 2 or Disposition.RUNS_STOP in col.traits:
        return None
    return float(entries[idx[0]] - s0 - 1.0)


def _partner(a: int, anchor: int, columns: list[ActorColumn], scene: SampledScene) -> int | None:
    """The actor whose path a lateral manoeuvre of actor a is aimed at."""
    if a != anchor:
        return anchor
    me = scene.actors[a]
    behavior = columns[a].behavior
    best, best_dist = None, math.inf
    for b, other in enumerate(scene.actors):
        if b == a:
            continue
        opposite = math.cos(other.yaw - me.yaw) < -0.3
        if behavior in ("cross_centerline", "overtake", "lose_control") and not opposite:
            continue
        dist = math.hypot(other.x - me.x, other.y - me.y)
        if dist < best_dist:
            best, best_dist = b, dist
    if best is None and len(scene.actors) > 1:
        best = next(b for b in range(len(scene.actors)) if b != a)
    return best


def _relative(arrays: RouteArrays, r: int, s: float, x: float, y: float, exact: bool = False
              ) -> tuple[float, float]:
    """(gap along route r from station s to the point, lateral offset of the point) [m]; the gap to the nearest
    route sample (ROUTE_DS), or with `exact` to the point's own projection on the route."""
    xy = arrays.xy[r]
    k = int(np.argmin(np.hypot(xy[:, 0] - x, xy[:, 1] - y)))
    yaw = arrays.yaw[r, k]
    dx, dy = x - xy[k, 0], y - xy[k, 1]
    lateral = -math.sin(yaw) * dx + math.cos(yaw) * dy
    along = math.cos(yaw) * dx + math.sin(yaw) * dy if exact else 0.0
    return k * ROUTE_DS + along - s, lateral
