"""Whether a shape's program fits the work area, said in the shape's terms.

The streamer checks every program against the work area before anything
moves, but its refusal names a G-code line; a user who asked for a circle
of size 150 wants to hear about the circle.  So the shape server checks the
program it built with the same parser and the same area first, and names
how far the shape reaches.
"""
from __future__ import annotations

from typing import List, Optional, Tuple

from plotter_bridge.gcode.geometry import arc_extreme_points
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.parser import moves_of, parse

Box = Tuple[float, float, float, float]     # x_min, x_max, y_min, y_max (mm)


def extent(program: str) -> Optional[Box]:
    """The box around every point the program's moves reach (arcs at their
    extreme points too), from wherever the pen starts; None without moves."""
    points: List[Tuple[float, float]] = []
    for i, move in enumerate(moves_of(parse(program))):
        if i > 0 or not move.rapid:           # the first travel starts wherever the pen is
            points.append((move.sx, move.sy))
        points.append((move.x, move.y))
        if move.kind == "arc":
            points += arc_extreme_points((move.sx, move.sy), (move.x, move.y), (move.cx, move.cy), bool(move.cw))
    if not points:
        return None
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return min(xs), max(xs), min(ys), max(ys)


def outside(program: str, area: WorkArea) -> Optional[str]:
    """Why the program's shape does not fit the area, or None."""
    box = extent(program)
    if box is None:
        return None
    x0, x1, y0, y1 = box
    if area.contains(x0, y0) and area.contains(x1, y1):
        return None
    return (f"does not fit the work area ({area.describe()}): it reaches "
            f"X {x0:.1f}..{x1:.1f} mm, Y {y0:.1f}..{y1:.1f} mm")
