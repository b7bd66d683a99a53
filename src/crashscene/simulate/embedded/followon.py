"""The written contact after a cascade's later one: the car that later contact sets moving (spun by a sideswipe,
pushed by a rear-end) meets a fourth vehicle, and the cascade plan chooses its options by it.

A cascade plan (`cascade_plan.plan_cascade`) chooses where its striker hits the first car (the corner) and
where along the third car's side the deflected car strikes it (`ALONGS`), by the third car's meeting alone. When the
written sequence goes on with a contact of the third car (or of the deflected one) with a fourth vehicle that drives
straight on, the motion that contact leaves decides whether the sequence can follow: a sideswipe on the third car's
front quarter spins it one way, one further back the other way, and it slides into the lanes beside it or not.
`predict` steps each candidate's contact as the simulator steps it (`rollout`, from a simulator step before the
touch: the deflected car already sliding from its first impact, the third car driven), and `lanes` lists where the
fourth vehicle may drive: its own lane and, when it starts in a lane beside the third car, the lanes further out on
that side (dsl.md: `left|right` is the adjacent lane or that side). The plan then takes the candidate whose
predicted slide meets the fourth vehicle with the written class and areas, and places the fourth vehicle in that
lane, timed to meet it there. When the fourth vehicle starts in the outermost lane, the lanes between it and the third
car can only grow the other way: `group_shifts` lists how far the cascade's three may start further from it (each
keeps its written side of the others), and the cascade plan plans them there too when its plan where they are does not
have the written fourth contact (a car spun by a sideswipe turns through a head-on's 150 deg only after it has slid
more than a lane across: in 3-C1-2017-001, seed 7, none of the 49 variations with the fourth car in the outermost
lane, one lane over, reproduced (their best candidates had the spun car turned 130-160 deg while within reach of that
lane), 35 of the 51 where it may drive two lanes over did).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from crashscene.geometry import footprints_overlap, pose_class, touch_fraction
from crashscene.simulate.drivers.behaviors import EDGE_TARGETS
from crashscene.simulate.embedded import cascade, lockstep, rollout
from crashscene.simulate.embedded.meetings import (
    CLASS_MATCH,
    along_route,
    later_terms,
    matches,
    meetings_along,
    place_third,
    third_reach,
)
from crashscene.simulate.embedded.stations import relative_to_route
from crashscene.simulate.roads import ROUTE_DS

if TYPE_CHECKING:
    from crashscene.simulate.embedded.plan import VariationPlan

CORNERS = tuple(round(0.05 + 0.025 * i, 3) for i in range(23))  # [-] the striker's centre off the struck car's,
# as a fraction of its width (cascade.CORNERS), tried when a fourth contact must follow: a smaller offset deflects
# the striker less, so that it comes alongside the third car more or less far forward; every 0.025 from 0.05 to 0.6,
# as the outcome of an offset impact turns over a few hundredths of the width (`steady`: the finer the grid, the
# more candidates are steady; 3-C1-2017-001, seed 7: 0.74 at the earlier 0.05 steps, 0.78 at 0.025, 0.76 at 0.0125)
ALONGS = (-0.15, -0.05, 0.05, 0.15, 0.25, 0.35, 0.45)  # [-] where along the third car's side (a fraction of its
# length ahead of its centre) the deflected car first reaches it (meetings.SIDE_ALONG without a fourth contact)
HORIZON = 4.0  # [s] the third car's motion after the contact is followed this long
SPREAD = 0.15  # [m] the third car is also tried this much further back and ahead at the touch (`choose`)
APPROACH_SHAKE = 0.01  # [rad] how far a drifting striker's heading at the touch may be off the plan's: its driver
# follows its lateral reference by pure pursuit, the plan's drift path (swerve.path) approximately (3-C1-2017-001:
# about 0.015 rad at the touch)
LEAD_SHAKE = 0.01  # [s] how far the touch may come earlier or later within the simulator's step than planned (0.3 m
# at highway speed: the plan measures gaps to its route samples)
STEADY_MISS = 0.5  # [m] a moving car predicted this much elsewhere at its meeting when the impact comes a little
# otherwise (APPROACH_SHAKE, LEAD_SHAKE) is not steady: a quarter of a car's width, beyond which a sideswipe's
# overlap is gone or doubled
STEADY_AFTER = 0.5  # [s] ...from its meeting step on this long (a sideswipe goes on while the two are alongside)
APART_STEPS = 5  # [-] simulator steps a prediction may start earlier than the meeting (`_apart`)
AIM_MISS = 0.3  # [m] a fourth actor is aimed at the moving car when its lane lets it drive this near its centre


@dataclass(frozen=True)
class Next:
    """The written contact after the later one: the fourth actor `actor`, the one of the later contact's two it
    meets (`moving`), and that contact as a meeting plan reads it (class, moving's area, the fourth's area)."""

    actor: int
    moving: int
    later: tuple[str, str, str]


@dataclass(frozen=True)
class Touch:
    """A candidate later contact to predict: the deflected car (`mover`) sliding with pose (x, y, yaw) [m, rad]
    and velocity (vx, vy, yaw rate) [m/s, rad/s] a simulator step before the touch, and the third car driven
    straight on at `speed` [m/s] from pose (x, y, yaw); sizes [m], masses [kg], wheelbases [m] of both."""

    mover_pose: tuple[float, float, float]
    mover_motion: tuple[float, float, float]
    third_pose: tuple[float, float, float]
    speed: float
    mover_body: tuple[float, float, float, float]  # length, width, mass, wheelbase
    third_body: tuple[float, float, float, float]
    friction: float
    dt: float  # [s] the simulator's step


def next_contact(plan: VariationPlan, planned: tuple[int, ...], mover: int, third: int) -> Next | None:
    """The written contact right after the one between `mover` and `third` (the cascade's later contact), when it
    is between one of them and an actor not yet `planned` that drives freely straight on; else None."""
    seq, cols = plan.ctx.contacts, plan.ctx.columns
    roles = [c.role for c in cols]
    pair = {roles[mover], roles[third]}
    at = [j for j, c in enumerate(seq) if j > 0 and {c[0], c[1]} == pair]
    if not at or at[0] + 1 >= len(seq):
        return None
    striking, struck = seq[at[0] + 1][:2]
    if striking not in roles or struck not in roles:
        return None
    ones = [a for a in (mover, third) if roles[a] in (striking, struck)]
    if len(ones) != 1:
        return None
    moving = ones[0]
    nxt = roles.index(striking if roles[moving] == struck else struck)
    if nxt in planned or cols[nxt].is_ads or cols[nxt].behavior != "go_forward":
        return None
    return Next(nxt, moving, later_terms(seq[at[0] + 1], roles[moving]))


def lanes(plan: VariationPlan, nxt: int, beside: int) -> list[float]:
    """[m] the lateral shifts of actor nxt's start its written position allows: none, and when it starts in a lane
    beside actor `beside`'s, one lane width for each lane of its carriageway further out on that side
    (PlanContext.lanes_beside)."""
    side = _side(plan, nxt, beside)
    count = _lanes_out(plan, nxt, side) if side else 0
    return [0.0] + [side * plan.lane_width * (i + 1) for i in range(count)]


def group_shifts(plan: VariationPlan, nxt: int, group: tuple[int, ...]) -> list[float]:
    """[m] the lateral shifts the actors of `group` (the cascade's three: striker, struck, third, the last one the
    car the fourth actor `nxt` meets) may take together, away from the side nxt starts on: one lane width for each
    lane of the carriageway that every one of them has on that side (PlanContext.lanes_beside). The written
    relations stay true (each keeps its side of the others; dsl.md: `left|right` is the adjacent lane or that
    side), and the fourth actor is one lane further away for each, as `lanes` moves it further out when its own
    side has room: a car spun across the lanes (the third, by a sideswipe) turns through its written heading only
    after it has crossed so many lanes."""
    side = _side(plan, nxt, group[-1])
    if not side:
        return []
    count = min(_lanes_out(plan, a, -side) for a in group)
    return [-side * plan.lane_width * (i + 1) for i in range(count)]


def _side(plan: VariationPlan, nxt: int, beside: int) -> float:
    """1 when actor nxt starts in a lane on the left of actor `beside`'s, -1 on its right, 0 in the same lane."""
    other = plan.scene.actors[beside]
    _, lat = relative_to_route(plan.ctx.arrays, plan.route[nxt], plan.s0[nxt], other.x, other.y)
    across = float(plan.d0[nxt]) - (lat + float(plan.drifted[beside]))  # [m] how far nxt is on beside's left
    if abs(across) < plan.lane_width / 2:
        return 0.0
    return 1.0 if across > 0 else -1.0


def _lanes_out(plan: VariationPlan, a: int, side: float) -> int:
    """How many same-direction lanes lie beyond actor a's start lane on `side` (1: left, -1: right)."""
    arrays, table = plan.ctx.arrays, plan.ctx.lanes_beside
    if table is None or not len(table):
        return 0
    lane = int(arrays.lane[plan.route[a], min(int(plan.s0[a] / ROUTE_DS), arrays.lane.shape[1] - 1)])
    return int(table[lane, 0 if side > 0 else 1]) if lane >= 0 else 0


def shift_across(plan: VariationPlan, actors: tuple[int, ...], shift: float) -> None:
    """The actors' starts moved `shift` [m] across their routes (drifted across: plan.drifted), and the lateral
    targets that are offsets from their lanes with them (a driver leaving the road steers to the road's edge,
    setup._set_lateral_targets, which does not move)."""
    for a in actors:
        names = ("d0", "drifted") if plan.ctx.columns[a].behavior in EDGE_TARGETS else ("d0", "lateral_target",
                                                                                         "drifted")
        for name in names:
            getattr(plan, name)[a] += shift


Path = tuple[np.ndarray, np.ndarray, np.ndarray]  # (x, y, yaw) every cascade.DT [m, m, rad], world coordinates


def predict(touches: list[Touch]) -> list[tuple[Path, float, Path, tuple[float, ...]] | None]:
    """Each candidate's contact stepped as the simulator steps it (`rollout.stepped`, computed for every candidate
    of every variation at once: lockstep): the third car's path after the touch, the touch's time [s] after the
    candidate's start, the deflected car's path, and the poses the simulator records the touch at (x, y, yaw of
    the deflected car, then of the third: `touch_class`); None where they do not touch."""
    return lockstep.together(_predict, touches)


def touch_class(plan: VariationPlan, mover: int, third: int, poses: tuple[float, ...]) -> str:
    """The class the monitor gives a contact between actors `mover` and `third` recorded at `poses` (x, y, yaw
    [m, m, rad] of the mover, then of the third; `predict`): geometry.pose_class, the monitor's own, with the
    earlier actor of the pair first (side to side where the longitudinal gap is not the nearer to touching)."""
    (a, pa), (b, pb) = sorted(((mover, poses[:3]), (third, poses[3:])), key=lambda q: q[0])
    one = (np.array([v], dtype=float) for v in (*pa, plan.length[a], plan.width[a], *pb, plan.length[b],
                                                 plan.width[b]))
    return str(pose_class(*one)[0][0])


def _predict(touches: list[Touch]) -> list[tuple[Path, float, Path, tuple[float, ...]] | None]:
    """`predict` of all the items at once (each element computed as it would be alone)."""
    if not touches:
        return []
    out: list = [None] * len(touches)
    steps = int(HORIZON / cascade.DT)
    for dt in sorted({t.dt for t in touches}):
        rows = [i for i, t in enumerate(touches) if t.dt == dt]
        sel = [touches[i] for i in rows]

        def col(values) -> np.ndarray:
            return np.array(list(values), dtype=float)

        n = len(sel)
        (mx, my, myaw), (mvx, mvy, mw) = ([col(t.mover_pose[j] for t in sel) for j in range(3)],
                                          [col(t.mover_motion[j] for t in sel) for j in range(3)])
        tx, ty, tyaw = (col(t.third_pose[j] for t in sel) for j in range(3))
        speed = col(t.speed for t in sel)
        ml, mwd, mm, mwb = (col(t.mover_body[j] for t in sel) for j in range(4))
        tl, twd, tm, twb = (col(t.third_body[j] for t in sel) for j in range(4))
        free = np.ones(n, dtype=bool)
        mover = rollout.Bodies(mx, my, myaw, mvx, mvy, mw, ml, mwd, mm, mwb, free, np.zeros(n))
        third = rollout.Bodies(tx, ty, tyaw, speed * np.cos(tyaw), speed * np.sin(tyaw), np.zeros(n), tl, twd, tm,
                               twb, np.zeros(n, dtype=bool), np.zeros(n))
        sliding = np.stack([free, np.zeros(n, dtype=bool)])
        pa, pb, first, at = rollout.stepped(mover, third, col(t.friction for t in sel), dt, steps, cascade.DT,
                                            sliding, recorded=True)
        for j, i in enumerate(rows):
            if np.isfinite(first[j]):
                out[i] = ((pb[0][j], pb[1][j], pb[2][j]), float(first[j]), (pa[0][j], pa[1][j], pa[2][j]),
                          tuple(at[:, j].tolist()))
    return out


def steady(items: list[cascade.Push], moving: tuple[np.ndarray, ...], striker: bool, steps: list[int | None]
           ) -> list[bool]:
    """Whether each first impact of `items` (cascade.Push, one offset each) sends the car that meets the third
    (`moving`: its forward, left (N, steps) in the struck car's frame, as the items' pushes predicted it; the
    striker's when `striker`, else the struck car's) to within STEADY_MISS of where it is predicted at its meeting
    step (`steps`, None: no meeting) also when the striker comes APPROACH_SHAKE more or less turned, or the touch
    LEAD_SHAKE earlier or later in the simulator's step: an offset impact whose contacts can throw the striker
    either way (cascade's module docstring) does so on less than the plan can foresee."""
    shakes = [(-APPROACH_SHAKE, 0.0), (APPROACH_SHAKE, 0.0), (0.0, -LEAD_SHAKE), (0.0, LEAD_SHAKE)]
    shaken = [replace(p, approach=p.approach + da, lead=float(np.clip(p.lead + dl, 1e-3, p.dt)))
              for p, k in zip(items, steps) if k is not None for da, dl in shakes]
    found = lockstep.together(cascade.pushes_moving, shaken)
    out, i = [], 0
    for j, k in enumerate(steps):
        if k is None:
            out.append(False)
            continue
        miss = 0.0
        end = k + int(round(STEADY_AFTER / cascade.DT)) + 1
        for one in found[i:i + len(shakes)]:
            path = one[1 if striker else 0]
            miss = max(miss, float(np.max(np.hypot(path[0][0][k:end] - moving[0][j][k:end],
                                                   path[1][0][k:end] - moving[1][j][k:end]))))
        i += len(shakes)
        out.append(miss <= STEADY_MISS)
    return out


def mover_states(paths: np.ndarray, rows: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The poses (x, y, yaw) and motions (vx, vy, yaw rate), (3, N) each, of vehicles moving along `paths` (M, 6,
    steps: world x, y, yaw, vx, vy, yaw rate every cascade.DT; yaw continuous, np.unwrap) at step `k` (N,)
    (fractional: linear between steps) of paths `rows` (N,)."""
    last = paths.shape[2] - 1
    k = np.clip(k, 0.0, last)
    i0 = np.minimum(k.astype(np.intp), last - 1)
    f = k - i0
    before, after = paths[rows, :, i0], paths[rows, :, i0 + 1]  # (N, 6)
    at = (before + f[:, None] * (after - before)).T
    return at[:3], at[3:]


def route_poses(plan: VariationPlan, a: int, station: np.ndarray, lateral: float) -> np.ndarray:
    """World poses (3, N) [m, m, rad] of the points `lateral` [m] left of actor a's route at stations `station`
    (N,) [m] (`route_pose` of each)."""
    px, py, pyaw = plan.ctx.arrays.point(np.full(len(station), plan.route[a]), station)
    return np.stack([px - np.sin(pyaw) * lateral, py + np.cos(pyaw) * lateral, pyaw])


def route_pose(plan: VariationPlan, a: int, station: float, lateral: float) -> tuple[float, float, float]:
    """World pose [m, m, rad] of a point `lateral` [m] left of actor a's route at `station` [m] (`route_poses`)."""
    return tuple(route_poses(plan, a, np.array([station], dtype=float), lateral)[:, 0].tolist())


@dataclass(frozen=True)
class Choice:
    """The cascade's options chosen for a fourth contact: the striker's corner (`offset`, row `row` of the
    candidates), where along the third car's side the deflected car reaches it (`along`), the third car's
    meeting (meetings.pushed_meetings), and the fourth actor's lateral shift [m], meeting and arrival [s] (None when
    no candidate's predicted motion meets it)."""

    row: int
    offset: float
    along: float
    meeting: tuple
    shift: float = 0.0
    follow: tuple | None = None
    arrive: float = 0.0
    key: tuple = ()  # how well it has the written contacts (`choose`'s order: larger is better)


def choose(plan: VariationPlan, nxt: Next, candidates: list[tuple[int, float, tuple, bool, bool]],
           paths: list[tuple[np.ndarray, ...]], t1: float, mover: int, third: int,
           later: tuple[str, str, str], passing: tuple[int, ...], alongs: tuple[float, ...]) -> Choice | None:
    """Among the cascade's candidates (row, corner offset, the third car's meeting, whether the striker does not
    push the first car again before it, whether the impact is `steady`), each with the deflected car's path (world
    x, y, yaw, vx, vy, yaw rate every cascade.DT after the first touch at t1 [s]), and every `alongs` fraction: the
    one whose predicted contact with the third car leaves the written next contact (`predict`, met in one of the
    `lanes` of the fourth actor):
    first by the third car's meeting having its written class, then by not pushing again, then by the next contact's
    class where the third car comes SPREAD earlier or later too (the least of the three: a sideswipe's outcome can
    turn on a few centimetres), then by those two with their areas (meetings.matches), then by a steady first
    impact, then by the sooner meeting, then by the nominal one's (`_follow_key`), then by how far inside its
    class's heading range the third car's meeting is (`option_key`)."""
    dt = plan.ctx.skid_paths.dt
    placed, starts = [], []
    for row, offset, meeting, clean, steady_one in candidates:
        k = meeting[0]
        arrive = t1 + (k + 1) * cascade.DT
        for along in alongs:
            speed = _placed_speed(plan, third, meeting, later, arrive, passing, along)
            if speed is None:
                continue
            reach = float(plan.s0[third]) + third_reach(plan, third, meeting, later, along)
            placed.append((row, offset, along, meeting, clean, steady_one))
            starts.append((row, k, arrive, reach, speed))
    if not placed:
        return None
    options, touches = [], []
    for (row, offset, along, meeting, clean, steady_one), (_, _, _, reach, speed), (
            lead, mover_pose, mover_motion, third_pose) in zip(placed, starts, _apart(plan, mover, third, paths,
                                                                                      starts)):
        options.append((row, offset, along, meeting, clean, reach - speed * lead, steady_one, lead))
        touches.append(Touch(mover_pose, mover_motion, third_pose, speed, _body(plan, mover), _body(plan, third),
                             plan.ctx.friction, dt))
    predicted = predict(touches)
    follows = _follows(plan, nxt, third, predicted)
    # the options whose next contact has its written class: the third car SPREAD earlier and later too
    check = [i for i in range(len(options)) if i in follows and follows[i][1][2] == nxt.later[0]]
    spread = _follows(plan, nxt, third, predict([
        replace(touches[i], third_pose=route_pose(plan, third, options[i][5] + d, float(plan.d0[third])))
        for i in check for d in (-SPREAD, SPREAD)]))
    least = {i: min(_follow_key(f, nxt)[0] if f else -1 for f in (follows[i], spread.get(2 * j), spread.get(2 * j + 1)))
             for j, i in enumerate(check)}
    none = (-1, False, -math.inf)
    best, best_key = 0, None
    for i, (row, offset, along, meeting, clean, _, steady_one, _) in enumerate(options):
        nominal = follows.get(i)
        follow = _follow_key(nominal, nxt) if nominal else none
        key = option_key(_later_match(plan, meeting, later, predicted[i], mover, third), clean,
                         least.get(i, follow[0]), steady_one, meeting[0], follow, meeting[5])
        if best_key is None or key > best_key:
            best, best_key = i, key
    row, offset, along, meeting = options[best][:4]
    follow = follows.get(best)
    if follow is None:
        return Choice(row, offset, along, meeting, key=best_key)
    touch = t1 + (meeting[0] + 1) * cascade.DT
    arrive = touch - options[best][7] + predicted[best][1] + (follow[1][0] + 1) * cascade.DT
    return Choice(row, offset, along, meeting, follow[0], follow[1], arrive, best_key)


Start = tuple[int, int, float, float, float]  # a candidate's path row, meeting step, arrival [s], reach [m], speed [m/s]


def _apart(plan: VariationPlan, mover: int, third: int, paths: list[tuple[np.ndarray, ...]], starts: list[Start]
           ) -> list[tuple[float, tuple, tuple, tuple]]:
    """Where each candidate's prediction starts, for `starts` (row of `paths`, the meeting step k of that path,
    arrive [s], reach [m], speed [m/s]): (how long before `arrive` [s], the time the third car's station is `reach`
    [m] at `speed`, the deflected car's pose and motion then (`paths[row]` k steps after the first touch), the
    third car's pose then), at the simulator's last step before the meeting, or as many steps earlier as the two
    footprints still overlap there (the meeting is where the deflected car is well into the third car's side,
    pushed_meetings: they touched before, and a prediction that starts with the two in each other finds no
    contact), at most APART_STEPS; all candidates at once."""
    dt = plan.ctx.skid_paths.dt
    stacked = np.array(paths, dtype=float)  # (M, 6, steps)
    stacked[:, 2] = np.unwrap(stacked[:, 2], axis=-1)
    rows, k, arrive, reach, speed = (np.array(q) for q in zip(*starts))
    lead = np.array([cascade.step_lead(float(t), dt) for t in arrive])  # [s] from the simulator's last step before
    pose, motion, third_pose = np.zeros((3, len(starts))), np.zeros((3, len(starts))), np.zeros((3, len(starts)))
    todo = np.arange(len(starts))
    length, width = plan.length, plan.width
    for _ in range(APART_STEPS + 1):
        pose[:, todo], motion[:, todo] = mover_states(stacked, rows[todo], k[todo] - lead[todo] / cascade.DT)
        third_pose[:, todo] = route_poses(plan, third, reach[todo] - speed[todo] * lead[todo], float(plan.d0[third]))
        todo = todo[footprints_overlap(*pose[:, todo], length[mover], width[mover], *third_pose[:, todo],
                                       length[third], width[third])]
        lead[todo] += dt
    return [(float(lead[i]), tuple(pose[:, i].tolist()), tuple(motion[:, i].tolist()),
             tuple(third_pose[:, i].tolist())) for i in range(len(starts))]


def _later_match(plan: VariationPlan, meeting: tuple, later: tuple[str, str, str], predicted: tuple | None,
                 mover: int, third: int) -> int:
    """How well a candidate has the written later contact: its meeting's (meetings.matches), without the class
    when the contact its prediction steps (`predict`) is recorded as another class (`touch_class`: the meeting
    reads the class off the headings alone, and a deflected car met late, slow and turned, is struck end on)."""
    found = matches(meeting, later)
    if predicted is not None and found >= 2 and touch_class(plan, mover, third, predicted[3]) != later[0]:
        found -= 2
    return found


def option_key(later: int, clean: bool, least: int, steady_one: bool, step: int, follow: tuple[int, bool, float],
               margin: float) -> tuple:
    """How `choose` ranks a candidate (larger is better): the written classes first, then the areas (rules.md: a
    variation reproduces its report when the crash sequence happens, a contact's two actors and class in order; the
    areas each touched are a separate figure, not required): the third car's meeting having the written later
    contact's class, a striker that does not push the first car again before it, the next contact's class where the
    third car comes SPREAD earlier or later too (`least`), then those two matches with their areas
    (meetings.matches), a steady first impact (`steady`), then the sooner meeting (`step` of cascade.DT after the
    first impact: a prediction of two bodies holds less the longer after it, as the cars it leaves out come back
    into play; in 3-C1-2017-001, seed 7, 66 of the 70 reproduced variations met the third car within 0.5 s of the
    first impact, 16 of the 30 others later), the nominal next contact's `_follow_key`, and how far inside its
    class's heading range the third car's meeting is [deg]. A candidate whose deflected car meets the third with
    another face than the written one but leaves the next contact's class ranks above one with the written face
    that loses it (3-C1-2017-001 at a 60 mph limit, seed 7: in 13 of its 18 failures the only candidates with the
    written head-on after the sideswipe met the third car with another face of the striker)."""
    return (later >= CLASS_MATCH, clean, least >= CLASS_MATCH, later, least, steady_one, -step, *follow, margin)


_LATER, _LEAST, _STEADY, _AIMED = 3, 4, 5, 8  # where option_key puts them


def full(key: tuple) -> bool:
    """Whether a `Choice.key` (`option_key`) has the written later contact and, robustly (SPREAD earlier and later
    too), the written next one with its class and the moving car's area, from a steady first impact, with the
    fourth actor aimed at the moving car (`_aimed`): one that cannot drive at its centre within its lane meets it
    off its centre line, and a contact that far to the side is a side-to-side one for the monitor whatever the
    headings (geometry.classify_contact; 3-C1-2017-001, seed 2: of the variations planned full but for this, with
    the third car met within 0.45 s of the first impact, 9 of 16 did not reproduce, against 2 of 48 with the fourth
    car aimed). plan_cascade tries its alternatives until one is."""
    return bool(key) and key[_LATER] == 3 and key[_LEAST] == 3 and key[_STEADY] and key[_AIMED]


def _follows(plan: VariationPlan, nxt: Next, third: int, predicted: list) -> dict[int, tuple[float, tuple, bool]]:
    """The fourth actor's best meeting (`_aimed`: shift, meeting, aimed) with the moving car of each predicted
    contact that touches, over the `lanes` it may take (`_follow_key`)."""
    live = [i for i, p in enumerate(predicted) if p is not None]
    out: dict[int, tuple[float, tuple, bool]] = {}
    if not live:
        return out
    moving = [predicted[i][0] if nxt.moving == third else predicted[i][2] for i in live]
    measured = along_route(plan, nxt.moving, nxt.actor, moving, [(0.0, 0.0, 0.0)] * len(live))
    for shift in lanes(plan, nxt.actor, third):
        plan.d0[nxt.actor] += shift
        try:
            found = meetings_along(plan, nxt.actor, measured, nxt.later)
        finally:
            plan.d0[nxt.actor] -= shift
        ones = {j: _aimed(plan, nxt, measured.lateral(j, meeting[0]), meeting, shift)
                for j, meeting in enumerate(found) if meeting is not None}
        # the meetings with the written class by their headings, classed where the two first touch (`_met`)
        classed = [j for j, one in ones.items() if one[1][2] == nxt.later[0]]
        for j, one in zip(classed, _met(plan, nxt, [moving[j] for j in classed], [ones[j] for j in classed])):
            ones[j] = one
        for j, one in ones.items():
            i = live[j]
            if i not in out or _follow_key(one, nxt) > _follow_key(out[i], nxt):
                out[i] = one
    return out


def _met(plan: VariationPlan, nxt: Next, paths: list[Path], follows: list[tuple[float, tuple, bool]]
         ) -> list[tuple[float, tuple, bool]]:
    """Each of `follows` (`_aimed`: the fourth actor's lateral shift [m], its meeting with the moving car along the
    path of `paths`) with its meeting's class the one the monitor gives the contact (`touch_class`, at the poses
    where the two first touch, as the simulator records a contact: simulator._back_to_contact) where the fourth
    actor, driving straight along its route at its speed, across as shifted and timed to the meeting
    (meetings.third_reach), first touches the moving car on its path; no class (None) where it never does. The
    meeting reads the class off the two headings alone; a car turned 20 deg off a head-on and met off its centre
    line is met side to side. All at once (the paths of one length, `predict`'s)."""
    if not follows:
        return []
    a, n = nxt.actor, len(follows)
    x, y, yaw = (np.array([np.asarray(p[q]) for p in paths]) for q in range(3))  # (n, steps)
    steps = x.shape[1]
    k = np.array([f[1][0] for f in follows], dtype=float)
    reach = np.array([third_reach(plan, a, f[1], nxt.later) for f in follows])
    station = float(plan.s0[a]) + reach[:, None] - float(plan.speeds[a]) * cascade.DT * (k[:, None] - np.arange(steps))
    px, py, pyaw = plan.ctx.arrays.point(np.full(n * steps, plan.route[a]), station.reshape(-1))
    lateral = np.repeat(float(plan.d0[a]) + np.array([f[0] for f in follows]), steps)
    mine = tuple(q.reshape(n, steps) for q in (px - np.sin(pyaw) * lateral, py + np.cos(pyaw) * lateral, pyaw))
    lm, wm, la, wa = plan.length[nxt.moving], plan.width[nxt.moving], plan.length[a], plan.width[a]
    touch = footprints_overlap(x, y, yaw, lm, wm, *mine, la, wa)
    hit = touch.any(axis=1)
    m = np.argmax(touch, axis=1)
    rows = np.arange(n)
    before = np.maximum(m - 1, 0)

    def between(q: tuple[np.ndarray, ...]):
        return lambda f: tuple(v[rows, before] + f * (v[rows, m] - v[rows, before]) for v in q)

    theirs, ours = between((x, y, np.unwrap(yaw, axis=1))), between(mine)
    one = np.ones(n)
    # back to where they first touch (already touching at the path's start: there)
    f = np.where(m > 0, touch_fraction(theirs, ours, lm * one, wm * one, la * one, wa * one, n), 1.0)
    at = (*theirs(f), *ours(f))
    out = []
    for r, (shift, meeting, aimed) in enumerate(follows):
        klass = touch_class(plan, nxt.moving, a, tuple(float(v[r]) for v in at)) if hit[r] else None
        out.append((shift, (*meeting[:2], klass, *meeting[3:]), aimed))
    return out


def _aimed(plan: VariationPlan, nxt: Next, lat: float, meeting: tuple, shift: float) -> tuple[float, tuple, bool]:
    """(lateral shift [m], meeting, whether it is aimed) of the fourth actor meeting the moving car as `meeting`
    has it, the moving car's centre `lat` [m] left of the fourth actor's route then (meetings.AlongRoute.lateral),
    in the lane `shift` [m] across: within that lane, it drives where the moving car's centre is predicted to be
    then (its front meets the moving car end to end, not with a side); aimed when that is within its lane
    (AIM_MISS)."""
    a = nxt.actor
    lane = float(plan.d0[a]) + shift
    room = max(plan.lane_width - float(plan.width[a]), 0.0) / 2
    within = float(np.clip(lat - lane, -room, room))
    return shift + within, meeting, abs(lat - lane - within) < AIM_MISS


def _follow_key(follow: tuple[float, tuple, bool], nxt: Next) -> tuple[int, bool, float]:
    """How well a predicted next meeting has the written next contact: its class and the moving car's area
    (meetings.matches), then whether the fourth actor can drive at it (`_aimed`), then how far inside the class's
    heading range it is [deg]."""
    return matches(follow[1], nxt.later), follow[2], follow[1][5]


def _placed_speed(plan: VariationPlan, third: int, meeting: tuple, later: tuple[str, str, str], arrive: float,
                  passing: tuple[int, ...], along: float) -> float | None:
    """[m/s] the speed actor `third` meets at when placed as meetings.place_third places it (a dry run: the plan is
    left as it was); None when it cannot be placed."""
    saved = plan.snapshot()
    try:
        if not place_third(plan, third, meeting, later, arrive, passing, along):
            return None
        return float(plan.speeds[third])
    finally:
        plan.restore(saved)


def _body(plan: VariationPlan, a: int) -> tuple[float, float, float, float]:
    """(length [m], width [m], mass [kg], wheelbase [m]) of actor a."""
    limits = plan.ctx.columns[a].limits
    return float(plan.length[a]), float(plan.width[a]), limits.mass, limits.wheelbase_ratio * float(plan.length[a])


def place(plan: VariationPlan, nxt: Next, choice: Choice) -> bool:
    """The fourth actor shifted to the chosen lane (its start drifted across: plan.drifted) and placed to meet the
    moving car as the chosen meeting has it; False when it cannot be placed (then it is left as it was)."""
    if choice.follow is None:
        return False
    a = nxt.actor
    saved = plan.snapshot()
    for name in ("d0", "lateral_target", "drifted"):
        getattr(plan, name)[a] += choice.shift
    if place_third(plan, a, choice.follow, nxt.later, choice.arrive):
        return True
    plan.restore(saved)
    return False
