"""How long the monitor judges each actor: while its driver is in control of it.

rules.md judges driving from the recorded trace. A contact does not by itself
end driving: after a light touch (a clipped corner, a heavy truck that barely
slowed) the driver drives on and chooses its motion, and what it does then is
judged like anything before. An impact that upsets the vehicle (its velocity
changes by CONTROL_DELTA_V or more, or its yaw rate by CONTROL_YAW_RATE or more:
`crashscene.upset`, the thresholds the embedded simulator uses to hand a vehicle
to its tyres) ends its driving: from then on it moves as the impact made it, so
its rules see its trace only up to a short grace after that contact, and the
conflict paths of the right-of-way rules end at the contact.

The change is measured from the trace alone (rules.md), so that every backend
is judged alike: the velocity from the positions over the step before the
contact's step against the step after it, the yaw rate likewise. A backend
without contact physics that stops vehicles where they touch (newtonian)
shows their whole speed as the change; bodies that still overlap a grace
after the contact are passing through each other, not driving; a contact whose
neighbouring steps are not recorded counts as upsetting (judging ends there,
as it always did).
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

from crashscene.geometry import footprints_overlap, wrap_angle
from crashscene.monitor.arrays import TraceArrays
from crashscene.upset import upsets

NEVER = -1
AFTER_STEPS = (0, 1)  # [steps] the motion after a contact is read from its step onwards over these steps


def contact_change(arrays: TraceArrays, v: np.ndarray, a: np.ndarray, step: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Velocity change [m/s] and yaw-rate change [rad/s] of actor a in variation v across a contact at `step`
    (arrays of equal length), from positions and headings: the step from `step - 2` to `step - 1` before it
    against each step after it that starts AFTER_STEPS from `step`, the larger (the step into `step` may hold a
    move back to the contact). NaN where a needed row is missing."""
    n_steps = arrays.shape[2]
    x, y, yaw = arrays.floats["x"], arrays.floats["y"], arrays.floats["yaw"]

    def at(arr: np.ndarray, k: np.ndarray) -> np.ndarray:
        inside = (k >= 0) & (k < n_steps)
        kk = np.clip(k, 0, max(n_steps - 1, 0))
        got = np.where(arrays.alive[v, a, kk], arr[v, a, kk], np.nan)
        return np.where(inside, got, np.nan)

    def motion(k0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k1 = k0 + 1
        vx = (at(x, k1) - at(x, k0)) / arrays.dt
        vy = (at(y, k1) - at(y, k0)) / arrays.dt
        w = wrap_angle(at(yaw, k1) - at(yaw, k0)) / arrays.dt
        return vx, vy, w

    bx, by, bw = motion(step - 2)
    dv, dw = np.zeros(len(step)), np.zeros(len(step))
    for k in AFTER_STEPS:  # a simulator may apply the impact's rotation a step late: the larger change counts
        ax, ay, aw = motion(step + k)
        dv = np.fmax(dv, np.hypot(ax - bx, ay - by)) if k else np.hypot(ax - bx, ay - by)
        dw = np.fmax(dw, np.abs(aw - bw)) if k else np.abs(aw - bw)
    return dv, dw


def contact_steps(t: np.ndarray, dt: float) -> np.ndarray:
    """The first recorded step at or after each contact time `t` [s]: a simulator moves touching vehicles back to
    where they first touched, within the step that found them overlapping, so the contact's own step is the first
    one whose state includes it."""
    return np.ceil(np.asarray(t, dtype=float) / dt - 1e-6).astype(np.int64)


def contact_indices(arrays: TraceArrays, collisions: pa.Table, rounded: bool = False
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(variation, actor_a, actor_b, step) of each row of a collisions table, as indices into `arrays`: the
    variation's row, the two actors' columns, and the contact's step, the first recorded one at or after it
    (`contact_steps`), or with `rounded` the nearest one."""
    role_index = {r: i for i, r in enumerate(arrays.roles)}
    v = np.searchsorted(arrays.variations, collisions.column("variation").to_numpy())
    a, b = (np.array([role_index[r] for r in collisions.column(col).to_pylist()], dtype=np.int64)
            for col in ("actor_a", "actor_b"))
    t = collisions.column("t").to_numpy()
    step = np.round(t / arrays.dt).astype(np.int64) if rounded else contact_steps(t, arrays.dt)
    return v, a, b, step


def still_touching(arrays: TraceArrays, v: np.ndarray, a: np.ndarray, b: np.ndarray, step: np.ndarray
                   ) -> np.ndarray:
    """Whether the footprints of actors a and b in variation v overlap at `step` (False where either has no row)."""
    n_steps = arrays.shape[2]
    k = np.clip(step, 0, max(n_steps - 1, 0))
    f = arrays.floats
    both = arrays.alive[v, a, k] & arrays.alive[v, b, k] & (step < n_steps)
    touching = footprints_overlap(f["x"][v, a, k], f["y"][v, a, k], f["yaw"][v, a, k], arrays.length[v, a],
                                  arrays.width[v, a], f["x"][v, b, k], f["y"][v, b, k], f["yaw"][v, b, k],
                                  arrays.length[v, b], arrays.width[v, b])
    return both & touching


def upset_steps(arrays: TraceArrays, collisions: pa.Table | None, grace: int) -> np.ndarray:
    """(V, A) step of each actor's first contact that takes it out of its driver's control, NEVER when no contact
    does: its velocity or yaw rate changed by an upsetting amount (`crashscene.upset`, measured by
    `contact_change`), or the two bodies still overlap `grace` steps after it (vehicles passing through each other,
    as on a backend without contact physics, are not driven)."""
    out = np.full(arrays.shape[:2], NEVER, dtype=np.int64)
    if collisions is None or not collisions.num_rows:
        return out
    v, *pair, step = contact_indices(arrays, collisions)
    big = np.iinfo(np.int64).max
    best = np.full(arrays.shape[:2], big, dtype=np.int64)
    through = still_touching(arrays, v, pair[0], pair[1], step + grace)
    for a in pair:
        dv, dw = contact_change(arrays, v, a, step)
        upset = upsets(np.where(np.isfinite(dv), dv, np.inf), np.where(np.isfinite(dw), dw, np.inf)) | through
        np.minimum.at(best, (v[upset], a[upset]), step[upset])
    return np.where(best < big, best, NEVER)


def judged_until(upset: np.ndarray, grace: int) -> np.ndarray:
    """(V, A) last step each actor's rules see: `grace` steps past its upsetting contact, NEVER (the whole trace)
    when none upset it."""
    return np.where(upset >= 0, upset + grace, NEVER)
