"""Property-based: random valid documents round-trip; random junk only ever raises DslError."""
from __future__ import annotations

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from crashscene.dsl import DslError, dumps, from_raw, loads
from crashscene.dsl import tokens as t

TEXT = st.text(st.characters(blacklist_categories=("Cs",)), max_size=40)


@st.composite
def scenarios(draw) -> dict:
    n_npcs = draw(st.integers(0, 3))
    names = ["ego"] + [f"npc{i}" for i in range(1, n_npcs + 1)]

    def actor(name: str) -> dict:
        refs = [e.value for e in t.RoadElement] + [n for n in names if n != name]
        pos = {"reference": draw(st.sampled_from(refs)), "relation": draw(st.sampled_from(list(t.Relation)))}
        if name != "ego" and draw(st.booleans()):
            pos["heading"] = draw(st.sampled_from(list(t.Heading)))
        out = {"type": draw(st.sampled_from(list(t.ActorType))), "behavior": draw(st.sampled_from(list(t.Behavior))),
               "position": pos}
        if draw(st.booleans()):
            out["label"] = draw(TEXT)
        if draw(st.booleans()):
            out["speed_mph"] = draw(st.integers(1, 120))
        return out

    road = {"road_type": draw(st.sampled_from(list(t.RoadType))), "number_of_ways": draw(st.sampled_from([1, 2])),
            "number_of_lanes": draw(st.integers(1, 8)), "road_marker": draw(st.sampled_from(list(t.RoadMarker))),
            "traffic_signs": draw(st.lists(st.sampled_from(list(t.Sign)), max_size=4))}
    if draw(st.booleans()):
        road["speed_limit_mph"] = draw(st.integers(1, 16)) * 5
    doc = {"environment": {"weather": draw(st.sampled_from(list(t.Weather))),
                           "time_of_day": draw(st.sampled_from(list(t.TimeOfDay)))},
           "road_network": road, "actors": {name: actor(name) for name in names},
           "oracle": [{"code": draw(st.sampled_from(sorted(t.MONITORED_CODES) + ["CVC_21804"])),
                       "violation": "x_" + draw(st.sampled_from(["a", "b"])),
                       "actor": draw(st.sampled_from(names)), "description": draw(TEXT)}
                      for _ in range(draw(st.integers(0, 2)))],
           "evidence": draw(st.dictionaries(st.sampled_from(["environment", "oracle[0]", "odd key: x"]), TEXT,
                                            max_size=3))}
    if draw(st.booleans()):
        doc["summary"] = draw(TEXT)
    if draw(st.booleans()):
        doc["scenario_id"] = draw(TEXT.filter(lambda s: s.strip() != ""))
    return doc


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
def test_valid_documents_roundtrip(doc: dict) -> None:
    scenario = from_raw(doc)
    text = dumps(scenario)
    again = loads(text)
    assert again == scenario
    assert dumps(again) == text


JUNK = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True) | TEXT,
    lambda children: st.lists(children, max_size=4) | st.dictionaries(TEXT, children, max_size=4),
    max_leaves=20,
)


def _mutate(doc: dict, path: list, value) -> dict:
    node = doc
    for key in path[:-1]:
        if not isinstance(node, dict) or key not in node:
            return doc
        node = node[key]
    if isinstance(node, dict):
        node[path[-1]] = value
    return doc


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios(), st.sampled_from([["environment"], ["environment", "weather"], ["road_network", "number_of_lanes"],
                                     ["actors"], ["actors", "ego"], ["actors", "ego", "position"], ["oracle"],
                                     ["evidence"], ["road_network", "traffic_signs"], ["summary"], ["dsl_version"]]),
       JUNK)
def test_invalid_documents_raise_only_dsl_error(doc: dict, path: list, junk) -> None:
    doc = _mutate(doc, path, junk)
    try:
        text = yaml.safe_dump(doc, allow_unicode=True)
    except yaml.YAMLError:
        return
    try:
        loads(text, source="fuzz.yaml")
    except DslError as exc:
        assert exc.diagnostics and all(d.file == "fuzz.yaml" for d in exc.diagnostics)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=300))
def test_arbitrary_text_raises_only_dsl_error(text: str) -> None:
    try:
        loads(text)
    except DslError:
        pass


def test_an_identifier_with_a_trailing_newline_roundtrips() -> None:
    """Hypothesis once found 'A\\n': YAML reads the plain scalar back without its newline, so it must be quoted."""
    scenario = from_raw({"environment": {"weather": "clear", "time_of_day": "day"},
                         "road_network": {"road_type": "straight", "number_of_ways": 2, "number_of_lanes": 2,
                                          "road_marker": "solid_line", "traffic_signs": []},
                         "actors": {"ego": {"type": "car", "behavior": "go_straight",
                                            "position": {"reference": "road", "relation": "front"}}},
                         "oracle": [], "scenario_id": "A\n"})
    assert loads(dumps(scenario)) == scenario
