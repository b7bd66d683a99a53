"""The record of which bundled cases each extraction rule was written from, and the switches that turn
those rules off (issue 11).

An honest held-out figure needs to know which cases were looked at while a rule was written. Every rule of the
extractor is named in `RULE_SOURCES` and is a switch in the code: the rules extractor consults it with
`RulesState.uses(name)` and, when it is switched off (`extract_rules(..., off=...)`), falls back to what the
extractor did before the rule: the first round's reading where the rule replaced one (rear-end codes by phrase,
cause statements by label window), else nothing (the next phrasing of its table, or the convention default).
`crashscene eval --held-out` extracts every bundled case with each rule whose sources include that case switched
off (with `--folds K`: any case of its fold), so a case is scored only by rules written from other cases or from
the spec (`crashscene.extract.held_out`).

Three records: the first round's (below, `CONVENTION_RULES` and `ROUND_ONE_SOURCES`), and the later sessions'
(`LATER_SOURCES`). A rule rests on at least two cases, or was written from dsl.md (`FROM_CONVENTIONS`), or fires
on no bundled case (`FIRES_ON_NO_BUNDLED_CASE`); `tests/evaluation/test_folds.py` checks that, and that every case
named exists. Rules written in sessions 2 and 3 from synthetic narratives (`FROM_SYNTHETIC`) change no bundled
case's extraction but those they were corrected on (`tests/extract/test_held_out.py`). Rules with one source
were generalised (merged into the rule they are a case of), cited (their convention found) or dropped.

Issue 11's first rules were written looking at folds 0, 1 and 2 of `--folds 4` only, sparing fold 3 (105203,
109525, 3-C1-2017-001, 3-C1-2017-006, 3-C2-2017-002, 3-C2-2018-008, 3-C4-2017-002, 3-C4-2017-004, 3-C4-2018-015);
later rules name their own cases, fold 3's included, and `--held-out` replaces the spared fold.

Session 5 extended the test for what counts as a convention rule, and wrote it down (below, `THE_TEST`, and
`tests/extract/test_extended_conventions.py`) before measuring anything: the normative specs are dsl.md AND
rules.md, whose rulebook defines each code's trigger in its own words. Every case-written rule on the oracle's path
was then judged against it by its wording alone (`EXTENDED_TEST_DECISIONS`, each decision written before the held-out
table was measured again); rules whose wording mixes both kinds were split, the spec-worded part becoming a
convention rule (`SPEC_QUOTED_CONVENTIONS`, each citing the spec's words verbatim; a test finds them in the copy of
the specs under `tests/data/spec/`).

Session 6 kept the test and added two records: rules that pass it but were written while reading bundled cases'
texts name those cases (`SPEC_QUOTED_FROM_CASES`: held out like any case-written rule), and a split decided on a
first-round rule's wording (`SESSION_6_DECISIONS`) whose spec-worded part rests on no case (`SESSION_6_CONVENTIONS`).

Session 7 added deductions the integrator allowed (`SESSION_7_DEDUCTIONS`): a value the specs state, reached from facts
already decided through a step that follows from the specs' own sentences (each cited verbatim), not from a report's
phrasing. They rest on the specs (`DEDUCED_FROM_THE_SPECS`), and name the cases they were written for, which
`--held-out` switches them off on.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping

# The first round's rules (session 1, commits 45cdc70..c4787e2), written looking at all 37 bundled cases, each
# now a switch. Two kinds, decided by one test applied to each rule's wording, not by its score:
# - a convention rule: its trigger words AND the value it gives are both stated in dsl.md (sections 2, 3, 5) or in
#   issue 11's list of formulas and cause statements, up to inflection and spelling (centre/center). It implements
#   the spec, so it is written from no case (CONVENTION_RULES names the sentence it implements); tested one by one
#   on synthetic narratives (tests/extract/test_round_one_rules.py);
# - otherwise it was written from the reports (a phrasing the spec does not use, a heuristic): its sources are every
#   bundled case it fires on, since its author read them all. "Fires on" is measured, not remembered: switching
#   it off alone from the full extractor, or on alone over the first round's case-written rules all off, changes
#   that case's extraction, evidence included (crashscene.extract.held_out.measure_sources; a slow test checks
#   the record below against a new measurement).
CONVENTION_RULES: dict[str, str] = {
    "rules_environment.condition_words": "section 2 aliases and convention 4: clear/'no adverse conditions', daylight, "
                                         "dark (predawn), dawn, dusk; 'snow and ice covered' -> icy",
    "rules_environment.sketch_condition_notes": "convention 4: not_mentioned only when neither text nor sketch says",
    "rules_vehicles.travel_direction": "convention 7: headings worked out from the travel directions (V1 eastbound, "
                                       "V2 northbound: V2 comes from V1's right)",
    "rules_vehicles.lane_side": "section 3, convention 7: relation left|right = in the adjacent lane on that side",
    "rules_vehicles.body_type": "section 2 aliases: semi, tractor-trailer, bus, box truck -> truck; pickups, vans -> "
                                "car",
    "rules_road.divided_roadway": "convention 3: a divided roadway (median or barrier) is V1's carriageway alone",
    "rules_road.sketch_median": "convention 3 (median) read on the sketch; issue 11 point 2: sketch facts before "
                                "giving up",
    "rules_road.traffic_control_words": "convention 6 and section 3: signals, stop and yield signs controlling an "
                                        "approach; a flashing red is a stop_sign for the approach it faces",
    "rules_road.sketch_devices": "convention 6 read on the sketch (issue 11 point 2) when the text names no device",
    "rules_road.junction_words": "convention 2: a junction counts when an actor enters, leaves or turns at it",
    "rules_road.leg_words": "convention 2: 4 legs -> intersection; 3 legs, a driveway or a business access -> "
                            "t_intersection; section 2 alias T-intersection",
    "rules_road.curve_words": "convention 2: curve when the crash is on a stated curve",
    "rules_road.driveway_exit": "conventions 2 and 9: a driveway is a third leg; leaving a driveway -> CVC_21804",
    "rules_road.posted_limit": "section 3 and convention 6: the posted limit the report or sketch states (km/h "
                               "rounded to 5 mph); the text wins over the sketch",
    "rules_road.centre_line_words": "convention 5: double solid, solid, broken, solid beside broken or a two-way "
                                    "left-turn lane, unpaved or 'no centre markings' -> none",
    "rules_road.drawn_centre_line": "convention 5: the centre line as stated or clearly drawn",
    "rules_lanes.n_lane_road": "section 3 and convention 3: a 'two-lane, two-way road' is 2",
    # first recorded as case-written (sources 100343, 103341, 109176), then found to meet the test above
    "rules_lanes.divided_total_is_halved": "convention 3: a divided roadway is V1's carriageway alone (a 'four-lane "
                                           "divided' road: two lanes each way)",
    "rules_lanes.acceleration_lane_in_a_merge": "convention 3: an acceleration lane counts when a merge is part of "
                                                "the crash",
    "rules_behavior.lose_control_words": "section 3 lose_control (skid, yaw, rotation); convention 8 lost control",
    "rules_behavior.centre_line_crossing_words": "section 3 cross_centerline (enters the opposing lanes: drift, "
                                                 "wrong way); conventions 8 and 9: crossed the centre line",
    "rules_behavior.run_off_road_words": "section 3 leave_road (runs off the road edge); convention 8 ran off the road",
    "rules_behavior.overtake_words": "section 3 overtake (passes through the opposing lane and returns)",
    "rules_behavior.lane_change_words": "section 3 change_lane_*; conventions 2 and 8: merging -> a lane change",
    "rules_behavior.turn_words": "section 3 turn_left, turn_right, u_turn",
    "rules_behavior.stop_words": "section 3 stop (comes to or is at a stop); convention 8",
    "rules_behavior.stopped_then_proceeded": "convention 8: stopped at a sign then went straight -> go_forward",
    "rules_behavior.parked_words": "convention 1: a parked or disabled vehicle is static",
    "rules_behavior.slowing_words": "section 3 decelerate (slowing or braking in lane); convention 8",
    "rules_positions.behind_words": "section 3 front|behind along its lane; convention 11: struck in the rear",
    "rules_positions.stated_speed": "section 3: speed_mph only when the report states that actor's travel speed",
    "rules_road.junction_ahead_plays_no_part": "convention 2: a junction counts only when it plays a part (an "
                                               "intersection 'ahead' is not reached)",
    "rules_positions.parked_on_the_shoulder_side": "convention 7: a stationary vehicle takes relation from where it "
                                                   "stands relative to the ego's path",
    "rules_positions.lane_changer_comes_from_the_side_it_leaves": "section 3 change_lane_left|right and convention 7: "
                                                                  "relation is the adjacent lane it comes from",
    "rules_lanes.turn_lane_named_in_a_count": "convention 3: through lanes only, not turn lanes (a lane of a stated "
                                              "count named a turn lane)",
    "rules_behavior.slowing_traffic_is_the_leaders": "convention 8: slowing in traffic -> decelerate (the vehicles "
                                                     "ahead that make up that traffic); stop is stopped in a queue",
    "rules_behavior.opposing_entry_between_impacts": "section 3: the manoeuvre that leads to the vehicle's crash; "
                                                     "convention 8: crossed the centre line -> cross_centerline, read "
                                                     "up to the contact it leads to (convention 11: a later contact is"
                                                     " its own entry)",
}

# the first round's rules written from the reports: measured sources (see above)
ROUND_ONE_SOURCES: dict[str, tuple[str, ...]] = {
    "rules_behavior.shoulder_is_leaving_the_road": ('3-C1-2017-001', '3-C4-2018-015'),
    "rules_behavior.unoccupied_is_parked": (),
    "rules_behavior.veering_into_a_lane": ('100343', '3-C2-2017-002', '3-C4-2018-010'),
    "rules_behavior.waiting_is_stopped": (),
    "rules_behavior.waiting_to_turn_is_a_stop": ('120013', '3-C2-2018-008'),
    "rules_environment.more_condition_words": ('3-C4-2018-010', '3-C4-2018-015'),
    "rules_lanes.carriageway_lane_phrases": ("3-C1-2017-001", "3-C1-2018-003", "3-C1-2018-007", "3-C1-2018-012",
                                             "3-C4-2017-004", "3-C4-2018-012", "3-C4-2018-015", "3-C5-2017-002"),
    "rules_lanes.lanes_per_direction_phrases": ("100343", "103341", "109176", "119897", "3-C1-2017-001",
                                                "3-C1-2018-010", "3-C4-2017-002", "3-C4-2017-004", "3-C4-2017-007",
                                                "3-C4-2018-010", "3-C4-2018-012", "3-C5-2018-004"),
    "rules_lanes.odd_total_holds_a_turn_lane": ('117021', '3-C1-2018-007', '3-C4-2017-002'),
    "rules_lanes.one_lane_in_each_direction": (),
    "rules_lanes.through_lane_breakdown": ('3-C1-2018-003', '3-C4-2018-012'),
    "rules_oracle.angle_contact_is_crossing": (),
    "rules_oracle.more_cause_phrases": (),
    "rules_oracle.protected_arrow_exempts_a_left_turn": (),
    "rules_positions.rear_end_is_same_direction": (),
    "rules_road.centre_turn_lane_is_not_divided": (),
    "rules_road.freeway_is_divided": ("3-C1-2017-001", "3-C1-2018-003", "3-C1-2018-007", "3-C1-2018-012",
                                      "3-C5-2017-002"),
    "rules_road.passing_zone": (),
    "rules_road.straight_before_a_curve": (),
    "rules_vehicles.avoidance_is_not_the_manoeuvre": ('108812', '3-C2-2017-002', '3-C4-2018-012'),
    "rules_vehicles.more_truck_words": (),
    "rules_vehicles.summary_lead_is_not_the_sequence": (),
}

# rules written in sessions 2 and 3, each recorded as it was written
LATER_SOURCES: dict[str, tuple[str, ...]] = {
    # rules_collisions: the impact formulas ("the front of V2 struck the right side of V1", possessive planes,
    # "with its frontal plane", passive "was struck by", "collided head-on", "causing V1 to strike")
    "rules_collisions.impact_formula": ("100237", "100343", "103341", "108812", "117021", "119489", "119897",
                                        "121520", "3-C1-2018-012", "3-C4-2017-007"),
    "rules_collisions.possessive_and_with_its": ("3-C1-2018-003", "3-C1-2018-007", "3-C5-2018-004",
                                                 "3-C1-2018-010"),
    "rules_collisions.collided_head_on_at_fault": ("3-C2-2017-004", "3-C4-2018-010"),
    "rules_collisions.corner_by_configuration": ("3-C4-2018-012", "3-C5-2018-004", "3-C2-2017-004"),
    "rules_collisions.event_numbers_and_merge": ("3-C1-2018-003", "3-C4-2017-007", "3-C5-2018-004"),
    "rules_collisions.noun_impact_is_not_a_contact": ("3-C1-2018-003", "3-C5-2018-004"),
    # rules_road: who an unattributed stop or yield sign controls
    "rules_road.attribute_signs": ("100237", "117021"),
    # rules_oracle.sequence_rear_end (rear-end codes read from the crash sequence; 109176, 120013, 3-C1-2018-003,
    # 3-C1-2018-012, 3-C5-2018-004) and rules_oracle.cause_statements (cause statements by their subject; 117330,
    # 119897, 103341) were recorded here; session 5's test found both worded by the specs (EXTENDED_TEST_DECISIONS)
    # written after the record (41685c7, 6332e92) from synthetic narratives, naming no case: they change no
    # bundled case's extraction (tests/extract/test_held_out.py checks it), so they rest on no bundled case
    "rules_collisions.the_two_vehicles_collided": (),
    "rules_collisions.noun_only_contact": (),
    "rules_behavior.into_oncoming_path": (),
    "rules_oracle.left_turn_stated_oncoming": (),
    # issue 11, second session: written from dsl.md section 5 and synthetic narratives (tests/extract/
    # test_rules_conventions.py), before looking at any bundled case's text for them
    "rules_road.divided_by_a_line_is_not_divided": (),
    # its first form lost a field on two cases, then looked at (their marker quotes only): a "middle left-turn
    # lane" at a junction is a turn bay; a sketch's "Solid Yellow Line" names no road
    "rules_road.marker_phrasings": ("121520", "3-C4-2017-004"),
    "rules_road.every_flashing_signal": (),
    "rules_lanes.lanes_in_each_direction": (),
    "rules_positions.same_direction_on_one_carriageway": (),
    "rules_vehicles.manoeuvre_after_the_impact_verb": (),
    "rules_environment.snow_on_the_road_is_not_snowfall": (),
    "rules_oracle.red_light_only_when_disobeyed": (),
    "rules_oracle.stated_speed_above_the_limit": (),
    "rules_oracle.a_turning_vehicle_is_moving": (),
    "rules_vehicles.direction_in_any_clause": (),
    "rules_road.crossed_the_median_words": (),
    "rules_collisions.which_was_pushed_into": (),
    "rules_positions.limit_words_in_the_same_sentence": (),
    "rules_road.a_junction_some_distance_away_plays_no_part": (),
    "rules_road.leaving_an_access_is_a_junction": (),
    "rules_road.white_lines_separate_lanes": (),
    "rules_behavior.merging_from_a_ramp_is_to_the_left": (),
    "rules_positions.stated_opposite_direction": (),
    "rules_positions.access_side": (),
    # corrected on one case: "V2 skidded for 73 meters" is a braking skid, not a loss of control
    "rules_behavior.skids_slides_and_traction": ("3-C2-2018-008",),
    "rules_behavior.sitting_in_traffic_is_a_stop": (),
    "rules_behavior.leaving_the_road_is_primary_only_without_control_loss": (),
    "rules_behavior.crossing_to_pass_is_overtaking": (),
    "rules_behavior.stopped_to_turn_is_a_stop": (),
    "rules_behavior.parked_in_apposition": (),
    "rules_oracle.failed_to_stop_at_an_uncontrolled_junction": (),
    "rules_road.junction_devices_only_at_a_junction": (),
    "rules_oracle.disobeyed_device_phrasings": (),
    "rules_behavior.failing_to_yield_after_a_stop_is_proceeding": (),
    "rules_road.a_bend_is_a_curve": (),
    "rules_road.curve_side_for_a_stated_direction": (),
    "rules_behavior.made_a_lane_change": (),
}


# session 4: written from dsl.md conventions and synthetic narratives (tests/extract/test_rules_conventions.py)
# after the honest held-out table named the fields it lost (case ids and values, not the reports' texts); they
# rest on no case's text, and were not tuned on those cases
FROM_THE_HELD_OUT_TABLE: dict[str, str] = {
    "rules_behavior.struck_from_behind_before_the_turn_is_a_stop": "conventions 8 and 11: stopped in a queue and "
                                                                   "struck in the rear before the turn began",
    "rules_lanes.a_named_centre_turn_lane_is_not_a_through_lane": "convention 3: an odd N-lane total holding a "
                                                                  "named centre turn lane counts N - 1",
}

# session 5: the extended test, fixed before anything was measured (tests/extract/test_extended_conventions.py)
THE_TEST = """A rule is a convention rule when both what it reads (its trigger words, or facts the extractor has
already decided) and the value it gives are stated in a normative spec, up to inflection, spelling (centre/center),
hyphenation, articles and the qualifier that decides between two codes the spec itself names (left of "double
solid" centre lines is CVC_21460, left of the centre line CVC_21650). The normative specs are:
- dsl.md sections 2, 3 and 5 (grammar, meaning of each field, the conventions);
- rules.md, the rulebook: its table (each code's requirement and its quantitative check) and its paragraphs on
  collisions and reproduction; the rulebook defines each code's trigger in its own words;
- issue 11's list of impact formulas and cause statements.
A value may be reached through a chain in which every link is a stated sentence: rules.md states what a code
forbids, dsl.md convention 9 gives the code of a manoeuvre, device or contact, dsl.md section 3 names the manoeuvre.
Not enough, however close: a word the specs do not use (veer, swerve, steer, encroach, the shoulder as leaving the
road, waiting), a phrase read in a report, a heuristic (the sketch label drawn nearest a sign), a rule's score.
The decision is made on the wording alone, before the rule's held-out effect is measured. A rule whose wording
mixes both kinds is split: its spec-worded part becomes a convention rule citing the spec's words verbatim
(SPEC_QUOTED_CONVENTIONS), the rest stays recorded with the cases it was written from."""

# session 5: convention rules by the extended test, each citing the spec's words verbatim (file: "quote"; a test
# finds every quote in tests/data/spec/) and tested on a synthetic narrative
SPEC_QUOTED_CONVENTIONS: dict[str, str] = {
    "rules_behavior.rulebook_crossing_words":
        'rules.md CVC_21460: "never drive left of double solid centre lines", "beyond a double solid centre line"; '
        'rules.md CVC_21650: "in a lane of the opposite direction"; rules.md CVC_21650\'s token: "wrong_side"; '
        'dsl.md section 3 cross_centerline: "enters the opposing lanes"; dsl.md convention 9: "Entering the opposing '
        'lanes -> CVC_21650"; dsl.md convention 3: "crosses into the opposing carriageway"',
    "rules_road.sign_controls_by_the_spec":
        'rules.md CVC_21800: "at an intersection without signals or with all-way stops"; dsl.md convention 9: '
        '"no stop at a stop sign -> CVC_22450", "a yield sign not obeyed -> CVC_21803"; rules.md CVC_21802: "after '
        'stopping at a stop sign, yield to traffic on the through road"; dsl.md convention 8: "stopped at a sign '
        'then went straight"; dsl.md section 3: "if no actor names it, it controls the ego\'s approach"; issue 11\'s '
        'cause statements "failed to stop", "failed to yield"',
    "rules_collisions.spec_impact_formula":
        'dsl.md convention 11: "the front of V2 struck the right side of V1", "sideswiped", "A vehicle struck in the '
        'rear by a second vehicle", "keep the report\'s wording (V1 striking)"; issue 11\'s impact formulas',
    "rules_oracle.sequence_rear_end":
        'dsl.md convention 9: "striking a moving vehicle ahead -> CVC_21703", "a stopped one -> CVC_22350", read '
        'from the crash sequence of dsl.md convention 11 ("the contacts between actors, in the order they happen")',
    "rules_oracle.cause_statements":
        'dsl.md section 3 oracle: "each attributed to the actor that committed it"; dsl.md convention 9: "too fast '
        'for conditions", "stated speeding"; issue 11\'s statements "failed to stop", "too fast"',
}

# measured after these decisions were committed (`crashscene eval --gold examples/ciren --held-out --folds 4`):
# held-out oracle recall 77.5% -> 85.0% (precision 83.8% -> 81.0%), overall 94.1% -> 94.7%, collisions 25.6% ->
# 71.8%; the bundled extraction is byte for byte the same. Giving sequence_rear_end and cause_statements their
# session-2 sources back leaves recall at 85.0% (precision 82.9%): the recall comes from the three splits. One
# judgement was made after a measurement (of sources, not of scores): the remainder of more_crossing_phrases fired on
# one case, and was merged into veering_into_a_lane.

# session 5: every case-written rule on the oracle's path (manoeuvres, devices, the crash sequence, the oracle)
# judged against THE_TEST by its wording, written before the held-out table was measured again
EXTENDED_TEST_DECISIONS: dict[str, str] = {
    "rules_behavior.veering_into_a_lane":
        "stays: veer, move, steer, swerve are not the specs' words; 'drift' is (dsl.md section 3), but only for the "
        "opposing lanes, which the convention rule centre_line_crossing_words already reads ('into the southbound "
        "lane' while northbound); a drift into a lane of the same direction is a lane change nowhere in the specs. "
        "It also holds what is left of the first round's more_crossing_phrases (sources 117330, 3-C2-2017-002), "
        "split: 'left of center' is rules.md's 'left of ... centre lines' (CVC_21460/21650), moved to "
        "rules_behavior.rulebook_crossing_words with the specs' other words for the same concept; 'encroached into "
        "V2's lane' (rules.md has only 'post-encroachment time', a metric) and 'against the flow' are not the "
        "specs' words. Re-measured, they fired on one case alone (3-C2-2017-002), so they were merged here, into the "
        "reports' other words for moving into a lane, rather than kept as a rule resting on one case",
    "rules_behavior.shoulder_is_leaving_the_road":
        "stays: the specs name the shoulder only as a lane not counted (dsl.md convention 3), never as leaving the "
        "road",
    "rules_behavior.waiting_to_turn_is_a_stop":
        "stays: 'stopped and not proceeding' is convention 8, but the trigger ('waiting', 'preparing', 'intending' "
        "to turn) is not the specs' words",
    "rules_vehicles.avoidance_is_not_the_manoeuvre":
        "stays: 'avoid' is not the specs' word",
    "rules_road.attribute_signs":
        "split: an all-way stop controls every approach (rules.md CVC_21800), the vehicle stated as failing to stop "
        "or yield or as stopped at the sign is the one it controls (issue 11's statements, conventions 8 and 9, "
        "rules.md CVC_21802), and a sign no vehicle is tied to controls V1's approach (dsl.md section 3): moved to "
        "rules_road.sign_controls_by_the_spec; the sketch label drawn nearest the sign, and the phrasings 'did not "
        "yield/stop/see/observe', 'without stopping', 'ran the', 'disregarded the', stay here",
    "rules_collisions.impact_formula":
        "split: contacts read with 'struck' (and 'sideswiped'), dsl.md convention 11's own formula, moved to "
        "rules_collisions.spec_impact_formula; the other verbs (impacted, contacted, hit, rear-ended, collided with, "
        "crashed into, ran into) stay here",
    "rules_collisions.possessive_and_with_its":
        "stays: 'V1's frontal plane', 'with its frontal plane' are not the formula's words",
    "rules_collisions.collided_head_on_at_fault":
        "stays: 'head-on' is a class word of the specs, but the striker as the vehicle at fault is not stated",
    "rules_collisions.corner_by_configuration": "stays: areas from the configuration are not stated",
    "rules_collisions.event_numbers_and_merge":
        "stays: 'Event 2' is issue 11's, but the merge of repeated readings of one contact is not stated; not split "
        "this session",
    "rules_collisions.noun_impact_is_not_a_contact": "stays: not stated (it narrows what is read)",
    "rules_oracle.sequence_rear_end":
        "reclassified as a convention rule: it reads the crash sequence (convention 11) and gives convention 9's "
        "codes for striking a vehicle ahead, moving (CVC_21703) or stopped (CVC_22350); written in session 2 looking "
        "at 109176, 120013, 3-C1-2018-003, 3-C1-2018-012, 3-C5-2018-004",
    "rules_oracle.cause_statements":
        "reclassified as a convention rule: the statements are the specs' (issue 11, convention 9) and the rule "
        "attributes each to the vehicle that committed it (dsl.md section 3), the clause's acting vehicle; written in "
        "session 2 looking at 117330, 119897, 103341",
}

# session 6: rules that pass THE_TEST (each cites the specs' words verbatim, checked like SPEC_QUOTED_CONVENTIONS)
# but were written while reading bundled cases' texts: those cases are recorded as their sources, so `--held-out`
# switches the rule off for them (and, with --folds, for their folds), as for any case-written rule
SPEC_QUOTED_FROM_CASES: dict[str, tuple[str, tuple[str, ...]]] = {
    "rules_behavior.lane_of_the_opposite_direction": (
        'rules.md CVC_21650: "in a lane of the opposite direction"; dsl.md section 3 cross_centerline: "enters the '
        'opposing lanes"; dsl.md convention 9: "Entering the opposing lanes -> CVC_21650"; dsl.md convention 7: '
        '"worked out from the travel directions". The lane is named by its direction of travel whatever qualifies '
        "it ('into the adjacent northbound travel lane' while southbound), or by a vehicle travelling the "
        "opposite way ('into V1's lane', 'into the lane of V1'); the verb does not decide (encroach, move, drift "
        "alike)",
        ("3-C2-2017-002", "3-C4-2018-010")),
    "rules_road.separated_by_a_barrier": (
        'dsl.md section 3: "seven lanes separated by a barrier"; dsl.md convention 3: "A divided roadway (median or '
        'barrier) is V1\'s carriageway alone". The directions separated by a barrier or a median whatever qualifies '
        "it ('separated from the northbound traffic-way by a positive concrete traffic barrier')",
        ("3-C1-2018-003", "3-C1-2018-007")),
}

# session 6: the split of a first-round rule by THE_TEST, decided on its wording before the held-out table was
# measured again; its spec-worded part cites the specs verbatim and rests on no case
SESSION_6_DECISIONS: dict[str, str] = {
    "rules_lanes.lanes_per_direction_phrases":
        "split: a count of lanes, or of through lanes, stated for one direction of travel ('two northbound lanes', "
        "'two lanes southbound', 'three through lanes eastbound'), summed over the directions, is dsl.md section 3's "
        "own definition: moved to rules_lanes.through_lanes_per_direction; 'travel lanes', 'straight through' and a "
        "count with no word 'lanes' ('two northbound and two southbound') are not the specs' words and stay here",
    "rules_behavior.veering_into_a_lane":
        "unchanged; its 'encroach ... into V2's lane' is, for a vehicle travelling the other way, also read by "
        "rules_behavior.lane_of_the_opposite_direction, by the lane (rules.md's 'a lane of the opposite direction'), "
        "not by the verb",
    "rules_collisions.impact_formula":
        "split again: 'rear-ended' (and 'rear-ending', 'rear-ends') is dsl.md's class token rear_end up to hyphenation "
        "and inflection, the contact rules.md calls 'struck from behind': moved to rules_collisions.rear_end_as_a_verb; "
        "the other verbs (impacted, contacted, hit, collided with, crashed into, ran into) and the noun 'impact' stay",
    "rules_collisions.possessive_and_with_its":
        "split: the genitive ('V3's frontal plane struck V4's back plane', 'V1's left side was struck by') is convention "
        "11's formula up to inflection (the genitive 's) and articles: moved to rules_collisions.genitive_impact_formula; "
        "'with its frontal plane' (the striker's area in a trailing phrase) is not the formula's words and stays",
}
SESSION_6_CONVENTIONS: dict[str, str] = {
    "rules_lanes.through_lanes_per_direction":
        'dsl.md section 3: "counts the through lanes of that roadway in both directions"; dsl.md convention 3: '
        '"counting through lanes only", "is V1\'s carriageway alone: number_of_ways: 1 and its lanes"; dsl.md '
        'convention 7: "V1 eastbound, V2 northbound"',
    "rules_collisions.rear_end_as_a_verb":
        'dsl.md section 3 (class): "front into rear, same direction -> '
        'rear_end"; rules.md: "rear_end (relative heading under 30°, struck from behind)"; dsl.md convention 11: '
        '"keep the report\'s wording (V1 striking)"',
    "rules_behavior.lane_change_into_a_vehicle":
        'dsl.md convention 9: "lane change or merge into another vehicle -> CVC_22107"; dsl.md section 3: '
        '"change_lane_left|right"; dsl.md convention 8: "merging -> a lane change"; dsl.md section 3 position: '
        '"left|right = in the adjacent lane or on that side". A lane change or merge into a named vehicle\'s lane '
        "or path takes the side from the changer's stated lane to that vehicle's",
    "rules_collisions.genitive_impact_formula":
        'dsl.md convention 11: "the front of V2 struck the right side of V1", "Read the impact from the narrative\'s '
        'formula"; the genitive ("V2\'s front struck V1\'s right side") is the same formula up to inflection',
}

# session 7: deductions the integrator allowed (issue 11): each reads only facts the extractor has already decided
# and gives a value the specs state, through a step that follows from the specs' own sentences (cited verbatim,
# checked like SPEC_QUOTED_CONVENTIONS) rather than from any report's phrasing; it was written for the cases
# named, which `--held-out` switches it off on. Tested on synthetic narratives (tests/extract/test_session_7_rules.py)
SESSION_7_DEDUCTIONS: dict[str, tuple[str, tuple[str, ...]]] = {
    "rules_positions.struck_in_the_order_of_their_positions": (
        'dsl.md section 1: "the contacts between actors, in the order they happen"; dsl.md section 3 collisions: '
        '"every contact between two actors, first harmful event first"; dsl.md section 3 class: "front into rear, '
        'same direction -> rear_end"; rules.md: "rear_end (relative heading under 30°, struck from behind)"; dsl.md '
        'section 3 position: "front|behind = ahead of / behind it along its lane"; dsl.md convention 7: "Traffic in '
        'the ego\'s lane, an adjacent lane or oncoming references ego (front/behind/left/right)". A striker keeping '
        "one lane meets the vehicles in it in the order of their positions: of two it rear-ends, the one struck "
        "earlier is behind the one struck later (the integrator's decision, session 7)",
        ("3-C1-2018-003",)),
    "rules_oracle.no_lane_change_into_a_vehicle_out_of_control": (
        'dsl.md convention 9: "lane change or merge into another vehicle -> CVC_22107", "losing control, or too fast '
        'for conditions -> CVC_22350"; rules.md CVC_22107: "during a lane change, a vehicle in the target lane must '
        'brake harder"; dsl.md section 3: "lose_control (skid, yaw, rotation)". A vehicle that lost control left its '
        "own path: a lane changer whose every contact is with such a vehicle moved into no vehicle of its target "
        "lane, and is not charged CVC_22107 (the integrator's decision, session 7)",
        ("103341",)),
    "rules_road.a_centre_line_lies_between_the_edges": (
        'dsl.md convention 5: "is the centre line of V1\'s road, as stated or clearly drawn", "nothing stated or '
        'clearly drawn -> not_mentioned"; rules.md CVC_21650: "drive on the right half of a two-way roadway"; '
        'rules.md CVC_21460: "never drive left of double solid centre lines". The centre line parts the two halves '
        "of the roadway, so drawn road (its lanes, up to the edges) lies on both sides of it: a double stroke with "
        "drawn road on one side only is a double-drawn road edge, not a clearly drawn centre line "
        "(crashscene.extract.sketch, 'double line drawn only at a road edge')",
        ("105203", "109525")),
    "rules_behavior.into_another_lane_of_its_direction": (
        'dsl.md section 3: "change_lane_left|right"; rules.md CVC_22107: "during a lane change, a vehicle in the '
        'target lane"; dsl.md section 3 position: "left|right = in the adjacent lane or on that side"; dsl.md '
        'convention 7: "worked out from the travel directions". A vehicle stated in one lane of its direction that '
        "goes into another lane of that direction, named by its side ('into the left northbound lane' from the "
        "right northbound lane), changes lanes to that side whatever the verb; the same-direction sibling of "
        "rules_behavior.lane_of_the_opposite_direction",
        ("100343",)),
    "rules_road.a_curved_centre_line_in_short_runs": (
        'dsl.md convention 5: "is the centre line of V1\'s road, as stated or clearly drawn", "double solid -> '
        'double_solid_line"; dsl.md convention 2: "on a stated or drawn curve". A line drawn along a curve is no '
        "long straight stroke: when the drawing has no long double line, a double line found on straight runs of a "
        "tenth of the short side (crashscene.extract.sketch, 'curved double solid line drawn'), "
        "with drawn road on both sides, is the drawn centre line",
        ("3-C1-2018-005",)),
}

RULE_SOURCES: dict[str, tuple[str, ...]] = {**ROUND_ONE_SOURCES, **{rule: () for rule in CONVENTION_RULES},
                                            **LATER_SOURCES, **{rule: () for rule in FROM_THE_HELD_OUT_TABLE},
                                            **{rule: () for rule in SPEC_QUOTED_CONVENTIONS},
                                            **{rule: cases for rule, (_, cases) in SPEC_QUOTED_FROM_CASES.items()},
                                            **{rule: () for rule in SESSION_6_CONVENTIONS},
                                            **{rule: cases for rule, (_, cases) in SESSION_7_DEDUCTIONS.items()}}

# sessions 2 and 3: written from dsl.md section 5 and synthetic narratives, not from bundled cases: they name no
# case, or only the cases they were corrected on after `crashscene eval --held-out` showed a loss there (those
# count as looked at); they change no bundled case's extraction but those
FROM_SYNTHETIC = frozenset(rule for rule, cases in LATER_SOURCES.items() if len(cases) < 2) | {
    "rules_road.marker_phrasings"}
# every rule written from the spec rather than from a case: the first round's convention rules and FROM_SYNTHETIC
FROM_CONVENTIONS = FROM_SYNTHETIC | frozenset(CONVENTION_RULES) | frozenset(FROM_THE_HELD_OUT_TABLE) | \
    frozenset(SPEC_QUOTED_CONVENTIONS) | frozenset(SESSION_6_CONVENTIONS)
# rules resting on the specs' sentences, not on their source cases' phrasing, though written with those cases in
# view (their sources are recorded and held out all the same)
DEDUCED_FROM_THE_SPECS = frozenset(SESSION_7_DEDUCTIONS)
# the first round's case-written rules that fire on no bundled case today: no bundled figure depends on them
FIRES_ON_NO_BUNDLED_CASE = frozenset(rule for rule, cases in ROUND_ONE_SOURCES.items() if not cases)


def known_rule(name: str) -> str:
    """`name` when it is a recorded rule; a KeyError naming the recorded rules otherwise."""
    if name not in RULE_SOURCES:
        raise KeyError(f"{name!r} is not a recorded rule; recorded: {', '.join(sorted(RULE_SOURCES))}")
    return name


def rules_written_from(cases: Iterable[str], sources: Mapping[str, Iterable[str]] | None = None) -> frozenset[str]:
    """The recorded rules whose sources include any of `cases`: the ones to switch off to hold them out."""
    wanted = set(cases)
    return frozenset(rule for rule, written_from in (sources or RULE_SOURCES).items() if wanted & set(written_from))
