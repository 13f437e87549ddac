"""Conversion of parsed moves (mm) to integer motor steps for the firmware.

Rounding rules, chosen so that errors never accumulate:

- Every end point is rounded to whole steps once, from its absolute machine
  coordinate (half steps round up). A move's start is the previous move's
  rounded end, so the step displacements of a program always add up to the
  rounded final position, however many small incremental moves it has.
- An arc's end stays that rounded absolute end. Its centre is sent as an
  integer offset (i, j) from the rounded start. The exact centre is moved onto
  the perpendicular bisector of the rounded start and end (so the arc stays a
  circle through both); of the integer points around it, those whose radii to
  start and end differ by less than one step qualify (the firmware tolerates
  an end that is off the circle by less than one step), and the one with the
  smallest largest error is taken, the error being the larger of that radius
  difference and the distance between the middle of the drawn arc and the
  middle of the exact arc. ``radius_error`` reports the remaining difference,
  |end - centre| - |start - centre| in steps.
- An arc of more than 180 degrees is sent as two arcs, split at the middle of
  the exact arc (that point rounded once, like every end point), so that the
  rule above applies to each half. A full circle is one arc with end == start
  and its centre rounded.
- An arc whose ends round to the same step (shorter than a step) becomes a
  zero-length line.
- An arc too large for the board's numbers (a radius, centre offset or
  displacement beyond 32767 steps, firmware/PROTOCOL.md) goes as chords
  whose ends are on the exact arc (rounded once) and which stray from it by at
  most half a step: so flat an arc is a line to the board at a few hundred
  steps of sagitta per chord anyway.

Dwell, PenChange and Pause items pass through unchanged, in order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Iterator, List, Optional, Tuple, Union

from .types import Dwell, Item, Move, Pause, PenChange
from .geometry import TWO_PI, Point, arc_midpoint, arc_sweep


@dataclass(frozen=True)
class StepMove:
    """A move in steps: absolute end (x, y), displacement (dx, dy) from the start."""

    line: int
    kind: str
    x: int
    y: int
    dx: int
    dy: int
    feed: float
    pen: str
    rapid: bool = False
    i: Optional[int] = None
    j: Optional[int] = None
    cw: Optional[bool] = None
    radius_error: float = 0.0


StepItem = Union[StepMove, Dwell, PenChange, Pause]

# The board's range of one command's numbers (link/protocol.py's MAX_DELTA, which this
# layer may not import; tests/test_arcfit.py holds the two equal).
MAX_DELTA = 32767
MAX_OFFSET = MAX_DELTA - 2     # dx, dy, i and j of a board arc, with room for rounding (firmware/PROTOCOL.md)


def round_step(value: float) -> int:
    """Nearest integer, halves rounded up (the same way for every coordinate)."""
    return math.floor(value + 0.5)


def _radius_difference(c: Tuple[int, int], s: Tuple[int, int], e: Tuple[int, int]) -> float:
    return math.hypot(e[0] - c[0], e[1] - c[1]) - math.hypot(s[0] - c[0], s[1] - c[1])


def integer_centre(centre: Point, s: Tuple[int, int], e: Tuple[int, int], cw: bool,
                   exact_mid: Point) -> Tuple[int, int]:
    """Integer centre of an arc of at most 180 degrees between rounded ends s != e.

    ``centre`` and ``exact_mid`` are the exact arc's centre and middle point
    (steps). Candidates are the integer points around the exact centre moved
    onto the perpendicular bisector of s and e. Of those whose radii to s and
    e differ by less than a step, the one with the smallest largest error is
    taken: the error is the larger of that radius difference and the distance
    between the middle of the drawn arc and the exact one.
    """
    mx, my = (s[0] + e[0]) / 2.0, (s[1] + e[1]) / 2.0
    ux, uy = float(e[1] - s[1]), float(s[0] - e[0])  # normal of the chord
    norm = math.hypot(ux, uy)
    ux, uy = ux / norm, uy / norm
    along = (centre[0] - mx) * ux + (centre[1] - my) * uy
    bx, by = math.floor(mx + along * ux), math.floor(my + along * uy)
    candidates = [(bx + a, by + b) for a in range(-1, 3) for b in range(-1, 3)]

    def score(c: Tuple[int, int]) -> Tuple[bool, float, float]:
        diff = abs(_radius_difference(c, s, e))
        if c == s or c == e:
            return (True, math.inf, math.inf)
        shape = math.dist(arc_midpoint(s, e, c, cw), exact_mid)
        return (diff >= 1.0, max(diff, shape), math.dist(c, centre))

    return min(candidates, key=score)


def _piece(move: Move, s: Tuple[int, int], e: Tuple[int, int], centre: Point,
           exact_mid: Point) -> StepMove:
    """One arc of at most 180 degrees between rounded ends s and e."""
    common = dict(line=move.line, x=e[0], y=e[1], dx=e[0] - s[0], dy=e[1] - s[1],
                  feed=move.feed, pen=move.pen, rapid=move.rapid)
    if s == e:
        return StepMove(kind="line", **common)
    c = integer_centre(centre, s, e, bool(move.cw), exact_mid)
    return StepMove(kind="arc", i=c[0] - s[0], j=c[1] - s[1], cw=move.cw,
                    radius_error=_radius_difference(c, s, e), **common)


def _fits_board(move: Move, spm: float) -> bool:
    """Whether the arc's numbers fit the board's arcs: its radius (so every centre offset)
    within MAX_OFFSET steps, and each piece's displacement too."""
    start, end, centre = (move.sx * spm, move.sy * spm), (move.x * spm, move.y * spm), (move.cx * spm, move.cy * spm)
    if math.dist(start, centre) > MAX_OFFSET:
        return False
    if move.is_full_circle:
        return True
    ends = [start, end]
    if arc_sweep(start, end, centre, bool(move.cw)) > math.pi:
        ends.insert(1, arc_midpoint(start, end, centre, bool(move.cw)))
    return all(abs(b[0] - a[0]) <= MAX_OFFSET and abs(b[1] - a[1]) <= MAX_OFFSET
               for a, b in zip(ends, ends[1:]))


def _arc_chords(move: Move, s: Tuple[int, int], spm: float) -> List[StepMove]:
    """An arc as chords (steps) that stray from it by at most half a step."""
    centre = (move.cx * spm, move.cy * spm)
    start = (move.sx * spm, move.sy * spm)
    r = math.dist(start, centre)
    sweep = TWO_PI if move.is_full_circle else arc_sweep(start, (move.x * spm, move.y * spm), centre,
                                                         bool(move.cw))
    # sagitta r (1 - cos(a / 2)) <= 0.5 step, and no chord longer than the board takes in one line
    per_chord = min(2.0 * math.acos(max(-1.0, 1.0 - 0.5 / r)), 2.0 * math.asin(min(1.0, MAX_DELTA / (2 * r))))
    n = max(1, math.ceil(sweep / per_chord))
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    sign = -1.0 if move.cw else 1.0
    out, prev = [], s
    for k in range(1, n + 1):
        if k == n:
            e = (round_step(move.x * spm), round_step(move.y * spm))
        else:
            a = a0 + sign * sweep * k / n
            e = (round_step(centre[0] + r * math.cos(a)), round_step(centre[1] + r * math.sin(a)))
        out.append(StepMove(move.line, "line", e[0], e[1], e[0] - prev[0], e[1] - prev[1],
                            move.feed, move.pen, move.rapid))
        prev = e
    return out


def _convert(move: Move, spm: float) -> List[StepMove]:
    s = (round_step(move.sx * spm), round_step(move.sy * spm))
    e = (round_step(move.x * spm), round_step(move.y * spm))
    if move.kind != "arc":
        return [StepMove(move.line, "line", e[0], e[1], e[0] - s[0], e[1] - s[1],
                         move.feed, move.pen, move.rapid)]
    if not _fits_board(move, spm):
        return _arc_chords(move, s, spm)
    centre = (move.cx * spm, move.cy * spm)
    if move.is_full_circle:
        c = (round_step(centre[0]), round_step(centre[1]))
        return [StepMove(move.line, "arc", e[0], e[1], 0, 0, move.feed, move.pen,
                         move.rapid, i=c[0] - s[0], j=c[1] - s[1], cw=move.cw)]
    cw = bool(move.cw)
    start, end = (move.sx * spm, move.sy * spm), (move.x * spm, move.y * spm)
    middle = arc_midpoint(start, end, centre, cw)
    if arc_sweep(start, end, centre, cw) <= math.pi:
        return [_piece(move, s, e, centre, middle)]
    # Longer arcs go as two halves, split at the exact arc's middle.
    m = (round_step(middle[0]), round_step(middle[1]))
    return [_piece(move, s, m, centre, arc_midpoint(start, middle, centre, cw)),
            _piece(move, m, e, centre, arc_midpoint(middle, end, centre, cw))]


def to_steps(items: Iterable[Item], steps_per_mm: float) -> List[StepItem]:
    """Moves rounded to steps (see the module doc); other items unchanged.

    A move gives one StepMove, except an arc of more than 180 degrees (not a
    full circle), which gives two.
    """
    return list(iter_steps(items, steps_per_mm))


def iter_steps(items: Iterable[Item], steps_per_mm: float) -> Iterator[StepItem]:
    """to_steps one item at a time (a bad steps_per_mm is refused at the call)."""
    if not math.isfinite(steps_per_mm) or steps_per_mm <= 0.0:
        raise ValueError(f"steps per mm must be positive, not {steps_per_mm!r}")
    return _steps(items, steps_per_mm)


def _steps(items: Iterable[Item], steps_per_mm: float) -> Iterator[StepItem]:
    for item in items:
        if isinstance(item, Move):
            yield from _convert(item, steps_per_mm)
        else:
            yield item
