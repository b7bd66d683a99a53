"""Reproduce mode on synthetic scenarios, one per crash configuration of issue 10: the first contact (the same
two actors, the same class) happens in at least 90% of the valid variations; a cascade; same seed, same bytes."""
from __future__ import annotations

import warnings

import pyarrow.parquet as pq
import pytest

from crashscene.dsl import loads
from crashscene.pipeline.simulate import simulate_scenario

N = 20  # variations per configuration (0.9 of 20: at most 2 misses)

ROADS = {
    "four_way": "road_type: intersection\n  number_of_ways: 2\n  number_of_lanes: 2\n  road_marker: double_solid_line",
    "four_way_wide": "road_type: intersection\n  number_of_ways: 2\n  number_of_lanes: 4\n  road_marker: double_solid_line",
    "four_way_six": "road_type: intersection\n  number_of_ways: 2\n  number_of_lanes: 6\n  road_marker: double_solid_line",
    "tee": "road_type: t_intersection\n  number_of_ways: 2\n  number_of_lanes: 2\n  road_marker: double_solid_line",
    "tee_six": "road_type: t_intersection\n  number_of_ways: 2\n  number_of_lanes: 6\n  road_marker: double_solid_line",
    "two_way": "road_type: straight\n  number_of_ways: 2\n  number_of_lanes: 2\n  road_marker: broken_line",
    "two_way_three": "road_type: straight\n  number_of_ways: 2\n  number_of_lanes: 3\n  road_marker: broken_line",
    "two_way_four": "road_type: straight\n  number_of_ways: 2\n  number_of_lanes: 4\n  road_marker: broken_line",
    "divided": "road_type: straight\n  number_of_ways: 1\n  number_of_lanes: 3\n  road_marker: none",
    "divided_four": "road_type: straight\n  number_of_ways: 1\n  number_of_lanes: 4\n  road_marker: none",
    "one_way": "road_type: straight\n  number_of_ways: 1\n  number_of_lanes: 2\n  road_marker: none",
    "bend_left": "road_type: curve\n  curve_direction: left\n  number_of_ways: 1\n  number_of_lanes: 4\n  road_marker: none",
    "bend_right": "road_type: curve\n  curve_direction: right\n  number_of_ways: 1\n  number_of_lanes: 4\n"
                  "  road_marker: none",
}


def scenario(road: str, signs: str, limit: int, actors: str, oracle: str, collisions: str) -> str:
    return f"""dsl_version: 1
environment: {{weather: clear, time_of_day: daytime, road_surface: dry}}
road_network:
  {ROADS[road]}
  traffic_signs: [{signs}]
  speed_limit_mph: {limit}
actors:
{actors}
oracle:
{oracle}
collisions:
{collisions}
"""


def actor(role: str, behavior: str, position: str, type_: str = "car") -> str:
    return f"  {role}:\n    type: {type_}\n    behavior: {behavior}\n    position: {{{position}}}\n"


def oracle(code: str, violation: str, who: str) -> str:
    return f"  - {{code: {code}, violation: {violation}, actor: {who}}}\n"


def contact(striking: str, struck: str, sa: str, ta: str, klass: str) -> str:
    return f"  - {{striking: {striking}, struck: {struck}, striking_area: {sa}, struck_area: {ta}, class: {klass}}}\n"


CONFIGURATIONS = {
    "crossing_paths": scenario(
        "four_way", "traffic_light, speed_limit_sign", 35,
        actor("ego", "go_forward", "reference: traffic_light, relation: behind")
        + actor("npc1", "go_forward", "reference: intersection, relation: right, heading: from_right"),
        oracle("CVC_21453", "red_light", "npc1"), contact("npc1", "ego", "front", "right", "angle")),
    "left_turn_across_path": scenario(
        "four_way_wide", "traffic_light, speed_limit_sign", 35,
        actor("ego", "go_forward", "reference: traffic_light, relation: behind")
        + actor("npc1", "turn_left", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21801", "left_turn_yield", "npc1"), contact("ego", "npc1", "front", "right", "angle")),
    "turning_into_the_lane": scenario(
        "tee", "stop_sign, speed_limit_sign", 40,
        actor("ego", "turn_right", "reference: stop_sign, relation: behind")
        + actor("npc1", "go_forward", "reference: intersection, relation: left, heading: from_left"),
        oracle("CVC_21802", "stop_sign_yield", "ego"), contact("npc1", "ego", "front", "left", "angle")),
    "merging_lane_change": scenario(
        "one_way", "speed_limit_sign", 55,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "change_lane_left", "reference: ego, relation: right, heading: same_direction"),
        oracle("CVC_22107", "unsafe_lane_change", "npc1"), contact("npc1", "ego", "left", "right", "sideswipe")),
    "rear_end_stopped_leader": scenario(
        "two_way", "speed_limit_sign", 45,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "static", "reference: ego, relation: front, heading: same_direction"),
        oracle("CVC_22350", "unsafe_speed", "ego"), contact("ego", "npc1", "front", "rear", "rear_end")),
    "rear_end_slowing_leader": scenario(
        "one_way", "speed_limit_sign", 65,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "decelerate", "reference: ego, relation: front, heading: same_direction"),
        oracle("CVC_21703", "following_too_closely", "ego"), contact("ego", "npc1", "front", "rear", "rear_end")),
    "rear_end_pulling_out": scenario(
        "one_way", "speed_limit_sign", 55,
        actor("ego", "change_lane_left", "reference: road, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: front, heading: same_direction"),
        oracle("CVC_21703", "following_too_closely", "ego"), contact("ego", "npc1", "front", "rear", "rear_end")),
    "sideswipe_clipping_the_car_ahead": scenario(
        "two_way", "speed_limit_sign", 55,
        actor("ego", "cross_centerline", "reference: road, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: front, heading: same_direction"),
        oracle("CVC_21703", "following_too_closely", "ego"), contact("ego", "npc1", "right", "rear", "sideswipe")),
    "head_on_drift": scenario(
        "two_way", "speed_limit_sign", 45,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "cross_centerline", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21650", "wrong_side", "npc1"), contact("npc1", "ego", "front", "front", "head_on")),
    "head_on_overtake": scenario(
        "two_way", "speed_limit_sign", 55,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "overtake", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21650", "wrong_side", "npc1"), contact("npc1", "ego", "front", "front", "head_on")),
    # two lanes the ego's way and one the other: the ego starts beside the centre line, where the overtaker comes
    # (render.plan._centre_lanes; first contact 0.525 of 40 before, when it started in the outer lane in half)
    "head_on_overtake_on_three_lanes": scenario(
        "two_way_three", "speed_limit_sign", 55,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "overtake", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21650", "wrong_side", "npc1"), contact("npc1", "ego", "front", "front", "head_on")),
    # two lanes each way: the drifter starts in the opposing lane nearest the ego's (scenic_support._oncoming_lane)
    "head_on_drift_on_four_lanes": scenario(
        "two_way_four", "speed_limit_sign", 45,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "cross_centerline", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21650", "wrong_side", "npc1"), contact("npc1", "ego", "front", "front", "head_on")),
    "head_on_wrong_way_divided": scenario(
        "divided", "speed_limit_sign", 65,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21650", "wrong_side", "npc1"), contact("npc1", "ego", "front", "front", "head_on")),
    "rear_end_chain": scenario(
        "divided", "speed_limit_sign", 55,
        actor("ego", "decelerate", "reference: road, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: behind, heading: same_direction", "truck")
        + actor("npc2", "decelerate", "reference: ego, relation: behind, heading: same_direction"),
        oracle("CVC_21703", "following_too_closely", "npc1"),
        contact("npc1", "npc2", "front", "rear", "rear_end") + contact("npc1", "ego", "front", "rear", "rear_end")),
    "loss_of_control": scenario(
        "two_way", "speed_limit_sign", 45,
        actor("ego", "lose_control", "reference: road, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_22350", "unsafe_speed", "ego"), contact("npc1", "ego", "front", "right", "angle")),
}


def run(text: str, tmp_path, n: int = N, seed: int = 7) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate_scenario(loads(text), tmp_path, n, seed, mode="reproduce")


KNOWN_GAPS: dict[str, str] = {}  # configurations the planner does not reproduce yet: kept as strict expected failures


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=KNOWN_GAPS[n]))
                                  if n in KNOWN_GAPS else n for n in sorted(CONFIGURATIONS)])
def test_first_contact_in_nine_of_ten_variations(name, tmp_path):
    summary = run(CONFIGURATIONS[name], tmp_path)
    assert summary["valid"] >= N * 0.8, summary.get("invalid")
    assert summary["first_contact_rate"] >= 0.9, (name, summary["collisions"])


CASCADE = scenario(
    "divided", "speed_limit_sign", 55,
    actor("ego", "go_forward", "reference: road, relation: behind")
    + actor("npc1", "stop", "reference: ego, relation: front, heading: same_direction")
    + actor("npc2", "go_forward", "reference: npc1, relation: left, heading: same_direction"),
    oracle("CVC_22350", "unsafe_speed", "ego"),
    contact("ego", "npc1", "front", "rear", "rear_end") + contact("npc2", "npc1", "front", "left", "angle"))


@pytest.mark.slow
def test_cascade_a_rear_end_pushes_the_struck_car_into_the_next_lane(tmp_path):
    summary = run(CASCADE, tmp_path)
    rows = pq.read_table(tmp_path / "collisions_classified.parquet").to_pylist()
    pushed = 0
    for v in {r["variation"] for r in rows}:
        mine = sorted((r for r in rows if r["variation"] == v), key=lambda r: r["t"])
        pairs = [frozenset((r["actor_a"], r["actor_b"])) for r in mine]
        if pairs[:1] == [frozenset(("ego", "npc1"))] and frozenset(("npc1", "npc2")) in pairs[1:]:
            pushed += 1
    assert summary["first_contact_rate"] >= 0.9
    assert pushed >= 0.5 * summary["valid"], summary["collisions"]
    # and the third car meets it as written (an angle into its left side) in most variations: the plan chooses
    # the corner of the stopped car to hit (0.2 of the variations with one fixed corner)
    assert summary["sequence_rate"] >= 0.5, summary["collisions"]


def test_same_seed_same_bytes(tmp_path):
    text = CONFIGURATIONS["loss_of_control"]
    run(text, tmp_path / "a", n=4)
    run(text, tmp_path / "b", n=4)
    for name in ("traces", "collisions", "variations"):
        assert (tmp_path / "a" / f"{name}.parquet").read_bytes() == (tmp_path / "b" / f"{name}.parquet").read_bytes()


LATER_CONTACTS = {  # cascades planned from a predicted slide: (scenario, least sequence rate, why)
    # the overtaker hits the corner the plan chose, so the struck car turns its side to the car behind it (0.1 of
    # the variations before the overtaker was settled on that corner in time; 0.92 of 100 measured)
    "a_head_on_spins_the_struck_car_into_the_path_of_the_overtaken_one": (scenario(
        "two_way", "speed_limit_sign", 55,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "overtake", "reference: ego, relation: front, heading: opposite_direction")
        + actor("npc2", "go_forward", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21650", "wrong_side", "npc1"),
        contact("npc1", "ego", "front", "front", "head_on") + contact("npc2", "ego", "front", "left", "angle")), 0.7),
    # the later contact is the striker's own: it glances off the corner of the stopped car it hits (the plan
    # chooses which, from its predicted slide) into the car coming up in the next lane (0 of 20 variations when
    # only the struck car's motion was planned; with the impulse of the full effective-mass matrix and the tyre
    # forces of impact.tyre_slide, 0.80 of 100 when the meeting is timed within 2 deg of the most central heading,
    # 0.58 within 10 deg)
    "a_rear_end_deflects_the_striker_into_the_car_in_the_next_lane": (scenario(
        "divided", "speed_limit_sign", 55,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "stop", "reference: ego, relation: front, heading: same_direction")
        + actor("npc2", "go_forward", "reference: ego, relation: left, heading: same_direction"),
        oracle("CVC_22350", "unsafe_speed", "ego"),
        contact("ego", "npc1", "front", "rear", "rear_end") + contact("npc2", "ego", "front", "left", "sideswipe")),
        0.65),
    # a pull-out clips the car ahead and the clip spins the striker across into an oncoming car: the plan chooses
    # how fast it comes up on the car it clips (how hard the clip turns it) and on which trigger step its pull-out
    # starts from its predicted slide, and predicts no slide for a clip too light to upset it (0 of 40 variations
    # when only the clip was planned; 0.75 of 40 on a wet road; on a dry one the tyres stop the spin before it is
    # square to the oncoming car; 0.78 of 100 with the partner speed alone, 0.83 of 100 and 0.85 of 20 with the
    # start and the upset: every miss left has the shortest car of the pool ahead (3.7 m), whose clip turns the
    # striker at most ~60 deg at the slowest partner speed of its range, 79 of 79 with any other)
    "a_clip_spins_the_striker_into_an_oncoming_car": (scenario(
        "two_way", "speed_limit_sign", 55,
        actor("ego", "cross_centerline", "reference: road, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: front, heading: same_direction")
        + actor("npc2", "go_forward", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_21703", "following_too_closely", "ego"),
        contact("ego", "npc1", "right", "rear", "sideswipe") + contact("ego", "npc2", "front", "left", "angle"))
        .replace("weather: clear, time_of_day: daytime, road_surface: dry",
                 "weather: rainy, time_of_day: daytime, road_surface: wet"), 0.8),
    # a car standing at a junction on a six-lane road is pushed by a rear-end into an oncoming car's path: the two
    # meet across the centre line, so both start in the lanes beside it (render.plan._centre_lanes; 0.6 of 20 when
    # the standing car took any of its three lanes, 1.0 of 20 beside the centre line)
    "a_rear_end_pushes_the_standing_car_into_an_oncoming_one": (scenario(
        "tee_six", "speed_limit_sign", 50,
        actor("ego", "stop", "reference: intersection, relation: behind")
        + actor("npc1", "go_forward", "reference: ego, relation: behind, heading: same_direction")
        + actor("npc2", "go_forward", "reference: ego, relation: front, heading: opposite_direction"),
        oracle("CVC_22350", "unsafe_speed", "npc1"),
        contact("npc1", "ego", "front", "rear", "rear_end") + contact("npc2", "ego", "front", "right", "angle"))
        .replace("weather: clear, time_of_day: daytime, road_surface: dry",
                 "weather: rainy, time_of_day: nighttime, road_surface: wet"), 0.9),
    # a truck knocks the slowing car ahead of it aside and runs on into the next one: the plan chooses the corner
    # that takes the knocked car out of the lane soonest and starts the cars ahead far enough on for it to leave
    # before it reaches them (0.65 of 20 when the corner was fixed and the cars ahead were where sampled: the knocked
    # car, pushed on by the truck, ran into the next one; 1.0 of 20 with the room planned)
    # (the rear-end chain configuration, judged on its whole sequence)
    "a_truck_knocks_a_car_aside_and_runs_on_into_the_next_one": (CONFIGURATIONS["rear_end_chain"], 0.9),
    # a car drifting off the road strikes the corner of a parked car (the plan chooses which, from its predicted
    # slide, and times the drift to end there) and is deflected back into the side of the car passing in the next
    # lane, placed beside it (0 of 20 when a drifting striker got no cascade plan; 0.45, areas 0, with the drift
    # planned but the passing car timed to drive into the deflected one with its front; 0.95, areas 0.65, with the
    # deflected car coming alongside into its side)
    "a_drift_into_a_parked_car_deflects_the_striker_into_the_side_of_the_car_alongside": (scenario(
        "divided", "speed_limit_sign", 65,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "leave_road", "reference: ego, relation: right, heading: same_direction")
        + actor("npc2", "static", "reference: ego, relation: right, heading: same_direction"),
        "  []\n",
        contact("npc1", "npc2", "front", "rear", "rear_end") + contact("npc1", "ego", "left", "right", "sideswipe"))
        .replace("oracle:\n  []\n", "oracle: []\n"), 0.8),
    # ...and the car alongside, struck on its right side, spins across the lane to its left into the path of a car
    # coming up two lanes to its left, which meets it front to front: the plan chooses the corner of the parked car,
    # where along the passing car's side the deflected one reaches it and the fourth car's lane (any on that side)
    # from their contacts stepped as the simulator steps them (embedded.followon; 0 of 20 before: the fourth car
    # drove where sampled; 0.25 of 20 at seed 7, 0.2 of 40 at seed 1; 0.35 of 20 at 70 mph, 0.1 at 60, 0 at 55, where
    # no sideswipe the sampled speeds allow spins the car far enough round), and, when the fourth car starts in the
    # outermost lane, whether the other three start a lane further from it (followon.group_shifts: a car spun by a
    # sideswipe turns through 150 deg only after it has slid more than one lane across): 0.55 of 20 at seed 7, 0.475
    # and 0.55 of 40 at seeds 1 and 2 (0.25, 0.2, 0.35 without); preferring a first impact whose outcome does not
    # turn on a hundredth of a radian (followon.steady) and predicting the sideswipe from before the two touch
    # (followon._apart): 0.65, 0.6, 0.7; the sooner meeting (followon.option_key): 0.65, 0.6, 0.725; corners every
    # 0.025 of the width (followon.CORNERS): 0.6, 0.625, 0.675; the striker started up to 3/4 of a step further
    # back when no plan has the fourth contact steadily (cascade_plan.NUDGES): 0.6, 0.65, 0.65
    "a_sideswipe_spins_the_car_alongside_into_a_fourth_car_two_lanes_over": (scenario(
        "divided_four", "speed_limit_sign", 65,
        actor("ego", "go_forward", "reference: road, relation: behind")
        + actor("npc1", "leave_road", "reference: ego, relation: right, heading: same_direction")
        + actor("npc2", "static", "reference: ego, relation: right, heading: same_direction")
        + actor("npc3", "go_forward", "reference: ego, relation: left, heading: same_direction"),
        "  []\n",
        contact("npc1", "npc2", "front", "rear", "rear_end") + contact("npc1", "ego", "left", "right", "sideswipe")
        + contact("npc3", "ego", "front", "front", "head_on")).replace("oracle:\n  []\n", "oracle: []\n"), 0.55),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(LATER_CONTACTS))
def test_cascade_later_contact_from_a_predicted_slide(name, tmp_path):
    text, least = LATER_CONTACTS[name]
    summary = run(text, tmp_path)
    assert summary["first_contact_rate"] >= 0.9
    assert summary["sequence_rate"] >= least, summary["collisions"]


# A side slap after an offset angle impact (rules.md: a re-touch is its own contact; embedded.slap): the left turner
# struck on its right side ahead of its centre turns away from the striker's path while the striker's front is
# dragged along with it, and its rear slaps the striker's left side, nearly parallel. The plan places the first touch
# where the simulator's contact physics, on the paths the two drive, gives both the angle touch and the slap. Across
# three lanes of a six-lane road the turner is turned far enough ahead of its centre for both: 0.95 of 20 (0.975 of
# 40 at seeds 1 and 2, and at 45 mph; 0.7 at 25 mph, where the impulse is weaker; 0 of 20 before: the bodies
# rotated through each other after the first touch, and the touch was placed at the turner's middle).
SIDE_SLAP = scenario(
    "four_way_six", "traffic_light, speed_limit_sign", 35,
    actor("ego", "go_forward", "reference: traffic_light, relation: behind")
    + actor("npc1", "turn_left", "reference: ego, relation: front, heading: opposite_direction"),
    oracle("CVC_21801", "left_turn_yield", "npc1"),
    contact("ego", "npc1", "front", "right", "angle") + contact("ego", "npc1", "left", "right", "sideswipe"))


@pytest.mark.slow
def test_a_left_turner_struck_ahead_of_its_centre_is_slapped_again_by_the_strikers_side(tmp_path):
    summary = run(SIDE_SLAP, tmp_path)
    assert summary["first_contact_rate"] >= 0.9
    assert summary["sequence_rate"] >= 0.9, summary["collisions"]


# The same on a four-lane road: the turner crosses the striker's lane early in its turn, and a touch ahead of its
# centre meets it turned too little for an angle contact with a margin (the predicted touches that slap are at 118-126
# deg): no slap is planned, and the first touch stays where it was (first contact 1.0; sequence 0 of 20, 0.025 of 40).
SAME_PAIR_RETOUCH = CONFIGURATIONS["left_turn_across_path"].replace(
    contact("ego", "npc1", "front", "right", "angle"),
    contact("ego", "npc1", "front", "right", "angle") + contact("ego", "npc1", "left", "right", "sideswipe"))


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="no angle touch ahead of a four-lane left turner's centre is followed by a slap "
                                       "with a margin (embedded.slap): sequence 0 of 20")
def test_a_left_turner_is_struck_and_slapped_again_by_the_same_car(tmp_path):
    summary = run(SAME_PAIR_RETOUCH, tmp_path)
    assert summary["first_contact_rate"] >= 0.9
    assert summary["sequence_rate"] >= 0.9, summary["collisions"]


# A pull-out in a queue clips the car ahead, and the report has the striker spin into the next car of the queue
# (simulate.embedded.clipahead): the clip is predicted with the clipped car's motion, which the clip pushes on ahead of
# the striker, so no start of the next car has the striker meet it first (benchmarks/bench_clip_reach.py) and the plan
# moves none: the queue is left as sampled, its cars driving; first contact 20 of 20, sequence 0 of 20. Before, the car
# ahead was held standing at its start to meet a slide that ignored the clipped car: the clipped car braked for it and
# was pushed into it (first contact 20 of 20, the written sequence in 1 of 20, by chance).
QUEUE_CLIP = scenario(
    "divided", "speed_limit_sign", 55,
    actor("ego", "change_lane_left", "reference: road, relation: behind")
    + actor("npc1", "go_forward", "reference: ego, relation: front, heading: same_direction")
    + actor("npc2", "go_forward", "reference: ego, relation: front, heading: same_direction"),
    oracle("CVC_22107", "unsafe_lane_change", "ego"),
    contact("ego", "npc1", "front", "rear", "rear_end") + contact("ego", "npc2", "left", "rear", "angle"))


@pytest.mark.slow
def test_a_clip_in_a_queue_leaves_the_car_ahead_of_the_clipped_one_driving(tmp_path):
    summary = run(QUEUE_CLIP, tmp_path)
    assert summary["first_contact_rate"] >= 0.9, summary["collisions"]
    rows = pq.read_table(tmp_path / "traces.parquet", columns=["variation", "actor", "t", "speed"]).to_pylist()
    ahead = [r["speed"] for r in rows if r["actor"] == "npc2" and abs(r["t"] - 0.5) < 1e-6]
    assert len(ahead) == summary["valid"] and min(ahead) > 5.0


SPEEDING_TRUCK = scenario(
    "divided_four", "speed_limit_sign", 70,
    actor("ego", "lose_control", "reference: road, relation: behind", "truck")
    + actor("npc1", "change_lane_left", "reference: ego, relation: right, heading: same_direction"),
    oracle("CVC_22350", "unsafe_speed", "ego"), contact("npc1", "ego", "front", "left", "angle"))


@pytest.mark.slow
def test_a_speeding_truck_is_planned_at_the_speed_it_can_reach(tmp_path):
    # a truck charged with unsafe speed on a 70 mph road would cruise above its top speed (35 m/s); the simulator
    # clips it there, so a plan timed at the faster cruise has the merging car arrive after the truck's slide passed
    # (planned at 35-43 m/s: 0.90 of 20 at seed 7, 0.85 at seed 1; at the truck's top speed: 1.00 at both)
    summary = run(SPEEDING_TRUCK, tmp_path)
    rows = pq.read_table(tmp_path / "traces.parquet", columns=["actor", "t", "speed"]).to_pylist()
    assert max(r["speed"] for r in rows if r["actor"] == "ego" and r["t"] == 0.0) <= 35.0
    bodies = pq.read_table(tmp_path / "actors.parquet", columns=["actor", "length", "width"]).to_pylist()
    assert {(r["length"], r["width"]) for r in bodies if r["actor"] == "ego"} == {(7.94, 2.89)}  # a truck's body
    assert summary["first_contact_rate"] >= 0.95, summary["collisions"]


SHOULDER_TRUCK = scenario(
    "divided_four", "speed_limit_sign", 70,
    actor("ego", "go_forward", "reference: road, relation: behind")
    + actor("npc1", "leave_road", "reference: ego, relation: right, heading: same_direction", "truck")
    + actor("npc2", "static", "reference: ego, relation: right, heading: same_direction")
    + actor("npc3", "go_forward", "reference: ego, relation: left, heading: same_direction"),
    "  []\n",
    contact("npc1", "npc2", "front", "rear", "rear_end") + contact("npc1", "ego", "left", "right", "sideswipe")
    + contact("npc3", "ego", "front", "front", "head_on"))


@pytest.mark.slow
def test_a_wide_striker_starts_clear_of_the_car_alongside(tmp_path):
    # a truck drifting onto the shoulder into a parked car's corner, to be deflected into the ego alongside: the
    # corner that sends it back that way has it start about 1 m toward the ego, which with a truck's 2.89 m body
    # overlaps the ego in the next lane at t = 0; a corner it can start clear for is taken (main: 8 and 11 of 20
    # invalid at seeds 7 and 1)
    summary = run(SHOULDER_TRUCK, tmp_path)
    assert summary["valid"] == N, summary["invalid"]


def spin_on_a_bend(side: str) -> str:
    return scenario(
        f"bend_{side}", "speed_limit_sign", 70,
        actor("ego", "lose_control", "reference: road, relation: behind")
        + actor("npc1", "change_lane_left", "reference: ego, relation: right, heading: same_direction"),
        oracle("CVC_22350", "unsafe_speed", "ego"), contact("npc1", "ego", "front", "left", "angle"))


@pytest.mark.slow
@pytest.mark.parametrize("side", ["left", "right"])
def test_a_car_spinning_on_a_bend_is_struck_where_its_skid_meets_the_lane_round_the_bend(side, tmp_path):
    # the skid is planned in the road's frame round the bend (a car out of control keeps its course while its
    # partner follows the lane), and the partner keeps its speed on a 400 m bend (the route's curvature is the
    # bend's, not its chords' vertices'); planned as on a straight road: 0.40 / 0.15 of 20 bent left / right
    summary = run(spin_on_a_bend(side), tmp_path)
    assert summary["first_contact_rate"] >= 0.9, summary["collisions"]
