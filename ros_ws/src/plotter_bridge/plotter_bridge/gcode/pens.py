"""Pen changes (M6 once something is drawn): the travel to the park position
and back around each, and what the operator is told about the next pen.

The job stops at a pen change with the pen up; parked where the operator can
reach the holder, the pen comes back to where it left the drawing before the
program goes on, so the moves after it start where the program has them.
"""
from __future__ import annotations

import re
from typing import Iterable, Iterator, List, Optional, Sequence, Tuple

from .types import PEN_UP, Item, Move, ToolChange

_COLOUR = re.compile(r"#[0-9a-fA-F]{6}\b")


def park_for_changes(items: Sequence[Item], park: Optional[Tuple[float, float]]) -> List[Item]:
    """The items with a pen-up travel to `park` before each ToolChange and back after it
    (None: the pen waits, lifted, where it is)."""
    return list(iter_park_for_changes(items, park))


def iter_park_for_changes(items: Iterable[Item], park: Optional[Tuple[float, float]]) -> Iterator[Item]:
    """park_for_changes one item at a time."""
    at: Optional[Tuple[float, float]] = None
    feed = 0.0
    for item in items:
        if isinstance(item, Move):
            at, feed = (item.x, item.y), item.feed
        if isinstance(item, ToolChange) and item.wait and park is not None and at is not None \
                and at != tuple(park):
            px, py = float(park[0]), float(park[1])
            yield Move(item.line, "line", at[0], at[1], px, py, feed, PEN_UP, rapid=True)
            yield item
            yield Move(item.line, "line", px, py, at[0], at[1], feed, PEN_UP, rapid=True)
        else:
            yield item


def change_label(change: ToolChange) -> str:
    """What the operator is told at a pen change: the M6 line's comment, or the tool."""
    return change.label or f"pen T{change.tool}"


def label_colour(label: str) -> str:
    """The colour a label names as #rrggbb (lower case), or ""."""
    m = _COLOUR.search(label)
    return m.group().lower() if m else ""
