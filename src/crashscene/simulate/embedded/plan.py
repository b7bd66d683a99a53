"""Timing plans of an embedded batch, per variation: when each actor starts, how fast it cruises and when its
manoeuvre triggers, so that the paths conflict as the report says (see `timing` for the kinematics), and the
signal phase that gives the anchor its green.

Every draw comes from the variation's own generator in a fixed order, so a plan depends only on
(scenario, seed, variation index).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from crashscene.scene import SampledScene
from crashscene.simulate.drivers.behaviors import OVER_LIMIT, SPEEDING_CODES, speed_factor
from crashscene.simulate.embedded import signals, timing
from crashscene.simulate.embedded import skid as skid_plan
from crashscene.simulate.embedded.control import entry_before
from crashscene.simulate.embedded.world import RouteArrays
from crashscene.simulate.roads import ROUTE_DS
from crashscene.units import MPH

if TYPE_CHECKING:
    from crashscene.simulate.embedded.setup import ActorColumn

VEER_BEHAVIORS = ("change_lane_left", "change_lane_right", "cross_centerline", "overtake")
LATERAL_BEHAVIORS = ("change_lane_left", "change_lane_right", "cross_centerline", "overtake", "lose_control",
                     "leave_road")
SYNC_SLACK = 0.8  # [s] an actor moved back to meet later is placed this much early (sync.Meeting slows it)
START_MARGIN = 5.0  # [m] an actor moved back along its route stays this far from the route's start
ADVANCE_MARGIN = 3.0  # [m] an actor advanced by its timing plan stays this far before its junction entry


def plan_variation(v: int, scene: SampledScene, rng: np.random.Generator, columns: list[ActorColumn], anchor: int,
                    arrays: RouteArrays, route: np.ndarray, s0: np.ndarray, d0: np.ndarray, speed: np.ndarray,
                    length: np.ndarray, entry_control: np.ndarray, lateral_target: np.ndarray, hold: np.ndarray,
                    trigger: np.ndarray, scale: np.ndarray, phase: np.ndarray, conflict_time: np.ndarray,
                    runs_red: bool, cond: float, default_limit: float, planned_out: np.ndarray,
                    moved: np.ndarray, reproduce: bool, drifted: np.ndarray, skids: np.ndarray,
                    classes: dict[frozenset[str], str], strikers: dict[frozenset[str], str],
                    first_pair: frozenset[str] | None, friction: float,
                    width: np.ndarray,
                    lane_width: float) -> None:
    """Fill row v of the timing arrays (draws from rng in a fixed order)."""
    n_a = len(columns)
    planned = [_planned_speed(arrays, route[v, a], s0[v, a], speed[v, a], columns[a], cond, default_limit)
               for a in range(n_a)]
    planned_out[v] = planned
    draws = {"offset": rng.normal(timing.ARRIVAL_OFFSET_MEAN, timing.ARRIVAL_OFFSET_SD, n_a),
             "lead": rng.uniform(0.8, 2.0, n_a), "trigger": rng.uniform(1.0, 4.0, n_a),
             "green": rng.uniform(3.0, 15.0), "spin": rng.choice([-1.0, 1.0], n_a),
             "rotation": rng.uniform(0.0, 1.0, n_a)}
    ra = route[v, anchor]
    va = planned[anchor]
    anchor_col = columns[anchor]
    anchor_stop = stop_dist(arrays, ra, s0[v, anchor], entry_control, anchor_col)
    arrival_anchor = None
    for a, col in enumerate(columns):
        r = route[v, a]
        params = scene.params
        offset = float(np.clip(draws["offset"][a], -timing.ARRIVAL_OFFSET_MAX, timing.ARRIVAL_OFFSET_MAX))
        offset = _param(params, col.role, ("ARRIVAL_OFFSET",), offset)
        if reproduce:
            offset *= timing.REPRODUCE_OFFSET_SCALE
        if col.is_ads:
            continue
        if col.behavior in LATERAL_BEHAVIORS:
            partner = _partner(v, a, anchor, columns, scene, route, s0)
            if partner is None:
                trigger[v, a] = _param(params, col.role, ("TRIGGER_TIME", "MANEUVER_TIME"), draws["trigger"][a])
                if col.behavior == "lose_control":
                    lateral_target[v, a] = draws["spin"][a]
                continue
            gap, lateral = _relative(arrays, r, s0[v, a], scene.actors[partner].x, scene.actors[partner].y)
            opposite = math.cos(scene.actors[partner].yaw - scene.actors[a].yaw) < -0.3
            if col.behavior == "lose_control":
                lateral_target[v, a] = 1.0 if lateral >= 0 else -1.0
                dist = 2.5
            elif col.behavior == "cross_centerline" and opposite and lateral > lateral_target[v, a] > 0:
                # several opposing lanes: drift as far as the oncoming partner's lane
                lateral_target[v, a] = lateral
                dist = lateral - d0[v, a]
            else:
                dist = lateral_target[v, a] - d0[v, a]
            lead = _param(params, col.role, ("LEAD_TIME",), draws["lead"][a])
            if col.behavior == "lose_control":
                lead = (draws["lead"][a] - 1.4) / 1.2 * 0.6  # [-0.3, 0.3] s around reaching the partner's lane
            rate = timing.lateral_rate(col.behavior)
            p_col = columns[partner]
            if opposite and not p_col.is_ads and p_col.behavior not in LATERAL_BEHAVIORS and gap > 0:
                # too close to swerve in time: the oncoming partner comes a little slower (within its range)
                needed = abs(dist) / rate + lead
                closing = gap / needed
                if closing < planned[a] + planned[partner]:
                    scale[v, partner] = max(timing.SPEED_SCALE[0], (closing - planned[a]) / planned[partner])
                    planned[partner] *= scale[v, partner]
            contact = classes.get(frozenset((col.role, p_col.role)))
            if contact == "sideswipe" and not opposite and col.behavior in ("change_lane_left", "change_lane_right"):
                # side by side when it reaches the partner's lane: it starts where it will be alongside then
                rate = timing.lateral_rate(col.behavior)
                t_trig = float(draws["trigger"][a])
                touch = t_trig + max(abs(dist) - 0.5 * (width[v, a] + width[v, partner]), 0.0) / rate
                want_gap = (planned[a] - planned[partner]) * touch + (draws["lead"][a] - 1.4) * 1.5
                placed = _shift_start(arrays, v, a, route, s0, gap - want_gap, length, d0)
                if placed is not None:
                    s0[v, a] = placed
                    moved[v, a] = True
                    trigger[v, a] = t_trig
                    continue
            skid = None
            if col.behavior == "lose_control" or (contact == "angle" and col.behavior in VEER_BEHAVIORS):
                # a lateral manoeuvre that ends in an angle contact is a sudden veer: planned as a skid
                moves_in = p_col.behavior in ("change_lane_left", "change_lane_right") and not opposite
                # the partner's front meets the skidding car's side (its front, end-on) before the centres align
                reach = {"angle": length[v, partner] / 2 + width[v, a] / 2,
                         "head_on": (length[v, partner] + length[v, a]) / 2,
                         "rear_end": (length[v, partner] + length[v, a]) / 2}.get(contact or "", 0.0)
                ahead = 1.0 if (opposite or gap > 0) else -1.0
                skid = skid_plan.plan(planned[a], gap - ahead * reach, planned[partner], opposite,
                                      (0.0 if moves_in else lateral) - d0[v, a],
                                      lane_width, friction, float(length[v, a]), float(width[v, a]),
                                      skid_plan.rotation_for(contact, opposite, float(draws["rotation"][a])),
                                      contact)
                if skid is not None and skid.partner_shift:
                    placed = _shift_start(arrays, v, partner, route, s0, skid.partner_shift, length, d0)
                    if placed is None:
                        skid = None
                    else:
                        s0[v, partner] = placed
                        moved[v, partner] = True
            if skid is not None:
                skids[v, a] = (skid.spin_rate, skid.drift, skid.hold)
                trigger[v, a] = skid.trigger
                continue
            if col.behavior == "lose_control":
                t_trig = timing.skid_trigger(gap, planned[a], planned[partner], lateral, timing.SPIN_RATE,
                                             opposite=opposite) - lead
            else:
                t_trig = timing.lateral_trigger(gap, planned[a], planned[partner], opposite, dist, lead, rate)
            if t_trig < 0 and col.behavior in ("cross_centerline", "overtake") and opposite:
                # too close for the whole manoeuvre: the actor is already drifting across at t = 0
                shift = float(np.clip(-t_trig * rate, 0.0, abs(dist) * 0.6)) * math.copysign(1.0, dist)
                d0[v, a] += shift
                drifted[v, a] = shift
            trigger[v, a] = max(0.0, t_trig)
            continue
        if col.behavior in ("decelerate", "stop"):
            trigger[v, a] = _param(params, col.role, ("TRIGGER_TIME", "MANEUVER_TIME"), draws["trigger"][a])
            continue
        if a == anchor or col.behavior == "static":
            continue
        cs_a = arrays.conflict_s[r, ra]
        cs_e = arrays.conflict_s[ra, r]
        if np.isnan(cs_a) or cs_a <= s0[v, a] or cs_e <= s0[v, anchor]:
            continue
        lat_a = 2.0 if col.is_ads else 2.5
        lat_e = 2.0 if anchor_col.is_ads else 2.5
        if arrival_anchor is None:
            if anchor_stop is None:
                arrival_anchor = arrays.travel_time(ra, s0[v, anchor], cs_e, va, lat_e, v0=va)
            else:
                v_eff = _effective_speed(arrays, ra, s0[v, anchor], cs_e, va, anchor_col)
                arrival_anchor = timing.arrival_time(cs_e - s0[v, anchor], v_eff, anchor_col.limits.accel_max,
                                                     stop_dist=anchor_stop)
        stop = stop_dist(arrays, r, s0[v, a], entry_control, col)
        # a turning vehicle is struck on its side in its turn: it reaches the conflict point first
        turn_a = _turns_at(arrays, r, cs_a)
        turn_e = _turns_at(arrays, ra, cs_e)
        if turn_a and not turn_e:
            offset -= timing.TURNER_LEAD
        elif turn_e and not turn_a:
            offset += timing.TURNER_LEAD
        striking = strikers.get(frozenset((col.role, anchor_col.role)))
        if striking is not None:
            # the written contact says who strikes: the striker's front meets the middle of the struck one's side
            s_idx = a if striking == col.role else anchor
            t_idx = anchor if s_idx == a else a
            r_t, cs_t = (r, cs_a) if t_idx == a else (ra, cs_e)
            s_t0 = s0[v, t_idx]
            v_struck = _effective_speed(arrays, r_t, max(cs_t - 10.0, s_t0), cs_t, planned[t_idx], columns[t_idx])
            r_s, cs_s = (ra, cs_e) if t_idx == a else (r, cs_a)
            u = struck_offset(arrays, r_t, cs_t, r_s, cs_s, float(length[v, t_idx]),
                              classes.get(frozenset((col.role, anchor_col.role))))
            side_hit = (length[v, s_idx] / 2 + width[v, t_idx] / 2) / max(planned[s_idx], 1.0) \
                + u / max(v_struck, 1.0)
            jitter = offset - timing.ARRIVAL_OFFSET_MEAN * (timing.REPRODUCE_OFFSET_SCALE if reproduce else 1.0)
            offset = (side_hit if s_idx == a else -side_hit) + jitter
        target = arrival_anchor + offset
        # the first written contact's pair meets closed loop (sync.Meeting): place the free one a little early
        slack = SYNC_SLACK if reproduce and first_pair == frozenset((col.role, anchor_col.role)) else 0.0
        va_ = planned[a]
        if stop is not None:
            v_eff = _effective_speed(arrays, r, s0[v, a], cs_a, va_, col)
            sc, hd = timing.junction_plan(target, cs_a - s0[v, a], v_eff, col.limits.accel_max, stop_dist=stop)
            # stopping at its line first, it can come late even when it does not wait at all (hd == 0)
            t_stop_go = timing.arrival_time(cs_a - s0[v, a], v_eff, col.limits.accel_max, stop_dist=stop)
            late = max(0.0, t_stop_go - target) if hd == 0.0 else 0.0
        else:
            def t_at(k: float, s_start: float = s0[v, a], v_start: float | None = None) -> float:
                v_init = va_ * min(k, 1.0) if v_start is None else v_start
                return arrays.travel_time(r, s_start, cs_a, va_ * k, lat_a, v0=v_init)

            lo, hi = timing.SPEED_SCALE
            hd = 0.0
            if t_at(hi) > target:
                sc = hi
                late = t_at(hi) - target
            elif t_at(lo) < target and (back := _start_back(
                    arrays, v, a, route, s0, max(target - t_at(1.0) - slack, 0.0) * va_, length, d0)) is not None:
                # far too early: it was further back along its approach, driving at its own speed
                sc, late = 1.0, 0.0
                s0[v, a] = back
                moved[v, a] = True
            elif t_at(lo) < target:
                sc = lo
                late = 0.0
                hd = max(0.0, target - arrays.travel_time(r, s0[v, a], cs_a, va_ * lo, lat_a, v0=0.0))
            else:
                # travel time is nearly proportional to 1/speed: two secant corrections suffice
                sc = float(np.clip(t_at(1.0) / target, lo, hi))
                for _ in range(2):
                    sc = float(np.clip(sc * t_at(sc) / target, lo, hi))
                late = 0.0
        if late > 0.1 and stop is None:
            # even at its fastest the actor would come late: it has already been driving for a while,
            # so it starts further along its own approach (never closer than ADVANCE_MARGIN to the junction)
            entries = arrays.entry_s[r]
            first_entry = entries[np.isfinite(entries) & (entries > s0[v, a])]
            room = (first_entry[0] - s0[v, a] - ADVANCE_MARGIN) if len(first_entry) else 0.0
            if room > 0:
                best = s0[v, a]
                for cand in np.linspace(s0[v, a], s0[v, a] + room, 12)[1:]:
                    v_start = min(va_ * sc, max(float(arrays.curve_speed(np.array(r), np.array(cand),
                                                                         np.array(60.0), 2.5, 2.0)), 3.0))
                    best = cand
                    late = t_at(sc, cand, v_start) - target
                    if late <= 0.05:
                        break
                s0[v, a] = best
                moved[v, a] = True
        if late > 0.1 and not anchor_col.is_ads and anchor_col.behavior not in ("static", "stop") \
                and anchor_stop is None and hold[v, anchor] == 0.0:
            # reproduce mode: the scripted anchor comes that much later instead (slower, else it waits);
            # also for an actor that must first stop at its line, which no advance along its approach fixes
            t_new = arrival_anchor + late
            lo, hi = timing.SPEED_SCALE[0], 1.0
            # ...placed a little early rather than late: on the way it can slow down to meet (sync), rarely speed up
            back = _start_back(arrays, v, anchor, route, s0, max(late - slack, 0.0) * va, length, d0)
            if back is not None:
                # it started that much further back along its approach, at its own speed
                s0[v, anchor] = back
                moved[v, anchor] = True
            elif arrays.travel_time(ra, s0[v, anchor], cs_e, va * lo, lat_e, v0=va * lo) < t_new:
                scale[v, anchor] = lo
                t_rest = arrays.travel_time(ra, s0[v, anchor], cs_e, va * lo, lat_e, v0=0.0)
                hold[v, anchor] = max(0.0, t_new - t_rest)
            else:
                for _ in range(8):
                    mid = (lo + hi) / 2
                    t_mid = arrays.travel_time(ra, s0[v, anchor], cs_e, va * mid, lat_e, v0=va * mid)
                    lo, hi = (lo, mid) if t_mid < t_new else (mid, hi)
                scale[v, anchor] = (lo + hi) / 2
            arrival_anchor = t_new
        scale[v, a], hold[v, a] = sc, hd
        conflict_time[v] = min(conflict_time[v], arrival_anchor)
    # signal phase: green for the anchor's axis at its nominal arrival at its first junction
    entries = arrays.entry_s[ra]
    ahead = entries[np.isfinite(entries) & (entries > s0[v, anchor])]
    t_junction = (ahead[0] - s0[v, anchor]) / va if len(ahead) else 5.0
    green = float(scene.params.get("SIGNAL_GREEN_REMAINING", draws["green"]))
    phase[v] = float(signals.phase_for(np.array(t_junction), np.array(green), runs_red))


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
    rel = np.abs(np.remainder(arrays.yaw[r_t, k] - yaw_s + np.pi, 2 * np.pi) - np.pi)
    miss = np.abs(rel - target) + 0.02 * np.abs(u - default)
    return float(u[int(np.argmin(miss))])


def _same_lane(route: np.ndarray, d0: np.ndarray | None, v: int, a: int, b: int) -> bool:
    """Whether actors a and b start in the same lane (same route, lateral offsets within a lane)."""
    return b != a and route[v, b] == route[v, a] and (d0 is None or abs(d0[v, b] - d0[v, a]) < 2.0)


def _shift_start(arrays: RouteArrays, v: int, a: int, route: np.ndarray, s0: np.ndarray, shift: float,
                 length: np.ndarray, d0: np.ndarray | None = None) -> float | None:
    """Station `shift` [m] along actor a's route from its start (negative: back), if the route has room and
    no other actor on the same route is in the way; else None."""
    if shift < 0:
        return _start_back(arrays, v, a, route, s0, -shift, length, d0)
    new = s0[v, a] + shift
    if new > arrays.length[route[v, a]] - 100.0:
        return None
    for b in range(route.shape[1]):
        if _same_lane(route, d0, v, a, b) and s0[v, a] < s0[v, b] < new + (length[v, a] + length[v, b]) / 2 + 4.0:
            return None
    return float(new)


def _start_back(arrays: RouteArrays, v: int, a: int, route: np.ndarray, s0: np.ndarray, dist: float,
                length: np.ndarray, d0: np.ndarray | None = None) -> float | None:
    """Station `dist` [m] behind actor a's start on its route, if the route has room and no other actor on the
    same route is within a car length and a margin of the new start; else None."""
    new = s0[v, a] - dist
    if new < START_MARGIN:
        return None
    for b in range(route.shape[1]):
        if _same_lane(route, d0, v, a, b) and (abs(s0[v, b] - new) < (length[v, a] + length[v, b]) / 2 + 4.0
                                               or new < s0[v, b] < s0[v, a]):
            return None
    return float(new)


def _param(params: dict, role: str, names: tuple[str, ...], default: float) -> float:
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
            factor = cond if "CVC_22350" in col.dispositions else 1.0
            fast = max(fast, limit * factor + OVER_LIMIT)
        return max(fast, 0.5)
    return max(min(speed, limit * cond) if np.isfinite(limit) else speed, 0.5)


def _effective_speed(arrays: RouteArrays, r: int, s0: float, s1: float, speed: float, col: ActorColumn) -> float:
    """Average speed [m/s] from s0 to s1, slowing in curves as the driver will (not when careless)."""
    if s1 <= s0 or "CVC_22350" in col.dispositions:
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
    if len(idx) == 0 or entry_control[r, idx[0]] != 2 or "CVC_22450" in col.dispositions:
        return None
    return float(entries[idx[0]] - s0 - 1.0)


def _partner(v: int, a: int, anchor: int, columns: list[ActorColumn], scene: SampledScene, route: np.ndarray,
             s0: np.ndarray) -> int | None:
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


def _relative(arrays: RouteArrays, r: int, s: float, x: float, y: float) -> tuple[float, float]:
    """(gap along route r from station s to the point, lateral offset of the point) [m]."""
    xy = arrays.xy[r]
    k = int(np.argmin(np.hypot(xy[:, 0] - x, xy[:, 1] - y)))
    yaw = arrays.yaw[r, k]
    dx, dy = x - xy[k, 0], y - xy[k, 1]
    lateral = -math.sin(yaw) * dx + math.cos(yaw) * dy
    return k * ROUTE_DS - s, lateral
