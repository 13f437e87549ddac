"""Arc geometry for the G-code front end (pure functions on floats, mm).

The acceptance rules for arcs follow LinuxCNC's interpreter:

- centre format (I/J): the arc is rejected when the radius at the start or at
  the end is below the zero-radius tolerance (0.0002 inch / 0.002 mm), or when
  the radii at start and end differ by more than 100 times the absolute
  threshold, or by more than the absolute threshold AND more than 0.1 % of the
  larger radius. The absolute threshold is 2 * 0.001 inch * sqrt(2) for inch
  programs and 2 * 0.01 mm * sqrt(2) for metric ones.
- radius format (R): the arc is rejected when half the chord exceeds |R| by
  more than the tolerance (0.0002 inch / 0.002 mm); a chord just longer than
  the diameter within that tolerance is taken as a half circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Tuple

MM_PER_INCH = 25.4
TWO_PI = 2.0 * math.pi

Point = Tuple[float, float]


class ArcError(ValueError):
    """An arc is geometrically invalid; the message says why."""


@dataclass(frozen=True)
class ArcTolerance:
    """Tolerances in mm for the unit system a program is in."""

    zero_radius: float
    spiral_abs: float
    spiral_rel: float = 0.001


def arc_tolerance(inches: bool) -> ArcTolerance:
    """LinuxCNC's tolerances, for an inch (G20) or a metric (G21) program."""
    if inches:
        return ArcTolerance(zero_radius=0.0002 * MM_PER_INCH,
                            spiral_abs=2.0 * 0.001 * math.sqrt(2.0) * MM_PER_INCH)
    return ArcTolerance(zero_radius=0.002, spiral_abs=2.0 * 0.01 * math.sqrt(2.0))


def check_centre_arc(start: Point, end: Point, centre: Point, tol: ArcTolerance) -> None:
    """Raise ArcError when a centre-format arc has a zero or inconsistent radius."""
    r1 = math.hypot(start[0] - centre[0], start[1] - centre[1])
    r2 = math.hypot(end[0] - centre[0], end[1] - centre[1])
    if r1 < tol.zero_radius or r2 < tol.zero_radius:
        raise ArcError(f"zero-radius arc (radius {r1:.4f} mm at the start, "
                       f"{r2:.4f} mm at the end)")
    abs_err = abs(r1 - r2)
    rel_err = abs_err / max(r1, r2)
    if abs_err > 100.0 * tol.spiral_abs or (abs_err > tol.spiral_abs
                                            and rel_err > tol.spiral_rel):
        raise ArcError(
            f"radius to end of arc differs from radius to start: "
            f"start radius {r1:.4f} mm, end radius {r2:.4f} mm "
            f"(difference {abs_err:.4f} mm, {100.0 * rel_err:.4f} %)")


def centre_from_radius(start: Point, end: Point, radius: float, cw: bool,
                       reach_tolerance: float) -> Point:
    """Centre of the R-format arc from start to end.

    A positive radius gives the arc of at most 180 degrees, a negative one the
    arc of more than 180 degrees (as LinuxCNC and Fanuc). The centre lies to the
    right of the chord for a short clockwise or a long counter-clockwise arc.
    """
    dx, dy = end[0] - start[0], end[1] - start[1]
    chord = math.hypot(dx, dy)
    if chord == 0.0:
        raise ArcError("R-format arc ends where it starts (use I/J for a full circle)")
    half = chord / 2.0
    r = abs(radius)
    if half - r > reach_tolerance:
        raise ArcError(f"arc radius too small to reach the end point "
                       f"(|R| = {r:.4f} mm, half the chord = {half:.4f} mm)")
    if r < reach_tolerance:
        raise ArcError(f"zero-radius arc (|R| = {r:.4f} mm)")
    offset = math.sqrt(max(r * r - half * half, 0.0))
    right = cw == (radius > 0.0)
    nx, ny = (dy / chord, -dx / chord) if right else (-dy / chord, dx / chord)
    return (start[0] + dx / 2.0 + offset * nx, start[1] + dy / 2.0 + offset * ny)


def arc_sweep(start: Point, end: Point, centre: Point, cw: bool) -> float:
    """Angle swept (radians, in (0, 2*pi]) going from start to end; equal points: 2*pi."""
    if start == end:
        return TWO_PI
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    return ((a0 - a1) if cw else (a1 - a0)) % TWO_PI


def arc_length(start: Point, end: Point, centre: Point, cw: bool) -> float:
    r = max(math.hypot(start[0] - centre[0], start[1] - centre[1]),
            math.hypot(end[0] - centre[0], end[1] - centre[1]))
    return r * arc_sweep(start, end, centre, cw)


def arc_midpoint(start: Point, end: Point, centre: Point, cw: bool) -> Point:
    """The point halfway along the arc (on the circle through the start)."""
    sweep = arc_sweep(start, end, centre, cw)
    a = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a += -sweep / 2.0 if cw else sweep / 2.0
    r = math.hypot(start[0] - centre[0], start[1] - centre[1])
    return (centre[0] + r * math.cos(a), centre[1] + r * math.sin(a))


def arc_extreme_points(start: Point, end: Point, centre: Point, cw: bool) -> List[Point]:
    """The end point and the points where the arc crosses the axis directions.

    Together with the start point these bound the arc: an arc only reaches
    beyond its end points at the quadrant boundaries (0, 90, 180, 270 degrees)
    it passes. The larger of the start and end radii is used.
    """
    r = max(math.hypot(start[0] - centre[0], start[1] - centre[1]),
            math.hypot(end[0] - centre[0], end[1] - centre[1]))
    sweep = arc_sweep(start, end, centre, cw)
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    points = [end]
    for k, (ux, uy) in enumerate(((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))):
        phi = k * math.pi / 2.0
        travel = ((a0 - phi) if cw else (phi - a0)) % TWO_PI
        if travel <= sweep:
            points.append((centre[0] + r * ux, centre[1] + r * uy))
    return points
