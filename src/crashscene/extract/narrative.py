"""Narrative text for the rule-based extractor: labels, sentences, who does what, quotes.

NHTSA narratives name vehicles many ways ("Vehicle one (V1 - case vehicle)",
"Vehicle #2", "Vehicles 1, 3, and 4", "a 2016 Kia Rio (V1)"); `Narrative`
folds them to V1, V2, ... and splits sentences. `label_at` decides which
vehicle a phrase describes (the nearest preceding label that is not an object:
"V2 struck V1" is V2's action, "the driver of V2" is V2). `clip` and `around`
cut the evidence quotes that go into a scenario's `evidence`.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

from crashscene.units import KMH_PER_MPH

NUMBERS = {"one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9,
           "ten": 10, "single": 1, "1": 1, "2": 2, "3": 3, "4": 4, "5": 5, "6": 6, "7": 7, "8": 8, "9": 9}
NUM = r"(one|two|three|four|five|six|seven|eight|nine|ten|single|\d)"  # a lane or leg count in words or digits
COMPASS = {"north": 0, "east": 90, "south": 180, "west": 270}  # [deg] clockwise from north
DIR = r"(north|south|east|west)"


def _label_sub(match: re.Match) -> str:
    return f"V{NUMBERS[match.group(1).lower()]}"


@dataclass
class Narrative:
    """The narrative with vehicle labels normalised, split into sentences."""

    raw: str
    text: str = ""
    sentences: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        text = self.raw.replace("\u2019", "'").replace("\u201c", '"').replace("\u201d", '"')
        text = re.sub(r"\bVehicles\s+((?:[1-9](?:,\s*|\s+and\s+|,\s+and\s+))+[1-9])\b",
                      lambda m: re.sub(r"([1-9])", r"V\1", m.group(1)), text)
        text = re.sub(r"\b(?:Vehicle|Veh\.?|Vehicle\s+number)\s*#?\s*(one|two|three|four|five|[1-9])\b",
                      _label_sub, text, flags=re.I)
        text = re.sub(r"\bV-?\s?([1-9])\b", r"V\1", text)
        text = re.sub(r"\bV([1-9])\s*\(\s*V\1\b[^)]*\)", r"V\1", text)  # "V1 (V1 - case vehicle)"
        text = re.sub(r"\s+", " ", text)
        self.text = text
        # split on sentence ends, not on abbreviations like "approx." followed by a number
        parts = re.split(r"(?<=[.!?])\s+(?=[A-Z0-9\"(])", text)
        self.sentences = [p.strip() for p in parts if p.strip()]


def clip(text: str, limit: int = 220) -> str:
    """One line of at most `limit` characters."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3].rstrip() + "..."


def around(text: str, match: re.Match, width: int = 90) -> str:
    """The match with `width` characters of context either side, as an evidence quote."""
    start = max(0, match.start() - width)
    end = min(len(text), match.end() + width)
    return clip(("..." if start else "") + text[start:end] + ("..." if end < len(text) else ""))


# words after which a label is the object of the phrase, not its subject: "struck V2", "behind V1"
OBJECT_BEFORE = re.compile(r"(?:pass|passing|overtak\w*|struck|strike|striking|hit|avoid|avoiding|behind|following|"
                            r"follow|with|toward|towards|than|into|see|saw|approaching|and|of|front of|rear of|"
                            r"side of|by)\s+(?:the\s+)?$", re.I)


def subject_of(sentence: str) -> str | None:
    """The first vehicle label in the sentence that is not an object ('struck V2', 'behind V1')."""
    for match in re.finditer(r"\bV([1-9])\b", sentence):
        before = sentence[max(0, match.start() - 25):match.start()]
        if re.search(r"driver\s+of\s+(?:the\s+)?$", before, re.I) or not OBJECT_BEFORE.search(before):
            return f"V{match.group(1)}"
    return None


def label_at(text: str, position: int) -> str | None:
    """The acting vehicle for a phrase at `position`: nearest preceding label that is not an object."""
    clause_start = max(text.rfind(". ", 0, position), text.rfind("; ", 0, position))
    adjacent = re.search(r"\bV([1-9])\s+(?:was\s+|were\s+|had\s+|is\s+)?$", text[max(0, position - 16):position])
    if adjacent:  # "did not see V1 stopped": the phrase describes the label right before it
        return f"V{adjacent.group(1)}"
    best = None
    for match in re.finditer(r"\bV([1-9])\b", text[:position]):
        if match.start() < clause_start:
            continue
        before = text[max(0, match.start() - 25):match.start()]
        if re.search(r"driver\s+of\s+(?:the\s+)?$", before, re.I) or not OBJECT_BEFORE.search(before):
            best = f"V{match.group(1)}"
    return best


def label_after(text: str, position: int) -> str | None:
    """The first label within 60 characters after `position` in the same sentence."""
    match = re.match(r"[^.]{0,60}?\b(V[1-9])\b", text[position:])
    return match.group(1) if match else None


def last_label_before(text: str, position: int) -> str | None:
    """The last label mentioned anywhere before `position`."""
    labels = re.findall(r"\bV([1-9])\b", text[:position])
    if labels:
        return f"V{labels[-1]}"
    return None


def count_word(word: str) -> int:
    """'three' or '3' -> 3; unknown words -> 0."""
    return NUMBERS.get(word.lower(), 0)
