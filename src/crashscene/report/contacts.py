"""The contact table: the reported crash sequence (DSL `collisions`) beside the simulated contacts of a variation.

Matching follows rules.md: the first reported contact must be the variation's
first contact (the same two vehicles, the same class); every later reported
contact must happen after the previous match, in order. Areas are compared per
vehicle and shown as their own figure, as the monitor reports them.
"""
from __future__ import annotations

from crashscene.report.palette import label_of

CLASSES = ("rear_end", "head_on", "angle", "sideswipe")


def reported_contacts(raw: dict) -> list[dict] | None:
    """The DSL's `collisions` list (raw YAML mapping of the scenario); None when the file does not write it."""
    contacts = raw.get("collisions")
    if contacts is None:
        return None
    return [{"striking": c.get("striking"), "struck": c.get("struck"), "striking_area": c.get("striking_area"),
             "struck_area": c.get("struck_area"), "class": c.get("class")} for c in contacts if isinstance(c, dict)]


def labels_of(raw: dict) -> dict[str, str]:
    """role -> report label for every actor of the scenario."""
    actors = raw.get("actors") or {}
    return {role: label_of(role, (a or {}).get("label")) for role, a in actors.items()}


def _same(rep: dict, sim: dict) -> bool:
    return {rep["striking"], rep["struck"]} == {sim["actor_a"], sim["actor_b"]} and rep["class"] == sim["class"]


def _areas_match(rep: dict, sim: dict) -> bool | None:
    got = {sim["actor_a"]: sim.get("area_a"), sim["actor_b"]: sim.get("area_b")}
    if None in got.values():
        return None
    return got.get(rep["striking"]) == rep["striking_area"] and got.get(rep["struck"]) == rep["struck_area"]


def _sim_cells(sim: dict, labels: dict[str, str]) -> dict:
    a, b = labels.get(sim["actor_a"], sim["actor_a"]), labels.get(sim["actor_b"], sim["actor_b"])
    areas = (f"{a} {sim['area_a']}, {b} {sim['area_b']}" if sim.get("area_a") and sim.get("area_b") else "-")
    dv = [f"{lab} {v:.1f}" for lab, v in ((a, sim.get("delta_v_a")), (b, sim.get("delta_v_b"))) if v is not None]
    return {"pair": f"{a}-{b}", "class": sim["class"], "areas": areas, "delta_v": ", ".join(dv) or "-",
            "t": sim.get("t")}


def contact_table(reported: list[dict] | None, simulated: list[dict], labels: dict[str, str]) -> list[dict]:
    """Rows: {reported: cells or None, simulated: cells or None, status: match|mismatch|not reported|simulated,
    areas: True|False|None}; `simulated` rows are ordered by time (actor_a, actor_b, class, area_a, area_b,
    delta_v_a, delta_v_b [m/s], t [s])."""
    rows: list[dict] = []
    used: set[int] = set()
    last = -1
    for k, rep in enumerate(reported or []):
        s, r = labels.get(rep["striking"], rep["striking"]), labels.get(rep["struck"], rep["struck"])
        cells = {"pair": f"{s} → {r}", "class": rep["class"],
                 "areas": f"{s} {rep['striking_area']}, {r} {rep['struck_area']}"}
        if k == 0:
            hit = 0 if simulated else None
            ok = bool(simulated) and _same(rep, simulated[0])
        else:
            hit = next((j for j in range(last + 1, len(simulated)) if j not in used and _same(rep, simulated[j])),
                       None)
            ok = hit is not None
        if hit is not None:
            used.add(hit)
            if ok:
                last = hit
        sim = simulated[hit] if hit is not None else None
        rows.append({"reported": cells, "simulated": _sim_cells(sim, labels) if sim else None,
                     "status": "match" if ok else "mismatch",
                     "areas": _areas_match(rep, sim) if ok and sim else None})
    for j, sim in enumerate(simulated):
        if j not in used:
            rows.append({"reported": None, "simulated": _sim_cells(sim, labels),
                         "status": "not reported" if reported is not None else "simulated", "areas": None})
    return rows
