"""Bird's-eye pictures on a real OpenDRIVE map (CARLA Town02 from tests/data), from hand-made tracks."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from crashscene.report.birdseye import ActorTrack, animation_gif, still_png

TOWN02 = Path(__file__).resolve().parents[1] / "data" / "maps" / "carla" / "Town02.xodr"


@pytest.fixture(scope="module")
def town02(tmp_path_factory) -> Path:
    copy = tmp_path_factory.mktemp("maps") / "Town02.xodr"  # Scenic writes its .snet cache beside the map
    copy.write_bytes(TOWN02.read_bytes())
    return copy


def _tracks() -> list[ActorTrack]:
    t = np.arange(0.0, 8.0, 0.1)  # [s]
    ego = ActorTrack("ego", t, np.full_like(t, -7.5), -290.0 + 8.0 * t, np.full_like(t, np.pi / 2), 4.8, 2.0)
    npc = ActorTrack("npc1", t, np.full_like(t, -7.5), np.full_like(t, -245.0), np.full_like(t, np.pi / 2), 4.5, 1.9)
    return [ego, npc]


def test_pose_at_a_time_is_the_last_sample_before_it():
    ego = _tracks()[0]
    assert ego.at(1.05) == pytest.approx((-7.5, -290.0 + 8.0 * 1.0, np.pi / 2))
    assert ego.at(-1.0)[1] == pytest.approx(-290.0) and ego.at(99.0)[1] == pytest.approx(-290.0 + 8.0 * 7.9)


@pytest.mark.slow
def test_still_is_a_png_showing_road_and_actors(town02):
    png = still_png(town02, _tracks(), 5.5, "impact", impact=(-7.5, -247.0))
    with Image.open(io.BytesIO(png)) as img:
        assert img.format == "PNG" and img.width >= 400
        colors = {c for _, c in img.convert("RGB").getcolors(1 << 20)}
    assert (0x1f, 0x77, 0xb4) in colors and (0xd6, 0x27, 0x28) in colors  # ego blue, npc1 red boxes
    assert (0x4d, 0x4d, 0x4d) in colors  # asphalt from the map's drivable area


@pytest.mark.slow
def test_gif_animates_the_window(town02):
    gif = animation_gif(town02, _tracks(), 1.0, 5.0, "window")
    with Image.open(io.BytesIO(gif)) as img:
        assert img.format == "GIF" and img.n_frames == 21  # 4 s at 0.2 s per frame, both ends included
        img.seek(0)
        first = np.asarray(img.convert("RGB")).copy()
        img.seek(img.n_frames - 1)
        assert not np.array_equal(first, np.asarray(img.convert("RGB")))  # the ego moved
