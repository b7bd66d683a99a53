"""Generated OpenDRIVE maps (lane-linked junctions, signals, speed limit, markings), CARLA town choice, cache."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from crashscene.dsl import load_file
from crashscene.render.errors import RenderError
from crashscene.render.maps import carla_town, install_map, prepare_map
from crashscene.render.opendrive import build_map
from crashscene.render.plan import INIT_DIST, ONCOMING_DIST, MapSpec, convert

from tests.conftest import CARLA_MAPS, EXAMPLES

REPO_CACHE = Path(__file__).resolve().parents[2] / ".crashscene-cache" / "maps"


def spec(**kw) -> MapSpec:
    base = {"topology": "intersection", "lanes_forward": 1, "lanes_backward": 1, "center_mark": "double_solid_line",
                "speed_limit": 15.6, "back_length": 300.0, "ahead_length": 300.0, "arms": ["ego", "left", "opposite", "right"],
                "controls": {}}
    base.update(kw)
    return MapSpec(**base)


def network(path: Path):
    from scenic.domains.driving.roads import Network

    return Network.fromFile(path, useCache=False, writeCache=False)


@pytest.mark.parametrize("arms,maneuvers", [
    (["ego", "left", "opposite", "right"], 12), (["ego", "opposite", "right"], 6),
    (["ego", "opposite", "left"], 6), (["ego", "left", "right"], 6),
])
def test_lane_linked_junctions_have_no_bogus_u_turns(tmp_path, arms, maneuvers):
    from scenic.domains.driving.roads import ManeuverType

    net = network(build_map(spec(arms=arms), tmp_path / "j.xodr"))
    (inter,) = net.intersections
    assert len(inter.maneuvers) == maneuvers
    assert not [m for m in inter.maneuvers if m.type is ManeuverType.U_TURN]
    for lane in inter.incomingLanes:  # one manoeuvre per exit from each approach
        assert len(lane.maneuvers) == len(arms) - 1


def test_signals_on_controlled_approaches(tmp_path):
    path = build_map(spec(controls={"ego": "traffic_light", "left": "traffic_light", "opposite": "traffic_light",
                                    "right": "traffic_light"}), tmp_path / "j.xodr")
    (inter,) = network(path).intersections
    assert inter.signals and all(s.isTrafficLight for s in inter.signals)
    root = ET.parse(path).getroot()
    assert root.findall(".//object[@subtype='stopLine']"), "stop lines on signalised approaches"


def test_stop_sign_on_one_approach(tmp_path):
    path = build_map(spec(controls={"right": "stop_sign"}), tmp_path / "j.xodr")
    (inter,) = network(path).intersections
    assert {(s.country, s.type) for s in inter.signals} == {("US", "R1-1")}  # MUTCD stop sign
    right_road = ET.parse(path).getroot().find(".//road[@id='4']")  # arms: ego=1, left=2, opposite=3, right=4
    assert right_road.find(".//signal").get("type") == "R1-1"


def test_speed_limit_and_centre_marking(tmp_path):
    path = build_map(spec(topology="straight", arms=[], speed_limit=24.5872, center_mark="double_solid_line"),
                     tmp_path / "s.xodr")
    root = ET.parse(path).getroot()
    assert float(root.find(".//type/speed").get("max")) == pytest.approx(24.5872, abs=1e-3)
    center = root.find(".//center/lane/roadMark")
    assert center.get("type") == "solid solid"


@pytest.mark.parametrize("direction,sign", [("left", 1), ("right", -1)])
def test_curve_direction(tmp_path, direction, sign):
    from crashscene.render.scenic_support import _curve_start, _road_lanes

    path = build_map(spec(topology="curve", arms=[], curve_direction=direction, curve_radius=150.0,
                          curve_angle=1.3), tmp_path / "c.xodr")
    net = network(path)
    forward = [lane for lane in _road_lanes(net) if lane.group is lane.road.forwardLanes]
    assert forward and _curve_start(forward[0], sign, 0.5) == pytest.approx(300.0, abs=3.0)
    assert _curve_start(forward[0], -sign, 0.5) is None


def test_road_lengths_cover_the_horizon(tmp_path):
    plan = convert(load_file(EXAMPLES / "3-C1-2018-007" / "golden.yaml"))  # 70 mph, oncoming actor
    net = network(build_map(plan.map, tmp_path / "m.xodr"))
    longest = max(lane.centerline.length for lane in net.lanes)
    assert longest >= plan.map.back_length + plan.map.ahead_length - 1.0
    # the oncoming actor starts at least ONCOMING_DIST[0] - INIT_DIST[1] past the anchor and drives back over it
    assert plan.map.back_length + ONCOMING_DIST[0] - INIT_DIST[1] >= plan.actors[1].speed.high * plan.horizon


def test_generated_map_cache_is_keyed_by_inputs(tmp_path):
    plan = convert(load_file(EXAMPLES / "120013" / "golden.yaml"))
    first, town = prepare_map(plan, "generated", cache_dir=tmp_path, warm=False)
    again, _ = prepare_map(plan, "generated", cache_dir=tmp_path, warm=False)
    assert town is None and first == again and first.parent == tmp_path
    other, _ = prepare_map(convert(load_file(EXAMPLES / "100237" / "golden.yaml")), "generated", cache_dir=tmp_path,
                           warm=False)
    assert other != first


@pytest.mark.slow
def test_warm_cache_installs_snet_beside_the_output_map(tmp_path):
    plan = convert(load_file(EXAMPLES / "120013" / "golden.yaml"))
    cached, _ = prepare_map(plan, "generated", cache_dir=tmp_path / "cache")
    assert cached.with_suffix(".snet").exists()
    out = install_map(cached, tmp_path)
    assert out.read_bytes() == cached.read_bytes() and out.with_suffix(".snet").exists()


@pytest.mark.parametrize("case,town", [("120013", "Town02"), ("108812", "Town02"), ("3-C1-2017-001", "Town04"),
                                       ("121520", "Town05"), ("119489", "Town05")])
def test_carla_town_selection(case, town):
    assert carla_town(convert(load_file(EXAMPLES / case / "golden.yaml"))) == town


def test_missing_carla_town_is_a_clear_error(tmp_path):
    plan = convert(load_file(EXAMPLES / "121520" / "golden.yaml"))
    with pytest.raises(RenderError, match=r"Town05\.xodr"):
        prepare_map(plan, "carla", carla_maps=CARLA_MAPS, cache_dir=tmp_path, warm=False)
    path, town = prepare_map(plan, "carla", carla_maps=CARLA_MAPS, cache_dir=tmp_path, warm=False,
                             town_override={"Town05": "Town10HD"})
    assert town == "Town10HD" and path.read_bytes() == (CARLA_MAPS / "Town10HD.xodr").read_bytes()


def test_carla_mode_needs_a_folder_and_unknown_modes_fail(tmp_path):
    plan = convert(load_file(EXAMPLES / "120013" / "golden.yaml"))
    with pytest.raises(RenderError, match="--carla-maps"):
        prepare_map(plan, "carla", cache_dir=tmp_path, warm=False)
    with pytest.raises(RenderError, match="allowed: generated, carla"):
        prepare_map(plan, "osm", cache_dir=tmp_path, warm=False)


@pytest.mark.slow
def test_unreadable_carla_map_is_a_clear_error(tmp_path):
    towns = tmp_path / "towns"
    towns.mkdir()
    (towns / "Town02.xodr").write_text("<OpenDRIVE><road>not a map")
    plan = convert(load_file(EXAMPLES / "120013" / "golden.yaml"))
    with pytest.raises(RenderError, match="Town02.xodr"):
        prepare_map(plan, "carla", carla_maps=towns, cache_dir=tmp_path / "cache")


# ---------------------------------------------------------------- ASAM's OpenDRIVE checker bundle

def _asam_check(path: Path) -> list[str]:
    """Problems ASAM's qc_opendrive finds in `path` as declared (1.8) and re-declared as 1.7, so that every
    checker of the bundle runs on it: one rule applies up to 1.7 only, one from 1.8 on."""
    from crashscene.export.check import check_file

    declared = check_file(path)
    assert ET.parse(path).getroot().find("header").get("revMinor") == "8"
    as_17 = path.with_name(path.stem + "_as17.xodr")
    as_17.write_text(path.read_text(encoding="utf-8").replace('revMinor="8"', 'revMinor="7"', 1), encoding="utf-8")
    older = check_file(as_17)
    ran = {c.checker_id for r in (declared, older) for c in r.checkers if c.status == "completed"}
    everything = {c.checker_id for c in declared.checkers}
    problems = [r.describe() for r in (declared, older) if not r.ok]
    if ran != everything:
        problems.append(f"checkers that never ran: {sorted(everything - ran)}")
    return problems


OPTION_SPECS = {  # every topology and option render generates
    "straight_1+1_double_solid_limit": spec(topology="straight", arms=[], speed_limit=24.5872),
    "straight_3+0_oneway_no_limit": spec(topology="straight", arms=[], lanes_forward=3, lanes_backward=0,
                                         center_mark="none", speed_limit=None),
    "straight_2+2_broken": spec(topology="straight", arms=[], lanes_forward=2, lanes_backward=2,
                                center_mark="broken_line", speed_limit=31.3),
    "straight_2+1_solid_and_broken": spec(topology="straight", arms=[], lanes_forward=2, lanes_backward=1,
                                          center_mark="solid_and_broken_line"),
    "curve_left_1+1_solid": spec(topology="curve", arms=[], curve_direction="left", curve_radius=80.0,
                                 curve_angle=1.3, center_mark="solid_line"),
    "curve_right_2+2": spec(topology="curve", arms=[], lanes_forward=2, lanes_backward=2, curve_direction="right",
                            curve_radius=300.0, curve_angle=1.3, center_mark="not_mentioned"),
    "intersection_traffic_lights": spec(controls={a: "traffic_light" for a in ("ego", "left", "opposite", "right")}),
    "intersection_2+2_stop_signs": spec(lanes_forward=2, lanes_backward=2, cross_lanes=2,
                                        controls={"left": "stop_sign", "right": "stop_sign"}),
    "intersection_oneway_yield": spec(lanes_forward=2, lanes_backward=0, controls={"ego": "yield_sign"}),
    "t_opposite_right_stop": spec(topology="t_intersection", arms=["ego", "opposite", "right"],
                                  controls={"right": "stop_sign"}),
    "t_opposite_left_yield_3+3": spec(topology="t_intersection", arms=["ego", "opposite", "left"], lanes_forward=3,
                                      lanes_backward=3, controls={"ego": "yield_sign"}),
    "t_left_right_lights": spec(topology="t_intersection", arms=["ego", "left", "right"], cross_lanes=2,
                                controls={a: "traffic_light" for a in ("ego", "left", "right")}),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(OPTION_SPECS))
def test_generated_maps_pass_asam_opendrive_checker(tmp_path, name):
    path = build_map(OPTION_SPECS[name], tmp_path / f"{name}.xodr")
    assert not _asam_check(path), "\n".join(_asam_check(path))


def test_asam_checker_catches_an_invalid_map(tmp_path):
    """The check above can fail: a map with an out-of-schema object and a dangling junction link does."""
    path = build_map(spec(controls={"ego": "stop_sign"}), tmp_path / "bad.xodr")
    text = path.read_text(encoding="utf-8").replace('type="roadMark"', 'type="stopMarking"', 1)
    path.write_text(text, encoding="utf-8")
    problems = _asam_check(path)
    assert problems and "stopMarking" in "\n".join(problems)


def test_same_spec_same_bytes(tmp_path):
    """Signal/object ids and the header date do not depend on the process's history or the clock."""
    one = build_map(spec(controls={"ego": "traffic_light", "right": "stop_sign"}), tmp_path / "a.xodr").read_bytes()
    build_map(spec(controls={"left": "yield_sign"}), tmp_path / "other.xodr")
    two = build_map(spec(controls={"ego": "traffic_light", "right": "stop_sign"}), tmp_path / "b.xodr").read_bytes()
    assert one == two
