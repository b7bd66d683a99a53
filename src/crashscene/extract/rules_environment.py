"""Rules extractor: weather, light and road surface from the narrative's condition sentences
(and condition notes on the sketch: "Dusk, dry, clear skies", "DAYLIGHT/CLEAR/BT/DRY").

Each field takes the first token of its table whose phrasing occurs, so the table order is the
precedence: sleet before rain before fog ... before clear; "predawn" is night (dsl.md convention 4).
"""
from __future__ import annotations

import re

from crashscene.extract.narrative import around
from crashscene.extract.rules_state import RulesState

_CONDITION_SENTENCE = re.compile(
    r"weather|sky|skies|\bhours\b|daylight|dark|dawn|dusk|night|rain|snow|sleet|fog|cloudy|overcast|conditions|"
    r"surface|\b(?:dry|wet|icy)\b|roads were", re.I)
_SKETCH_CONDITIONS = re.compile(r"daylight|dark|dusk|dawn|clear|rain|dry|wet", re.I)

# dsl.md section 2 (tokens and aliases) and convention 4: each token's own word and the spec's aliases
# (sunny, fair -> clear; "no adverse conditions" -> clear; daylight -> daytime; dark, predawn -> nighttime;
# "snow and ice covered" -> icy), in precedence order: sleet before rain before fog ... before clear
WEATHER = (
    (r"\bsleet|\bsnow(?:ing|fall)?\b(?! (?:and ice )?covered)|\bblizzard", "snowy"),
    (r"\brain(?:ing|y)?\b", "rainy"),
    (r"\bfog(?:gy)?\b", "foggy"),
    (r"\bovercast\b", "overcast"),
    (r"\bcloudy\b", "cloudy"),
    (r"\bwindy\b", "windy"),
    (r"\bclear\b|no adverse|\bsunny\b|\bfair\b", "clear"),
)
TIME_OF_DAY = (
    (r"\bpre-?dawn\b", "nighttime"),
    (r"\bdawn\b", "dawn"),
    (r"\bdusk\b", "dusk"),
    (r"\bdark(?:ness)?\b|\bnight(?:time)?\b", "nighttime"),
    (r"\bdaylight\b|\bday ?time\b", "daytime"),
)
ROAD_SURFACE = (
    (r"\bic(?:y|e)\b|snow and ice|ice[- ]covered|snow[- ]covered", "icy"),  # "snow and ice covered" -> icy
    (r"\bwet\b", "wet"),
    (r"\bdry\b", "dry"),
)
# the first round's further words, read in the reports (not in dsl.md): a recorded rule
MORE_WORDS = {
    "rainy": r"|\bdrizzl|\bshowers\b", "foggy": r"|\bmist\b", "cloudy": r"|\bclouds\b", "windy": r"|\bhigh winds?\b",
    "daytime": r"|\bafternoon\b|\bmorning hours\b|\bmid-?day\b|\bnoon\b",
}


def decide_environment(state: RulesState) -> dict:
    """weather, time_of_day and road_surface; the narrative first, then condition notes on the sketch;
    `not_mentioned` when neither says (convention 4: the case XML's coded conditions are not used)."""
    narrative = " ".join(s for s in state.t.sentences if _CONDITION_SENTENCE.search(s))
    notes = [f for f in state.fact_texts("text: ") if _SKETCH_CONDITIONS.search(f) and ("/" in f or "," in f)] \
        if state.uses("rules_environment.sketch_condition_notes") else []  # convention 4: "neither text nor sketch"
    sources = (narrative, " ".join(notes))
    return {"weather": _first(state, "environment.weather", sources, WEATHER),
            "time_of_day": _first(state, "environment.time_of_day", sources, TIME_OF_DAY),
            "road_surface": _first(state, "environment.road_surface", sources, ROAD_SURFACE)}


# snow lying on the road is the surface, not the weather: "covered in snow and ice", "packed snow"
_SNOW_ON_THE_ROAD = r"(?<!covered in )(?<!covered with )(?<!covered by )(?<!packed )(?<!patches of )"


def _first(state: RulesState, path: str, sources: tuple[str, ...], table: tuple[tuple[str, str], ...]) -> str:
    if not state.uses("rules_environment.condition_words"):
        table = tuple((r"(?!)", token) for _, token in table)  # never matches: the more words alone, if on
    if state.uses("rules_environment.more_condition_words") and table is not ROAD_SURFACE:
        table = tuple((pattern + MORE_WORDS.get(token, ""), token) for pattern, token in table)
    if table[0][1] == "snowy" and state.uses("rules_environment.snow_on_the_road_is_not_snowfall"):
        table = tuple((pattern.replace(r"\bsnow(?:ing", _SNOW_ON_THE_ROAD + r"\bsnow(?:ing"), token)
                      for pattern, token in table)
    for text in sources:
        for pattern, token in table:
            match = re.search(pattern, text, re.I)
            if match:
                state.note(path, around(text, match) if text is sources[0] else f"sketch: {match.group(0)}")
                return token
    return "not_mentioned"
