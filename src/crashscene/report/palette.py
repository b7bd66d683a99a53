"""The report's vehicle language: report labels (V1, V2, ...) and one colour per label, as crash sketches draw them.

CIREN/NHTSA scene sketches draw V1 red, V2 blue, V3 green and V4 tan; every
picture, animation and chart of the report uses the same colour for the same
label, so a reader can match the simulated view against the sketch at a glance.
"""
from __future__ import annotations

import re

LABEL_COLORS = ("#d7191c", "#1f4e9c", "#2e9a3e", "#c49a5a", "#7b3fa0", "#e07b00", "#4a9fb5", "#8c564b")
OTHER_COLOR = "#6b6b6b"  # a vehicle without a numbered label
_LABEL = re.compile(r"^\s*V\s*(\d+)\s*$", re.IGNORECASE)
_NPC = re.compile(r"^npc(\d+)$")


def label_of(role: str, label: str | None) -> str:
    """The report label of an actor: the DSL `label` when written, else V1 for ego and V(k+1) for npc k (dsl.md)."""
    if label and label.strip():
        match = _LABEL.match(label)
        return f"V{int(match.group(1))}" if match else label.strip()
    if role == "ego":
        return "V1"
    match = _NPC.match(role)
    return f"V{int(match.group(1)) + 1}" if match else role


def color_of(label: str) -> str:
    """Hex colour of a report label (V1 red, V2 blue, ...); the same label always gets the same colour."""
    match = _LABEL.match(label)
    if not match or int(match.group(1)) < 1:
        return OTHER_COLOR
    return LABEL_COLORS[(int(match.group(1)) - 1) % len(LABEL_COLORS)]


def rgb(color: str) -> tuple[int, int, int]:
    value = color.lstrip("#")
    return int(value[0:2], 16), int(value[2:4], 16), int(value[4:6], 16)


def label_sort_key(label: str) -> tuple[int, str]:
    match = _LABEL.match(label)
    return (int(match.group(1)), "") if match else (1 << 30, label)
