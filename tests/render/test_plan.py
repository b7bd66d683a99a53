"""DSL -> render plan: defaults table, placements, queueing, and that only tokens and numbers survive."""
from __future__ import annotations

import math

import pytest

from crashscene.dsl import load_file, loads
from crashscene.dsl.tokens import TimeOfDay, Weather
from crashscene.monitor.rules.speed import unposted_limit
from crashscene.render.plan import (
    EGO_BLUEPRINT,
    MPH,
    Placement,
    RenderPlan,
    carla_weather,
    convert,
    scenario_hash,
)

from tests.conftest import CASES, EXAMPLES

BASE = """
environment: {weather: clear, time_of_day: daytime}
road_network:
  road_type: %(road_type)s
  number_of_ways: %(ways)s
  number_of_lanes: %(lanes)s
  road_marker: broken_line
  traffic_signs: [%(signs)s]
actors:
  ego: {type: car, behavior: %(ego_behavior)s, position: {reference: %(ego_ref)s, relation: behind}}
%(npcs)s
oracle: []
"""


def scenario(road_type="straight", ways=2, lanes=2, signs="", ego_behavior="go_forward", ego_ref="road", npcs=""):
    return loads(BASE % {"road_type": road_type, "ways": ways, "lanes": lanes, "signs": signs, "ego_behavior": ego_behavior,
                             "ego_ref": ego_ref, "npcs": npcs})


@pytest.mark.parametrize("case", CASES)
def test_every_golden_file_converts(case):
    plan = convert(load_file(EXAMPLES / case / "golden.yaml"))
    assert isinstance(plan, RenderPlan)
    assert plan.actors[0].role == "ego" and plan.actors[0].placement is Placement.ANCHOR
    assert plan.actors[0].blueprints == [EGO_BLUEPRINT]
    for actor in plan.actors:
        assert actor.speed.low <= actor.speed.high
        assert actor.init_dist.low >= 0
    # the map is long enough for the fastest actor over the whole horizon
    fastest = max(a.speed.high for a in plan.actors)
    assert plan.map.ahead_length >= fastest * plan.horizon


@pytest.mark.parametrize("weather,time,expected", [
    (Weather.CLEAR, TimeOfDay.NIGHTTIME, "ClearNight"), (Weather.CLOUDY, TimeOfDay.DAYTIME, "CloudyNoon"),
    (Weather.RAINY, TimeOfDay.DAYTIME, "WetNoon"), (Weather.RAINY, TimeOfDay.NIGHTTIME, "WetNight"),
    (Weather.CLEAR, TimeOfDay.DUSK, "ClearSunset"), (Weather.NOT_MENTIONED, TimeOfDay.NOT_MENTIONED, "ClearNoon"),
])
def test_weather_presets(weather, time, expected):
    assert carla_weather(weather, time) == expected


def test_wet_surface_makes_clear_weather_wet():
    assert carla_weather(Weather.CLEAR, TimeOfDay.DAYTIME, "wet") == "WetNoon"


def test_time_of_day_hours():
    plan = convert(scenario())
    assert plan.hour == 12.0
    night = loads(BASE.replace("daytime", "nighttime") % {"road_type": "straight", "ways": 2, "lanes": 2, "signs": "",
                                                               "ego_behavior": "go_forward", "ego_ref": "road", "npcs": ""})
    assert convert(night).hour == 22.0


@pytest.mark.parametrize("road_type, ways, lanes, mph", [
    ("straight", 2, 2, 55), ("curve", 2, 2, 55), ("straight", 2, 4, 65), ("straight", 1, 2, 65),
    ("intersection", 2, 2, 25), ("t_intersection", 2, 4, 25)])
def test_unstated_speed_is_up_to_the_limit_the_speed_rules_apply_where_none_is_posted(road_type, ways, lanes, mph):
    """A report silent on both the speed and the limit: traffic drives up to the limit the monitor applies there
    (rules.md rule 7: 25 mph in a junction, 55 mph on a two-lane two-way road, 65 mph otherwise), the same
    law-abiding range a posted limit gives, not the reference pipeline's 10 m/s on a rural highway."""
    kw = {"curve": "\n  curve_direction: left"}.get(road_type, "")
    plan = convert(loads((BASE % {"road_type": road_type, "ways": ways, "lanes": lanes, "signs": "",
                                  "ego_behavior": "go_forward", "ego_ref": "road", "npcs": ""}).replace(
        "  traffic_signs: []", "  traffic_signs: []" + kw)))
    assert plan.speed_limit is None  # nothing posted reaches the map or the program
    speed = plan.actors[0].speed
    limit = mph * MPH
    assert speed.high == pytest.approx(limit, abs=1e-3)
    assert speed.low == pytest.approx(limit - 2 * max(2.0, 0.1 * limit), abs=1e-3)  # as under a posted limit
    assert unposted_limit(ways, lanes, road_type in ("intersection", "t_intersection")) == pytest.approx(mph * MPH)


def test_an_actor_charged_with_speeding_at_an_unposted_junction_is_sampled_by_its_approachs_limit():
    """The monitor judges a speeder on its approach by the road's default (55 mph on a two-lane two-way road), not
    the junction's 25 mph: sampled around 25 mph it could not speed there (3-C2-2018-008 with its limit unstated:
    a rear-end on the approach, 0 of 20 reproduced). A law-abiding actor keeps to the junction's limit."""
    s = BASE % {"road_type": "t_intersection", "ways": 2, "lanes": 2, "signs": "", "ego_behavior": "stop",
                "ego_ref": "intersection", "npcs": "  npc1: {type: car, behavior: go_forward, position: "
                "{reference: ego, relation: behind, heading: same_direction}}"}
    s = s.replace("oracle: []", "oracle:\n  - {code: CVC_22350, violation: unsafe_speed, actor: npc1}")
    plan = convert(loads(s))
    speeder = next(a for a in plan.actors if a.role == "npc1")
    assert speeder.speed.low < 55 * MPH < speeder.speed.high
    calm = convert(loads(s.replace("actor: npc1", "actor: ego").replace("behavior: stop", "behavior: go_forward")))
    assert next(a for a in calm.actors if a.role == "npc1").speed.high == pytest.approx(25 * MPH, abs=1e-3)


def test_stated_speed_and_limit_set_the_nominal_speed():
    s = scenario(npcs="  npc1: {type: car, behavior: go_forward, speed_mph: 40, "
                      "position: {reference: ego, relation: front, heading: same_direction}}")
    plan = convert(s)
    npc = plan.actors[1]
    assert npc.speed.low < 40 * MPH < npc.speed.high


def test_standing_actors_have_zero_speed():
    s = scenario(npcs="  npc1: {type: car, behavior: static, position: {reference: ego, relation: front, "
                      "heading: same_direction}}")
    assert convert(s).actors[1].speed.high == 0.0


def test_truck_blueprint():
    s = scenario(npcs="  npc1: {type: truck, behavior: go_forward, position: {reference: ego, relation: front}}")
    plan = convert(s)
    assert plan.actors[1].blueprints == ["vehicle.carlamotors.european_hgv"]
    assert plan.actors[1].heading_relation is None
    assert plan.actors[1].placement is Placement.ONCOMING  # default heading: opposite_direction
    assert any("opposite_direction assumed" in n for n in plan.notes)


def test_an_ego_of_another_type_has_that_types_body():
    # the ego's fixed blueprint is a car's; a truck ego (a tractor-trailer in the report) is a truck's size
    s = loads(BASE.replace("ego: {type: car,", "ego: {type: truck,") % {
        "road_type": "straight", "ways": 2, "lanes": 2, "signs": "", "ego_behavior": "go_forward", "ego_ref": "road",
        "npcs": ""})
    assert convert(s).actors[0].blueprints == ["vehicle.carlamotors.european_hgv"]
    assert convert(scenario()).actors[0].blueprints == [EGO_BLUEPRINT]


@pytest.mark.parametrize("relation,heading,placement", [
    ("front", "same_direction", Placement.FOLLOW), ("behind", "same_direction", Placement.FOLLOW),
    ("left", "same_direction", Placement.SIDE_LEFT), ("right", "same_direction", Placement.SIDE_RIGHT),
    ("front", "opposite_direction", Placement.ONCOMING),
])
def test_placements_on_roads(relation, heading, placement):
    s = scenario(lanes=4, npcs=f"  npc1: {{type: car, behavior: go_forward, position: {{reference: ego, "
                               f"relation: {relation}, heading: {heading}}}}}")
    assert convert(s).actors[1].placement is placement


@pytest.mark.parametrize("heading,angle", [("from_left", -math.pi / 2), ("from_right", math.pi / 2)])
def test_crossing_traffic_at_junction_is_an_approach(heading, angle):
    side = "left" if heading == "from_left" else "right"
    s = scenario(road_type="intersection", ego_ref="intersection",
                 npcs=f"  npc1: {{type: car, behavior: go_forward, position: {{reference: intersection, "
                      f"relation: {side}, heading: {heading}}}}}")
    npc = convert(s).actors[1]
    assert npc.placement is Placement.APPROACH and npc.relative_heading == pytest.approx(angle)
    assert npc.arrival_offset is not None


def test_followers_queue_instead_of_overlapping():
    plan = convert(load_file(EXAMPLES / "3-C5-2018-004" / "golden.yaml"))  # four vehicles ahead of the ego
    refs = {a.role: a.placement_ref for a in plan.actors}
    assert refs == {"ego": "ego", "npc1": "ego", "npc2": "npc1", "npc3": "npc2", "npc4": "npc3"}


def test_overtaker_queues_behind_the_vehicle_it_passes():
    plan = convert(load_file(EXAMPLES / "3-C2-2017-004" / "golden.yaml"))
    npc1 = next(a for a in plan.actors if a.role == "npc1")
    assert npc1.behavior == "overtake" and npc1.placement_ref == "npc2" and npc1.along == "behind"


def test_side_lanes_widen_a_too_narrow_generated_road():
    s = scenario(lanes=2, npcs="  npc1: {type: car, behavior: go_forward, position: {reference: ego, "
                               "relation: left, heading: same_direction}}")
    plan = convert(s)
    assert plan.map.lanes_forward == 2 and any("widened" in n for n in plan.notes)


def test_one_way_road_with_oncoming_actor_gets_opposing_carriageway():
    plan = convert(load_file(EXAMPLES / "3-C1-2018-007" / "golden.yaml"))
    assert plan.map.lanes_forward == 7 and plan.map.lanes_backward == 7


def test_t_layout_serves_left_turn_with_traffic_from_left():
    plan = convert(load_file(EXAMPLES / "119489" / "golden.yaml"))  # ego turns left, npc1 from the left
    assert plan.map.arms == ["ego", "left", "right"]  # ego on the stem


def test_stop_sign_controls_the_naming_actor_else_the_ego():
    plan = convert(load_file(EXAMPLES / "117021" / "golden.yaml"))
    assert plan.map.controls == {"ego": "stop_sign"}
    plan = convert(load_file(EXAMPLES / "100237" / "golden.yaml"))  # yield sign named by npc1 (from right)
    assert plan.map.controls == {"right": "yield_sign"}
    assert plan.actors[1].controlled_by == "yield_sign"


def test_traffic_light_signals_every_approach():
    plan = convert(load_file(EXAMPLES / "121520" / "golden.yaml"))
    assert set(plan.map.controls.values()) == {"traffic_light"} and len(plan.map.controls) == 4


def test_dispositions_attributed():
    plan = convert(load_file(EXAMPLES / "117330" / "golden.yaml"))
    assert plan.actors[1].dispositions == ["CVC_22350", "CVC_21650", "CVC_21460"]
    assert plan.actors[0].dispositions == []


def test_hostile_label_is_dropped_not_rendered():
    s = scenario(npcs="  npc1: {label: \"V2'); import os #\", type: car, behavior: go_forward, "
                      "position: {reference: ego, relation: front, heading: same_direction}}")
    assert convert(s).actors[1].label is None


def test_scenario_hash_is_stable_and_option_sensitive():
    s = load_file(EXAMPLES / "100237" / "golden.yaml")
    assert scenario_hash(s, map_mode="generated") == scenario_hash(load_file(EXAMPLES / "100237" / "golden.yaml"),
                                                                    map_mode="generated")
    assert scenario_hash(s, map_mode="generated") != scenario_hash(s, map_mode="carla")


@pytest.mark.parametrize("relation,along", [("behind", "behind"), ("front", "front"), ("left", "behind"),
                                            ("right", "behind")])
def test_ego_relation_to_its_road_element(relation, along):
    s = loads((BASE % dict(road_type="intersection", ways=2, lanes=2, signs="", ego_behavior="go_forward",
                           ego_ref="intersection", npcs="")).replace("relation: behind", f"relation: {relation}"))
    assert convert(s).actors[0].along == along


def test_law_abiding_actors_stay_at_or_below_the_posted_limit():
    plan = convert(load_file(EXAMPLES / "117330" / "golden.yaml"))  # 50 mph; npc1 charged with CVC_22350
    limit = 50 * MPH
    ego, npc = plan.actors
    assert ego.speed.high == pytest.approx(limit, abs=1e-3) and ego.speed.low < limit
    assert npc.speed.low < limit < npc.speed.high  # unsafe speed: may exceed the limit


def test_vehicle_standing_ahead_leaves_room_to_stop():
    """120013: V2 stopped in V1's lane on a 55 mph road. At 15-20 m no driver could stop; the gap scales
    with the ego's top speed so that a prudent driver can, while a moving leader keeps INIT_DIST."""
    scenario = load_file(EXAMPLES / "120013" / "golden.yaml")
    plan = convert(scenario)
    ego, lead = plan.actors[0], plan.actors[1]
    reaction, braking = 0.5, 6.0  # [s], [m/s2]
    stopping = ego.speed.high * reaction + ego.speed.high ** 2 / (2 * braking)
    assert lead.init_dist.low > stopping
    moving = loads((EXAMPLES / "120013" / "golden.yaml").read_text().replace("behavior: stop", "behavior: go_forward"))
    assert (convert(moving).actors[1].init_dist.low, convert(moving).actors[1].init_dist.high) == (15.0, 20.0)
