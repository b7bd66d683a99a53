"""Bird's-eye pictures on a real OpenDRIVE map (CARLA Town02 from tests/data), from hand-made tracks."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from crashscene.report import framing
from crashscene.report.birdseye import animation_gif, still_png
from crashscene.report.palette import color_of, label_of, rgb
from crashscene.report.roadmap import load_map
from crashscene.report.tracks import ActorTrack

TOWN02 = Path(__file__).resolve().parents[1] / "data" / "maps" / "carla" / "Town02.xodr"


@pytest.fixture(scope="module")
def town02(tmp_path_factory):
    copy = tmp_path_factory.mktemp("maps") / "Town02.xodr"  # Scenic writes its .snet cache beside the map
    copy.write_bytes(TOWN02.read_bytes())
    return load_map(copy)


def _tracks() -> list[ActorTrack]:
    t = np.arange(0.0, 8.0, 0.1)  # [s]
    ego = ActorTrack("ego", t, np.full_like(t, -7.5), -290.0 + 8.0 * t, np.full_like(t, np.pi / 2), 4.8, 2.0)
    npc = ActorTrack("npc1", t, np.full_like(t, -7.5), np.full_like(t, -245.0), np.full_like(t, np.pi / 2), 4.5, 1.9)
    return [ego, npc]


def _colors(png: bytes) -> set[tuple[int, int, int]]:
    with Image.open(io.BytesIO(png)) as img:
        return {c for _, c in img.convert("RGB").getcolors(1 << 20)}


def test_labels_follow_the_dsl_and_colours_follow_the_sketches():
    assert label_of("ego", None) == "V1" and label_of("npc2", "") == "V3" and label_of("npc1", "v4") == "V4"
    assert color_of("V1") == "#d7191c" and color_of("V2") == "#1f4e9c"  # V1 red, V2 blue, as sketches draw them
    assert color_of("V9") == color_of("V1") and color_of("pedestrian") != color_of("V1")
    assert [tr.label for tr in _tracks()] == ["V1", "V2"]


def test_pose_at_a_time_is_the_last_sample_before_it():
    ego = _tracks()[0]
    assert ego.at(1.05) == pytest.approx((-7.5, -290.0 + 8.0 * 1.0, np.pi / 2))
    assert ego.at(-1.0)[1] == pytest.approx(-290.0) and ego.at(99.0)[1] == pytest.approx(-290.0 + 8.0 * 7.9)


def test_closest_approach_is_the_gap_between_footprints():
    t = np.arange(0.0, 4.0, 0.1)
    a = ActorTrack("ego", t, 10.0 * t, np.zeros_like(t), np.zeros_like(t), 4.0, 2.0)
    b = ActorTrack("npc1", t, 40.0 - 10.0 * t, np.full_like(t, 5.0), np.full_like(t, np.pi), 4.0, 2.0)
    focus = framing.closest_approach([a, b])
    assert focus.kind == "closest" and focus.gap == pytest.approx(3.0, abs=1e-6)  # 5 m apart, 1 m half widths
    assert focus.t == pytest.approx(2.0, abs=0.05) and focus.y == pytest.approx(2.5, abs=1e-6)
    assert framing.closest_approach([a]) is None


@pytest.mark.slow
def test_frame_is_centred_on_the_contact_and_never_the_whole_map(town02):
    focus = framing.Focus("contact", 5.5, -7.5, -247.0, pair=("ego", "npc1"))
    frame = framing.choose_frame(town02, _tracks(), focus)
    assert (frame.cx, frame.cy) == (-7.5, -247.0)
    assert framing.MIN_HALF[0] <= frame.hx <= framing.MAX_HALF and frame.hy <= frame.hx


@pytest.mark.slow
def test_a_vehicle_off_the_road_is_framed_with_the_road(town02):
    x, y, _ = town02.nearest_road_point(-7.5, -200.0)
    assert town02.nearest_road_point(x, y)[2] == pytest.approx(0.0, abs=1e-6)
    t = np.arange(0.0, 2.0, 0.1)
    off = next(dx for dx in (-30.0, -40.0, -50.0, 30.0, 40.0, 50.0) if town02.nearest_road_point(x + dx, y)[2] > 15.0)
    far = ActorTrack("ego", t, np.full_like(t, x + off), np.full_like(t, y), np.zeros_like(t), 4.5, 1.9)
    rx, ry, dist = town02.nearest_road_point(x + off, y)
    frame = framing.choose_frame(town02, [far], framing.alone([far], 1.0))
    assert abs(rx - frame.cx) < frame.hx and abs(ry - frame.cy) < frame.hy  # the nearest road is in the frame
    assert frame.hx <= framing.MAX_HALF


@pytest.mark.slow
def test_still_shows_road_and_vehicles_in_label_colours(town02):
    focus = framing.Focus("contact", 5.5, -7.5, -247.0, pair=("ego", "npc1"))
    frame = framing.choose_frame(town02, _tracks(), focus)
    png = still_png(town02, _tracks(), frame, focus, "impact")
    with Image.open(io.BytesIO(png)) as img:
        assert img.format == "PNG" and img.width == 640
    colors = _colors(png)
    assert rgb(color_of("V1")) in colors and rgb(color_of("V2")) in colors
    assert (0xc9, 0xc9, 0xc9) in colors  # asphalt from the map's drivable area
    assert png == still_png(town02, _tracks(), frame, focus, "impact")  # same input, same bytes


@pytest.mark.slow
def test_gif_animates_the_window(town02):
    focus = framing.Focus("contact", 5.5, -7.5, -247.0, pair=("ego", "npc1"))
    frame = framing.choose_frame(town02, _tracks(), focus)
    gif = animation_gif(town02, _tracks(), frame, 1.0, 5.0, "window", impact=focus)
    with Image.open(io.BytesIO(gif)) as img:
        assert img.format == "GIF" and img.n_frames == 21  # 4 s at 0.2 s per frame, both ends included
        img.seek(0)
        first = np.asarray(img.convert("RGB")).copy()
        img.seek(img.n_frames - 1)
        assert not np.array_equal(first, np.asarray(img.convert("RGB")))  # the ego moved


@pytest.mark.slow
def test_a_run_off_road_is_shown_just_after_the_departure(town02):
    x, y, _ = town02.nearest_road_point(-7.5, -200.0)
    t = np.arange(0.0, 6.0, 0.1)
    off = next(dx for dx in (-30.0, -40.0, 30.0, 40.0) if town02.nearest_road_point(x + dx, y)[2] > 15.0)
    xs = x + np.clip(t - 2.0, 0.0, None) * np.sign(off) * 10.0  # on the road for 2 s, then straight off it
    car = ActorTrack("ego", t, xs, np.full_like(t, y), np.zeros_like(t), 4.5, 1.9)
    focus = framing.road_departure(town02, car)
    assert focus is not None and focus.kind == "departure"
    leave = t[np.argmax([town02.nearest_road_point(a, y)[2] > 0 for a in xs])]
    assert focus.t == pytest.approx(leave + framing.DEPARTURE_AFTER, abs=1e-9)
    assert framing.road_departure(town02, ActorTrack("ego", t, np.full_like(t, x), np.full_like(t, y),
                                                     np.zeros_like(t), 4.5, 1.9)) is None
