"""The bird's-eye pictures of a case: which variations to draw (planned from the database), and drawing them.

The campaign keeps the traces of the variations the report draws (`campaign.keep`:
table `shown` and its traces), so planning reads them from the database and
drawing needs no simulation. A campaign written before that falls back to kept
run folders, then to re-simulating the variation (`tracks.ensure_run_dir`).
A `Shot` carries everything a drawing process needs, without the database.
"""
from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict

from crashscene.campaign.store import Store
from crashscene.report import birdseye, framing, tracks
from crashscene.report.errors import ReportError
from crashscene.report.tracks import ActorTrack

GIF_BEFORE, GIF_AFTER = 6.0, 1.5  # [s] shown before and after the key moment
GIF_AFTER_VIOLATION = 3.0  # [s] after an ADS violation starts
CLOSEST_CALLS = {"closest_robustness": "lowest ADS rule robustness", "closest_ttc": "lowest ADS time to collision"}


class Shot(BaseModel):
    """One picture: a still at the key moment or an animation around it."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    name: str  # still | gif_reproduce | gif_ads | closest_robustness | closest_ttc
    case_id: str
    work_dir: str
    mode: str
    variation: int
    label: str
    run: dict  # the `runs` row (DSL text, seed, options): the fallback re-simulation needs it
    t_key: float | None  # [s] first violation; None: the first contact, else the closest approach, else the end
    contact: dict | None = None  # the first contact (t, x, y, actor_a, actor_b)
    tracks: list[ActorTrack] | None = None  # kept in the database; None: find or re-simulate them


def shown_variations(store: Store, scenario_hash: str, seed: int, mode: str) -> dict[str, dict]:
    """reason -> {variation, score} of the variations the campaign kept for the report (empty for old campaigns)."""
    if not _has_table(store, "shown"):
        return {}
    rows = store.query("SELECT reason, variation, score FROM shown WHERE scenario_hash=? AND seed=? AND mode=? "
                       "ORDER BY reason, score, variation", [scenario_hash, seed, mode])
    out: dict[str, dict] = {}
    for r in rows:
        out.setdefault(r["reason"], {"variation": r["variation"], "score": r["score"]})
    return out


def _has_table(store: Store, name: str) -> bool:
    return bool(store.query("SELECT 1 FROM information_schema.tables WHERE table_name=?", [name]))


def kept_tracks(store: Store, key: list, variation: int) -> list[ActorTrack] | None:
    """The variation's tracks from the database, or None when the campaign did not keep them."""
    if not _has_table(store, "shown_traces"):
        return None
    where = "scenario_hash=? AND seed=? AND mode=? AND variation=?"
    traces = store.arrow(f"SELECT variation, actor, t, x, y, yaw FROM shown_traces WHERE {where} ORDER BY actor, t",
                         [*key, variation])
    if traces.num_rows == 0:
        return None
    actors = store.arrow(f"SELECT variation, actor, label, type, is_ads, length, width FROM shown_actors "
                         f"WHERE {where} ORDER BY actor", [*key, variation])
    return tracks.tracks_from_tables(traces, actors, variation)


def pick_still(modes: dict) -> tuple[str, int, str] | None:
    """(mode, variation, why) of the case's main picture: the first reproducing variation, else the first
    collision (reproduce mode first), else the first variation."""
    rep = modes.get("reproduce", {})
    if rep.get("first_reproducing") is not None:
        return "reproduce", rep["first_reproducing"], "first reproducing variation"
    for mode, run in modes.items():
        if run.get("first_collision"):
            return mode, run["first_collision"]["v"], "first variation with a collision (none reproduced the report)"
    if not modes:
        return None
    mode = "reproduce" if "reproduce" in modes else next(iter(modes))
    return mode, modes[mode].get("first_variation") or 0, "no collision in any variation: the first variation"


def plan_shots(store: Store, out: Path, case: dict, gifs: bool) -> list[Shot]:
    """The still, the GIFs and, in test mode, the ADS's closest calls."""
    modes = case["modes"]
    still = pick_still(modes)
    if still is None:
        return []
    wanted = [("still", *still, None)]
    if gifs and still[0] == "reproduce":
        wanted.append(("gif_reproduce", "reproduce", still[1], still[2], None))
    test = modes.get("test", {})
    ads = test.get("first_ads_violation")
    if gifs and ads:
        wanted.append(("gif_ads", "test", ads["v"], f"first ADS violation ({ads['codes']})", ads["t"]))
    for reason, why in CLOSEST_CALLS.items():
        call = test.get("shown", {}).get(reason)
        if call is not None:
            wanted.append((reason, "test", call["variation"], why, None))
    shots = []
    for name, mode, variation, label, t_key in wanted:
        run = store.query("SELECT * FROM runs WHERE scenario_hash=? AND mode=? ORDER BY seed LIMIT 1",
                          [case["scenario_hash"], mode])[0]
        key = [case["scenario_hash"], run["seed"], mode]
        contact = store.query("SELECT t, x, y, actor_a, actor_b FROM collisions WHERE scenario_hash=? AND seed=? "
                              "AND mode=? AND variation=? ORDER BY t, actor_a, actor_b LIMIT 1", [*key, variation])
        shots.append(Shot(name=name, case_id=case["case_id"], work_dir=str(out / "cases" / case["case_id"]),
                          mode=mode, variation=variation, label=label, run=run, t_key=t_key,
                          contact=contact[0] if contact else None, tracks=kept_tracks(store, key, variation)))
    return shots


def focus_of(shot: Shot, actor_tracks: list[ActorTrack], geometry=None) -> framing.Focus:
    """First contact, else (when no violation time is the key) the closest approach, else where the lone vehicle
    left the road, else the lone vehicle at the end."""
    c = shot.contact
    if c is not None and (shot.t_key is None or shot.t_key >= c["t"] - 0.5) and c["x"] is not None:
        return framing.Focus("contact", float(c["t"]), float(c["x"]), float(c["y"]), pair=(c["actor_a"], c["actor_b"]))
    t_end = float(max(tr.t[-1] for tr in actor_tracks))
    if shot.t_key is not None:
        ads = next((tr for tr in actor_tracks if tr.is_ads), actor_tracks[0])
        x, y, _ = ads.at(shot.t_key)
        return framing.Focus("alone", min(float(shot.t_key), t_end), x, y)
    ads = next((tr.role for tr in actor_tracks if tr.is_ads), None) if shot.name in CLOSEST_CALLS else None
    departure = framing.road_departure(geometry, actor_tracks[0]) if geometry is not None else None
    return (framing.closest_approach(actor_tracks, ads) or framing.closest_approach(actor_tracks) or departure
            or framing.alone(actor_tracks, t_end))


def draw_shots(shots: list[Shot]) -> dict:
    """Data URIs (and captions) of every shot; what cannot be drawn becomes a note, never an exception."""
    from crashscene.report.build import data_uri
    from crashscene.report.roadmap import load_map

    fig: dict = {"notes": []}
    for shot in shots:
        try:
            work = Path(shot.work_dir)
            actor_tracks, run_dir = shot.tracks, None
            if not actor_tracks:
                run_dir = tracks.ensure_run_dir(work, shot.case_id, shot.run, shot.variation)
                actor_tracks = tracks.load_tracks(run_dir, shot.variation)
            map_file = tracks.map_file_of(run_dir, work)
            if map_file is None:
                raise ReportError(f"{work}: no render/map.xodr")
            if not actor_tracks:
                raise ReportError(f"{shot.case_id}: no trace rows for {shot.mode} variation {shot.variation}")
            geometry = load_map(map_file)
            focus = focus_of(shot, actor_tracks, geometry)
            frame = framing.choose_frame(geometry, actor_tracks, focus)
            where = f"{shot.mode} mode, variation {shot.variation}"
            if shot.name.startswith("gif_"):
                t_end = float(max(tr.t[-1] for tr in actor_tracks))
                t_key = focus.t if shot.t_key is None else float(shot.t_key)
                after = GIF_AFTER if shot.name == "gif_reproduce" else GIF_AFTER_VIOLATION
                t0, t1 = max(0.0, t_key - GIF_BEFORE), min(t_end, t_key + after)
                gif = birdseye.animation_gif(geometry, actor_tracks, frame, t0, t1, f"{shot.case_id} {where}",
                                             impact=focus)
                fig[shot.name] = data_uri(gif, "image/gif")
                fig[shot.name + "_caption"] = f"{shot.label}: {where}, t = {t0:.1f}-{t1:.1f} s"
            else:
                png = birdseye.still_png(geometry, actor_tracks, frame, focus, f"{shot.case_id} {where}: {shot.label}")
                fig[shot.name] = data_uri(png, "image/png")
                fig[shot.name + "_caption"] = _caption(shot, focus, where, geometry.north)
        except Exception as exc:  # noqa: BLE001  (one missing picture must not sink the whole report)
            fig["notes"].append(f"{shot.name} ({shot.mode} #{shot.variation}) not drawn: {type(exc).__name__}: {exc}")
    return fig


def _caption(shot: Shot, focus: framing.Focus, where: str, north: bool) -> str:
    moment = {"contact": "at the first contact (star)",
              "closest": f"at the closest approach, {focus.gap:.1f} m between footprints" if focus.gap is not None
              else "at the closest approach",
              "departure": f"{framing.DEPARTURE_AFTER:g} s after leaving the road",
              "alone": "at the key moment" if shot.t_key is not None else "at the end"}[focus.kind]
    orientation = "north up" if north else "no north on this generated map: the ego approaches from the left"
    return f"{shot.label} ({where}) {moment}, t = {focus.t:.1f} s; {orientation}"
