"""The bird's-eye pictures of a case: which variations to draw (planned from the database), and drawing them.

Drawing may re-simulate a variation (when its traces were not kept), so cases are
drawn in a process pool when there are several; a `Shot` carries everything a
drawing process needs, without the database.
"""
from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel

from crashscene.campaign.store import Store
from crashscene.report import birdseye, tracks
from crashscene.report.errors import ReportError

GIF_BEFORE, GIF_AFTER = 6.0, 1.5  # [s] shown before and after the key moment
GIF_AFTER_VIOLATION = 3.0  # [s] after an ADS violation starts


class Shot(BaseModel):
    """One picture: a still at impact or an animation around a key moment."""

    name: str  # still | gif_reproduce | gif_ads
    case_id: str
    work_dir: str
    mode: str
    variation: int
    label: str
    run: dict  # the `runs` row (DSL text, seed, options) to re-simulate from
    t_key: float | None  # [s] impact or first violation; None: the end of the trace
    impact: tuple[float, float] | None = None  # [m] first contact point


def plan_shots(store: Store, out: Path, case: dict, gifs: bool) -> list[Shot]:
    """The still (first reproducing variation at impact, else first collision, else variation 0) and the GIFs."""
    modes = case["modes"]
    if not modes:
        return []
    rep = modes.get("reproduce", {})
    if rep.get("first_reproducing") is not None:
        pick = ("reproduce", rep["first_reproducing"], "first reproducing variation")
    else:
        pick = next(((m, r["first_collision"]["v"], "first variation with a collision")
                     for m, r in modes.items() if r.get("first_collision")), None)
        pick = pick or (next(iter(modes)), 0, "no collision in any variation: variation 0")
    wanted = [("still", *pick, None)]
    if gifs and rep.get("first_reproducing") is not None:
        wanted.append(("gif_reproduce", "reproduce", rep["first_reproducing"], "first reproducing variation", None))
    elif gifs and rep.get("first_collision"):  # nothing reproduced: show what the re-enactment did instead
        wanted.append(("gif_reproduce", "reproduce", rep["first_collision"]["v"],
                       "no variation reproduced the report; first variation with a collision", None))
    ads = modes.get("test", {}).get("first_ads_violation")
    if gifs and ads:
        wanted.append(("gif_ads", "test", ads["v"], f"first ADS violation ({ads['codes']})", ads["t"]))
    shots = []
    for name, mode, variation, label, t_key in wanted:
        key = [case["scenario_hash"], mode, variation]
        run = store.query("SELECT * FROM runs WHERE scenario_hash=? AND mode=? ORDER BY seed LIMIT 1", key[:2])[0]
        contact = store.query("SELECT t, x, y FROM collisions WHERE scenario_hash=? AND mode=? AND variation=? "
                              "ORDER BY t LIMIT 1", key)
        if t_key is None and contact:
            t_key = contact[0]["t"]
        shots.append(Shot(name=name, case_id=case["case_id"], work_dir=str(out / "cases" / case["case_id"]),
                          mode=mode, variation=variation, label=label, run=run, t_key=t_key,
                          impact=(contact[0]["x"], contact[0]["y"]) if contact and name == "still" else None))
    return shots


def draw_shots(shots: list[Shot]) -> dict:
    """Data URIs (and captions) of every shot; what cannot be drawn becomes a note, never an exception."""
    from crashscene.campaign.engines import quiet_scenic_warnings
    from crashscene.report.build import data_uri

    quiet_scenic_warnings()
    fig: dict = {"notes": []}
    for shot in shots:
        try:
            work = Path(shot.work_dir)
            run_dir = tracks.ensure_run_dir(work, shot.case_id, shot.run, shot.variation)
            map_file = tracks.map_file_of(run_dir, work)
            if map_file is None:
                raise ReportError(f"{run_dir}: no map.xodr")
            actor_tracks = tracks.load_tracks(run_dir, shot.variation)
            if not actor_tracks:
                raise ReportError(f"{run_dir}: no trace rows for variation {shot.variation}")
            t_end = float(max(tr.t[-1] for tr in actor_tracks))
            t_key = t_end if shot.t_key is None else min(float(shot.t_key), t_end)
            where = f"{shot.mode} mode, variation {shot.variation}"
            if shot.name == "still":
                title = f"{shot.case_id} {shot.mode} #{shot.variation}: {shot.label}"
                png = birdseye.still_png(map_file, actor_tracks, t_key, title, impact=shot.impact)
                fig["still"] = data_uri(png, "image/png")
                moment = "impact" if shot.impact is not None else "the end" if shot.t_key is None else "the key moment"
                fig["still_caption"] = f"{shot.label} ({where}) at {moment}, t = {t_key:.1f} s"
            else:
                after = GIF_AFTER if shot.name == "gif_reproduce" else GIF_AFTER_VIOLATION
                t0, t1 = max(0.0, t_key - GIF_BEFORE), min(t_end, t_key + after)
                gif = birdseye.animation_gif(map_file, actor_tracks, t0, t1, f"{shot.mode} #{shot.variation}")
                fig[shot.name] = data_uri(gif, "image/gif")
                fig[shot.name + "_caption"] = f"{shot.label}: {where}, t = {t0:.1f}-{t1:.1f} s"
        except Exception as exc:  # noqa: BLE001  (one missing picture must not sink the whole report)
            fig["notes"].append(f"{shot.name} ({shot.mode} #{shot.variation}) not drawn: {type(exc).__name__}: {exc}")
    return fig
