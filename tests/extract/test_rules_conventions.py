"""One test per convention rule of the rules backend (dsl.md section 5), on short synthetic narratives.

Each narrative is written for the test in NHTSA's formulaic style; none is copied from a bundled case.
"""
from __future__ import annotations

from pathlib import Path

from crashscene.extract.case_input import Report
from crashscene.extract.rules import extract_rules
from crashscene.extract.sketch import SketchFact

EAST_NORTH = ("V1 was traveling east in the eastbound lane of a two-lane, two-way road approaching a four-leg "
              "intersection. V2 was traveling north in the northbound lane of the intersecting road. ")
EAST_WEST = ("V1 was traveling east in the eastbound lane of a two-lane, two-way road. V2 was traveling west in the "
             "westbound lane. ")
EAST_EAST = ("V1 was traveling east in the right eastbound lane of a four-lane, two-way road. V2 was traveling "
             "east ahead of V1 in the same lane. ")


def _text(narrative: str, facts: list[SketchFact] | None = None):
    return extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")), facts or [])


def _oracle(scenario) -> set[tuple[str, str]]:
    return {(entry.code, entry.actor) for entry in scenario.oracle}


def _contacts(scenario) -> list[tuple[str, str, str, str, str]]:
    return [(c.striking, c.struck, c.striking_area.value, c.struck_area.value, c.class_.value)
            for c in scenario.collisions]


# ---------------------------------------------------------------- convention 11: the crash sequence


def test_impact_formula_gives_striker_struck_areas_and_class():
    s = _text(EAST_NORTH + "V1 and V2 entered the intersection and the front of V2 struck the right side of V1.")
    assert _contacts(s) == [("npc1", "ego", "front", "right", "angle")]
    assert "front of V2 struck the right side of V1" in s.evidence["collisions[0]"]


def test_passive_formula_and_with_its_plane():
    s = _text(EAST_NORTH + "The left plane of V1 was struck by the frontal plane of V2 (Event 1).")
    assert _contacts(s) == [("npc1", "ego", "front", "left", "angle")]
    s = _text(EAST_EAST + "V1 did not slow and struck the rear plane of V2 with its frontal plane (Event 1).")
    assert _contacts(s) == [("ego", "npc1", "front", "rear", "rear_end")]


def test_possessive_planes_and_event_order():
    s = _text("V1 was traveling east in the left eastbound lane of a divided highway. V2, V3 and V4 were traveling "
              "east in the center lane. V1's right side plane struck V2's left side plane (Event 1). "
              "V3's frontal plane subsequently struck V4's back plane (Event 3). "
              "V2's frontal plane then struck V3's back plane (Event 2).")
    assert [(c[0], c[1], c[4]) for c in _contacts(s)] == [
        ("ego", "npc1", "sideswipe"), ("npc1", "npc2", "rear_end"), ("npc2", "npc3", "rear_end")]


def test_collided_head_on_the_vehicle_that_left_its_lane_strikes():
    s = _text(EAST_WEST + "V2 crossed the center line into the eastbound lane. V1 and V2 collided head-on.")
    assert _contacts(s) == [("npc1", "ego", "front", "front", "head_on")]


def test_unstated_areas_follow_the_travel_directions():
    s = _text(EAST_NORTH + "V2 entered the intersection and struck V1.")
    # V1 comes from V2's left (V2 northbound, V1 eastbound): V2's front meets V1's right side
    assert _contacts(s) == [("npc1", "ego", "front", "right", "angle")]


def test_corner_areas_resolved_by_configuration():
    same = _text(EAST_EAST + "The right front corner of V1 struck the left rear corner of V2.")
    assert _contacts(same)[0][2:] == ("front", "rear", "rear_end")
    crossing = _text(EAST_NORTH + "The front of V2 struck the left front of V1 (Event 1).")
    assert _contacts(crossing)[0][2:] == ("front", "left", "angle")


def test_pushed_contact_is_its_own_entry_and_no_violation_of_the_pushed():
    s = _text("V1 was traveling east in the eastbound lane of a two-lane, two-way road and was stopped in traffic "
              "behind V3. V2 was traveling east behind V1. V2 failed to stop and the front of V2 struck the rear of "
              "V1 (Event 1). The impact pushed V1 forward causing V1 to strike the rear of V3 (Event 2).")
    assert [(c[0], c[1], c[4]) for c in _contacts(s)] == [("npc1", "ego", "rear_end"), ("ego", "npc2", "rear_end")]
    assert _oracle(s) == {("CVC_22350", "npc1")}  # struck a stopped vehicle; V1's second contact is an outcome


def test_contact_with_an_object_only_is_an_empty_sequence():
    s = _text("V1 was traveling north on a two-lane road. V1 departed the right side of the roadway and the front "
              "of V1 struck a tree.")
    assert s.collisions == []


def test_avoided_contact_is_not_listed_and_restatement_is_merged():
    s = _text(EAST_NORTH + "V1 attempted to avoid striking V2 by steering left. V2 struck V1. The front of V2 "
              "struck the right side of V1 in a T-type configuration.")
    assert _contacts(s) == [("npc1", "ego", "front", "right", "angle")]


# ---------------------------------------------------------------- convention 9: the oracle


def test_rear_end_on_a_moving_vehicle_is_following_too_closely():
    s = _text(EAST_EAST + "V2 was slowing for traffic. The front of V1 struck the rear of V2.")
    assert _oracle(s) == {("CVC_21703", "ego")}


def test_rear_end_on_a_stopped_vehicle_is_unsafe_speed():
    s = _text(EAST_EAST + "V2 was stopped in its lane for traffic. The front of V1 struck the back of V2.")
    assert _oracle(s) == {("CVC_22350", "ego")}


def test_striking_the_side_of_a_vehicle_stopped_across_the_lane_is_unsafe_speed():
    s = _text("V1 was traveling north in the northbound lane of a two-lane, two-way road. V2 was stopped at an "
              "angle, blocking the northbound lane. The front of V1 struck the left side of V2.")
    assert _oracle(s) == {("CVC_22350", "ego")}
    assert _contacts(s) == [("ego", "npc1", "front", "left", "angle")]


def test_lost_control_is_unsafe_speed_and_crossing_a_double_line_adds_21460():
    s = _text("V1 was traveling east in the eastbound lane of a two-lane, two-way road divided by double yellow "
              "lines. V2 was traveling west. V1 lost control on the wet road, crossed the center line and the front "
              "of V1 struck the front of V2.")
    assert _oracle(s) == {("CVC_22350", "ego"), ("CVC_21650", "ego"), ("CVC_21460", "ego")}


def test_too_fast_statement_is_attributed_to_its_subject():
    s = _text(EAST_EAST + "The driver of V1 was reportedly driving too fast for the icy conditions. The front of V1 "
              "struck the rear of V2.")
    assert ("CVC_22350", "ego") in _oracle(s)
    assert "too fast" in s.evidence[f"oracle[{[e.code for e in s.oracle].index('CVC_22350')}]"]


def test_stated_speeding_is_22349():
    s = _text(EAST_WEST + "Police reported that V2 was speeding. V2 crossed the center line and the front of V2 "
              "struck the front of V1.")
    assert {("CVC_22349", "npc1"), ("CVC_21650", "npc1")} <= _oracle(s)


def test_red_light_at_a_signal():
    s = _text(EAST_NORTH + "The intersection was controlled by traffic signals. V2 ran the red light and the front "
              "of V2 struck the right side of V1.")
    assert _oracle(s) == {("CVC_21453", "npc1")}


def test_left_turn_across_oncoming_traffic_unless_the_other_ran_the_red():
    turn = ("V1 was traveling east in the eastbound lane approaching a four-leg intersection controlled by traffic "
            "signals. V2 was traveling west and began to turn left at the intersection. ")
    s = _text(turn + "The front of V1 struck the right side of V2.")
    assert _oracle(s) == {("CVC_21801", "npc1")}
    s = _text(turn + "V1 entered against the red signal and the front of V1 struck the right side of V2.")
    assert _oracle(s) == {("CVC_21453", "ego")}


def test_stop_sign_missed_is_22450_stopped_then_entered_is_21802():
    base = ("V1 was traveling east in the eastbound lane approaching a four-leg intersection. V2 was traveling "
            "north on the intersecting road, which was controlled by a stop sign for northbound traffic. ")
    s = _text(base + "V2 failed to stop at the stop sign and the front of V2 struck the right side of V1.")
    assert _oracle(s) == {("CVC_22450", "npc1")}
    s = _text(base + "V2 stopped at the stop sign, then proceeded into the intersection and the front of V2 struck "
              "the right side of V1.")
    assert _oracle(s) == {("CVC_21802", "npc1")}
    assert s.actors["npc1"].position.reference == "stop_sign"


def test_unattributed_sketch_sign_controls_the_ego_approach():
    s = _text(EAST_NORTH + "Both vehicles entered the intersection and the front of V2 struck the right side of V1.",
              [SketchFact(text="stop sign")])
    assert s.actors["ego"].position.reference == "stop_sign"
    assert _oracle(s) == {("CVC_21802", "ego")}


def test_sketch_sign_drawn_beside_a_vehicle_label_controls_that_vehicle():
    facts = [SketchFact(text="yield sign", bbox=(400, 400, 440, 420)),
             SketchFact(text="vehicle label V1", bbox=(100, 100, 120, 120)),
             SketchFact(text="vehicle label V2", bbox=(420, 440, 440, 460))]
    s = _text(EAST_NORTH + "Both vehicles entered the intersection and the front of V2 struck the right side of V1.",
              facts)
    assert s.actors["npc1"].position.reference == "yield_sign"
    assert _oracle(s) == {("CVC_21803", "npc1")}


def test_uncontrolled_junction_the_vehicle_without_priority():
    s = _text(EAST_NORTH + "There were no traffic controls. V1 failed to yield and the front of V2 struck the "
              "right side of V1.")
    assert _oracle(s) == {("CVC_21800", "ego")}


def test_lane_change_into_another_vehicle():
    s = _text("V1 was traveling north in the right northbound lane of a four-lane divided highway. V2 was traveling "
              "north in the left lane beside V1. V1 changed lanes to the left and the left side of V1 struck the "
              "right side of V2.")
    assert _oracle(s) == {("CVC_22107", "ego")}
    assert _contacts(s)[0][4] == "sideswipe"


def test_run_off_road_without_a_stated_cause_has_no_oracle():
    s = _text("V1 was traveling north on a two-lane, two-way road. V1 departed the right side of the road and "
              "struck a utility pole.")
    assert s.oracle == []
    assert s.collisions == []


def test_drifting_into_the_path_of_an_oncoming_vehicle_is_crossing_the_centre_line():
    s = _text(EAST_WEST + "V2 drifted to the left and into the path of V1. The front of V2 struck the front of V1.")
    assert s.actors["npc1"].behavior.value == "cross_centerline"
    assert ("CVC_21650", "npc1") in _oracle(s)
    # into the path of a crossing vehicle is not a centre-line crossing
    s = _text(EAST_NORTH + "V2 moved into the path of V1 and the front of V1 struck the left side of V2.")
    assert s.actors["npc1"].behavior.value != "cross_centerline"


def test_left_turn_in_front_of_oncoming_traffic_without_stated_directions():
    s = _text("V1 was approaching a four-leg intersection. V2 was approaching from the opposite direction and began "
              "to turn left in front of V1. The front of V1 struck the right side of V2.")
    assert s.actors["npc1"].behavior.value == "turn_left"
    assert ("CVC_21801", "npc1") in _oracle(s)


def test_pair_named_without_a_striker_is_settled_by_a_later_formula_or_the_manoeuvre():
    s = _text(EAST_WEST + "V2 drifted left of center. The two vehicles collided. The front of V1 struck the front "
              "of V2 (Event 1).")
    assert _contacts(s) == [("ego", "npc1", "front", "front", "head_on")]
    s = _text(EAST_WEST + "V2 drifted left of center, resulting in a head-on collision with V1.")
    assert _contacts(s) == [("npc1", "ego", "front", "front", "head_on")]


# ---------------------------------------------------------------- issue 11, second session: general phrasings


TWO_WAY_NORTH = "V1 was traveling north on a two-lane, two-way roadway{road}. V2 was traveling south. "


def test_a_road_divided_by_a_painted_line_is_two_way_and_a_solid_yellow_line_is_solid_line():
    narrative = (TWO_WAY_NORTH.format(road=" divided by a solid yellow line")
                 + "V1 crossed over the solid yellow line and the front of V1 struck the front of V2.")
    s = _text(narrative)
    assert s.road_network.number_of_ways == 2 and s.road_network.road_marker.value == "solid_line"
    assert _oracle(s) == {("CVC_21650", "ego")}
    off = extract_rules(Report(case_id="t", narrative=narrative, source=Path("t.txt")),
                        off=["rules_road.divided_by_a_line_is_not_divided", "rules_road.marker_phrasings"])
    assert off.road_network.number_of_ways == 1


def test_no_centerline_is_none_and_a_centre_left_turn_lane_away_from_junctions_is_solid_and_broken():
    s = _text(TWO_WAY_NORTH.format(road=" that had no centerline") + "The front of V2 struck the front of V1.")
    assert s.road_network.road_marker.value == "none"
    s = _text("V1 was traveling east on a five-lane roadway with a center left-turn lane. V2 was traveling east "
              "ahead of V1 in the same lane. The front of V1 struck the rear of V2.")
    assert s.road_network.road_marker.value == "solid_and_broken_line" and s.road_network.number_of_lanes == 4
    # at a junction a middle left-turn lane is a turn bay: the marking stays unstated
    s = _text("V1 was traveling north on a five-lane road approaching a four-leg intersection. V2 was traveling south "
              "in the middle left-turn lane and turned left at the intersection. The front of V1 struck the right "
              "side of V2.")
    assert s.road_network.road_marker.value == "not_mentioned"


def test_a_marking_label_on_the_sketch_names_no_road():
    facts = [SketchFact(text="text: Solid Yellow Line", source="sketch:ocr")]
    s = _text(EAST_WEST + "V2 crossed the center line and the front of V2 struck the front of V1.", facts)
    assert s.road_network.road_marker.value == "not_mentioned"


def test_lanes_in_each_direction_count_both_directions_or_the_carriageway():
    s = _text("The roadway consisted of three lanes in each direction separated by a raised median. V1 was traveling "
              "west in the center lane. V2 was traveling west in the left lane and changed lanes to the right. The "
              "right side of V2 struck the left side of V1.")
    assert (s.road_network.number_of_ways, s.road_network.number_of_lanes) == (1, 3)
    s = _text("V1 was traveling east on an undivided road with two travel lanes in each direction. V2 was traveling "
              "east ahead of V1. The front of V1 struck the rear of V2.")
    assert (s.road_network.number_of_ways, s.road_network.number_of_lanes) == (2, 4)


def test_a_flashing_red_faced_by_one_vehicle_controls_its_approach_only():
    s = _text(EAST_NORTH.replace("approaching a four-leg intersection", "approaching a four-leg intersection "
                                 "controlled by a flashing yellow signal")
              + "V2 faced a flashing red signal. V2 entered the intersection and the front of V2 struck the right "
                "side of V1.")
    assert [t.value for t in s.road_network.traffic_signs] == ["stop_sign"]
    assert s.actors["npc1"].position.reference == "stop_sign"
    assert s.actors["ego"].position.reference == "intersection"
    assert _oracle(s) == {("CVC_21802", "npc1")}


def test_traffic_without_a_stated_direction_on_one_carriageway_goes_the_ego_s_way():
    s = _text("V1 was traveling west in the right lane of a three-lane interstate. V2 was entering the interstate "
              "from an on-ramp. V2 merged into the right lane and the left side of V2 struck the right side of V1.")
    npc = s.actors["npc1"]
    assert npc.behavior.value == "change_lane_left"
    assert (npc.position.reference, npc.position.relation.value, npc.position.heading.value) == (
        "ego", "right", "same_direction")
    assert _oracle(s) == {("CVC_22107", "npc1")}


def test_a_manoeuvre_told_after_the_impact_verb_is_pre_crash():
    s = _text(EAST_WEST.replace("two-lane, two-way road", "two-lane, two-way road with a double yellow centerline")
              + "The front of V2 struck the front of V1 after V2 drifted across the centerline.")
    assert s.actors["npc1"].behavior.value == "cross_centerline"
    assert _oracle(s) == {("CVC_21650", "npc1"), ("CVC_21460", "npc1")}


def test_snow_lying_on_the_road_is_the_surface_not_the_weather():
    s = _text("V1 was traveling west on a two-lane, two-way road covered in snow and ice. V1 lost control and the "
              "front of V2 struck the right side of V1. V2 was traveling east.")
    assert (s.environment.weather.value, s.environment.road_surface.value) == ("not_mentioned", "icy")
    s = _text("It was snowing. " + EAST_WEST + "The front of V2 struck the front of V1.")
    assert s.environment.weather.value == "snowy"


def test_a_red_light_waited_at_is_not_run():
    s = _text("V1 was traveling north approaching a signalized intersection. V2 was stopped for a red light ahead of "
              "V1. The front of V1 struck the rear of V2.")
    assert _oracle(s) == {("CVC_22350", "ego")}
    s = _text(EAST_NORTH.replace("four-leg intersection", "four-leg intersection controlled by traffic signals")
              + "V2 ran the red light and the front of V2 struck the right side of V1.")
    assert _oracle(s) == {("CVC_21453", "npc1")}


def test_a_stated_speed_above_the_stated_limit_is_22349():
    s = _text("The posted speed limit was 45 mph. V1 was traveling north at 70 mph on a two-lane, two-way road. V1 "
              "crossed the centerline and struck the front of V2, which was traveling south.")
    assert s.actors["ego"].speed_mph == 70 and s.road_network.speed_limit_mph == 45
    assert _oracle(s) == {("CVC_21650", "ego"), ("CVC_22349", "ego")}
    assert s.actors["npc1"].position.heading.value == "opposite_direction"


def test_rear_end_on_a_vehicle_that_stopped_then_turned_is_following_too_closely():
    s = _text("V1 was traveling east on a two-lane road. V2 was stopped at a stop sign on the northbound approach of "
              "the intersecting road and then turned right onto the eastbound lane. The front of V1 struck the rear "
              "of V2.")
    assert _oracle(s) == {("CVC_21802", "npc1"), ("CVC_21703", "ego")}


def test_crossing_a_grass_median_into_the_opposing_carriageway_counts_both():
    s = _text("V1 was traveling north on a four-lane divided highway. V1 crossed the grass median and entered the "
              "southbound lanes, where the front of V1 struck the front of V2, which was traveling south.")
    assert (s.road_network.number_of_ways, s.road_network.number_of_lanes) == (2, 4)
    assert s.actors["npc1"].position.heading.value == "opposite_direction"
    assert _contacts(s) == [("ego", "npc1", "front", "front", "head_on")]


def test_a_vehicle_which_was_pushed_into_another_is_its_own_contact():
    s = _text("V1, V2 and V3 were traveling east in the same lane of a two-lane road. V2 and V3 were stopped in "
              "traffic. The front of V1 struck the rear of V2, which was pushed into the rear of V3.")
    assert [(c[0], c[1], c[4]) for c in _contacts(s)] == [("ego", "npc1", "rear_end"), ("npc1", "npc2", "rear_end")]
    assert _oracle(s) == {("CVC_22350", "ego")}  # the pushed V2 chose nothing


def test_a_direction_stated_in_its_own_clause_wins_over_the_lane_entered():
    s = _text("The roadway was straight and level. V1 was traveling east and V2 was traveling west. V2 crossed into "
              "the eastbound lane and the front of V2 struck the front of V1.")
    npc = s.actors["npc1"]
    assert (npc.behavior.value, npc.position.heading.value) == ("cross_centerline", "opposite_direction")
    assert _oracle(s) == {("CVC_21650", "npc1")}


def test_all_way_stop_the_vehicle_with_the_other_on_its_right_lacks_priority():
    s = _text("V1 was traveling north and V2 was traveling east approaching an intersection controlled by a four-way "
              "stop. Both vehicles stopped and then entered the intersection. The front of V2 struck the right side "
              "of V1.")
    assert _oracle(s) == {("CVC_21800", "npc1")}


def test_a_junction_named_only_to_locate_the_crash_plays_no_part():
    s = _text("V1 was traveling north on a two-lane road approximately 100 meters south of an intersection. V2 was "
              "traveling north ahead of V1 and slowed for traffic. The front of V1 struck the rear of V2.")
    assert s.road_network.road_type.value == "straight"
    assert s.actors["ego"].position.reference == "road"


def test_leaving_a_parking_lot_is_a_three_leg_junction_and_its_side_gives_the_heading():
    s = _text("V1 was traveling east on a four-lane road. V2 was exiting a parking lot on the south side of the road "
              "attempting to turn left. The front of V1 struck the left side of V2.")
    assert s.road_network.road_type.value == "t_intersection"
    npc = s.actors["npc1"].position
    assert (npc.reference, npc.relation.value, npc.heading.value) == ("intersection", "right", "from_right")
    assert _oracle(s) == {("CVC_21804", "npc1")}


def test_a_white_lane_line_is_not_the_centre_line():
    s = _text("V1 was traveling east on a four-lane, two-way roadway. The eastbound lanes were separated by a broken "
              "white line. V2 was traveling east in the right lane and changed lanes into the left lane. The left "
              "side of V2 struck the right side of V1.")
    assert s.road_network.road_marker.value == "not_mentioned"
    assert s.actors["npc1"].behavior.value == "change_lane_left"


def test_merging_from_an_entrance_ramp_is_a_change_to_the_left():
    s = _text("V1 was traveling north in the right lane of a four-lane divided interstate. V2 was traveling on the "
              "entrance ramp and merged into the right lane in front of V1. The front of V1 struck the rear of V2.")
    assert s.actors["npc1"].behavior.value == "change_lane_left"
    assert ("CVC_22107", "npc1") in _oracle(s)


def test_a_vehicle_stated_as_oncoming_is_opposite_direction():
    s = _text("V1 was proceeding straight through the intersection on a green signal. V2, traveling in the opposite "
              "direction, turned left in front of V1. The front of V1 struck the right side of V2.")
    npc = s.actors["npc1"].position
    assert (npc.reference, npc.relation.value, npc.heading.value) == ("ego", "front", "opposite_direction")
    assert _oracle(s) == {("CVC_21801", "npc1")}


ONCOMING = "V1 was traveling east on a two-lane, two-way road. V2 was traveling west. "
AHEAD = "V1 was traveling east on a four-lane road. V2 was traveling east ahead of V1. "


def test_sliding_yawing_lost_traction_and_overcorrecting_are_losing_control():
    for told in ("V1 began to slide sideways and entered the westbound lane. The front of V2 struck the right side "
                 "of V1.",
                 "V1 entered a clockwise yaw and crossed the centerline. The front of V2 struck the right side of V1.",
                 "V1 lost traction on the icy road and crossed the center line. The front of V1 struck the front of "
                 "V2."):
        s = _text(ONCOMING + told)
        assert s.actors["ego"].behavior.value == "lose_control", told
        assert _oracle(s) == {("CVC_22350", "ego"), ("CVC_21650", "ego")}, told
    s = _text(AHEAD + "V2 stopped. V1 skidded for 20 meters before the front of V1 struck the rear of V2.")
    assert s.actors["ego"].behavior.value == "go_forward"  # a braking skid is no loss of control


def test_off_the_road_then_back_across_the_centre_line_into_another_vehicle():
    s = _text(ONCOMING + "V1 drifted onto the right shoulder. The driver overcorrected to the left and V1 crossed into "
              "the westbound lane, where the front of V1 struck the front of V2.")
    assert s.actors["ego"].behavior.value == "lose_control"
    s = _text(ONCOMING + "V1 departed the right side of the roadway, returned to the road and crossed the centerline. "
              "The front of V1 struck the front of V2.")
    assert s.actors["ego"].behavior.value == "cross_centerline"
    s = _text("V1 was traveling north. V1 departed the right side of the roadway and struck a utility pole.")
    assert s.actors["ego"].behavior.value == "leave_road" and s.oracle == []


def test_stopped_or_sitting_in_traffic_ahead_is_a_stop():
    s = _text(AHEAD + "V2 was sitting in traffic. The front of V1 struck the rear of V2.")
    assert s.actors["npc1"].behavior.value == "stop" and _oracle(s) == {("CVC_22350", "ego")}
    s = _text(AHEAD + "V2 came to a stop in the lane to make a left turn. The front of V1 struck the rear of V2.")
    assert s.actors["npc1"].behavior.value == "stop" and _oracle(s) == {("CVC_22350", "ego")}


def test_pulling_into_the_opposing_lane_to_pass_is_overtaking():
    s = _text("V1 was traveling east on a two-lane, two-way road. V2 was traveling east behind V1. V2 pulled into the "
              "westbound lane to pass V1 and the right side of V2 struck the left side of V1.")
    npc = s.actors["npc1"]
    assert (npc.behavior.value, npc.position.relation.value) == ("overtake", "behind")
    assert _oracle(s) == {("CVC_21650", "npc1")}


def test_a_vehicle_named_as_parked_in_apposition_is_static():
    s = _text("V1 was traveling north on a residential street. V1 ran off the right side of the road and struck V2, "
              "a parked car.")
    assert s.actors["npc1"].behavior.value == "static"


def test_lanes_each_way_and_a_lane_change_from_the_ramp_is_to_the_left():
    s = _text("V1 was traveling east on an undivided roadway with two lanes each way. V2 was traveling east ahead of "
              "V1. The front of V1 struck the rear of V2.")
    assert s.road_network.number_of_lanes == 4
    s = _text("V1 was traveling east on a two-lane interstate. V2 was entering from the on-ramp. V2 changed lanes into "
              "the right lane and struck the right side of V1.")
    assert (s.road_network.number_of_ways, s.road_network.number_of_lanes) == (1, 3)
    assert s.actors["npc1"].behavior.value == "change_lane_left"


def test_at_a_junction_without_devices_the_vehicle_that_failed_to_stop_lacks_priority():
    s = _text("V1 was traveling east on a two-lane road. The road ended at a T-intersection with a north/south road. "
              "V2 was traveling south on that road. V1 failed to stop and the front of V1 struck the left side of V2.")
    assert s.road_network.road_type.value == "t_intersection"
    assert _oracle(s) == {("CVC_21800", "ego")}


def test_a_device_on_a_side_road_away_from_the_crash_is_left_out():
    s = _text("V1 was traveling east on a two-lane road. A side street controlled by a stop sign joined the road from "
              "the north. V2 was traveling east ahead of V1 and slowed. The front of V1 struck the rear of V2.")
    assert s.road_network.road_type.value == "straight" and s.road_network.traffic_signs == []
    s = _text("V1 was traveling north approaching an intersection controlled by traffic signals. V2 was stopped for "
              "the red signal ahead of V1. The front of V1 struck the rear of V2.")
    assert [t.value for t in s.road_network.traffic_signs] == ["traffic_light"]  # the queue of its signal


STOP_NORTH = ("V1 was traveling east approaching a four-leg intersection. V2 was traveling north on the intersecting "
              "road, which was controlled by a stop sign. ")


def test_driving_through_or_not_obeying_a_device_is_running_it():
    for told in ("V2 drove through the stop sign and the front of V2 struck the right side of V1.",
                 "The driver of V2 failed to obey the stop sign. The front of V2 struck the right side of V1."):
        assert _oracle(_text(STOP_NORTH + told)) == {("CVC_22450", "npc1")}, told
    s = _text("V1 was traveling east approaching a four-leg intersection controlled by traffic signals. V2 was "
              "traveling north. The driver of V2 failed to obey the traffic signal and the front of V2 struck the "
              "right side of V1.")
    assert _oracle(s) == {("CVC_21453", "npc1")}


def test_stopped_then_failed_to_yield_went_on_into_cross_traffic():
    s = _text(STOP_NORTH + "V2 stopped, then failed to yield the right-of-way to V1. The front of V1 struck the left "
              "side of V2.")
    assert s.actors["npc1"].behavior.value == "go_forward"
    assert _oracle(s) == {("CVC_21802", "npc1")}


def test_a_bend_is_a_curve_and_a_side_stated_for_oncoming_traffic_is_turned_round():
    crash = " V1 crossed the center line and the front of V1 struck the front of V2, which was traveling south."
    s = _text("V1 was traveling north on a two-lane road that bends to the right." + crash)
    assert (s.road_network.road_type.value, s.road_network.curve_direction.value) == ("curve", "right")
    s = _text("V1 was traveling north on a two-lane road. For southbound traffic the road curved to the left." + crash)
    assert (s.road_network.road_type.value, s.road_network.curve_direction.value) == ("curve", "right")


def test_made_a_lane_change_into_a_lane_is_a_lane_change_to_that_side():
    s = _text("V1 was traveling north in the right lane of a four-lane divided highway. V2 was traveling north in the "
              "left lane and made an unsafe lane change into the right lane. The right side of V2 struck the left "
              "side of V1.")
    npc = s.actors["npc1"]
    assert (npc.behavior.value, npc.position.relation.value) == ("change_lane_right", "left")
    assert _oracle(s) == {("CVC_22107", "npc1")}
