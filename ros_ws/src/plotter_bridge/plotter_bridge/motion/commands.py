"""From step moves (gcode/steps.py) to commands of the firmware protocol.

The firmware's feed is in steps per second, and point-by-point interpolation
moves one axis at a time, so a path of length s mm drawn as n steps needs
n / s * v steps per second for a path speed of v mm/s (a 45-degree line takes
1.41 times more steps per mm than an axis-parallel one).

A third axis (firmware build ZAXIS=1) moves alone with the command `Z dz`;
its moves start and end at rest, like pen changes, since the look-ahead
planner's junctions are corners of the XY path.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, List, Optional, Tuple

from plotter_bridge.gcode.steps import StepMove, round_step
from plotter_bridge.gcode.pens import change_label
from plotter_bridge.gcode.types import Dwell, Pause, PenChange, ToolChange, ZMove
from plotter_bridge.link.protocol import (FIRMWARE_ACCEL, MAX_ARC_RATE, MAX_DELTA, MAX_RATE, MIN_RATE,  # noqa: F401
                                          PEN_CHANGE)


Vec = Tuple[float, float]


@dataclass
class BoardCommand:
    verb: str                      # L, C, A (motion), Z (the Z axis), P (pen), D (dwell), M6 (a pen change)
    args: Tuple[int, ...]          # dx dy [i j] for motion, dz for Z, the value for P and D, M6's number
    line: int                      # G-code line it came from (0: none)
    steps: int = 0                 # steps the board takes for it
    rate: int = 0                  # cruise rate, steps/s (motion)
    exit_rate: int = 0             # rate to leave it at, steps/s (set by the planner)
    dir_in: Optional[Vec] = None   # unit direction of travel where it starts (motion)
    dir_out: Optional[Vec] = None  # ... and where it ends
    note: str = ""                 # M6: the next pen, as the operator is told (gcode/pens.py change_label)

    @property
    def is_motion(self) -> bool:
        """A move of the XY path (what the look-ahead planner chains)."""
        return self.verb in ("L", "C", "A")

    @property
    def text(self) -> str:
        """The command on the wire (PROTOCOL.md), without sequence number and checksum."""
        parts = [self.verb, *map(str, self.args)]
        if self.is_motion or self.verb == "Z":
            parts += [str(self.rate), str(self.exit_rate)]
        return " ".join(parts)


def from_text(text: str, line: int = 0) -> BoardCommand:
    """A board command back from its text (BoardCommand.text), as a job's
    journal keeps it; ValueError for anything else."""
    parts = text.split()
    if not parts or parts[0] not in ("L", "C", "A", "Z", "P", "D", PEN_CHANGE):
        raise ValueError(f"not a board command: {text!r}")
    verb, numbers = parts[0], [int(v) for v in parts[1:]]
    if verb in ("P", "D", PEN_CHANGE):
        return BoardCommand(verb, tuple(numbers), line)
    if verb == "Z":
        return BoardCommand(verb, (numbers[0],), line, abs(numbers[0]), *numbers[1:3])
    if verb == "L":
        dx, dy = numbers[:2]
        return BoardCommand(verb, (dx, dy), line, abs(dx) + abs(dy), *numbers[2:4])
    dx, dy, i, j = numbers[:4]
    return BoardCommand(verb, (dx, dy, i, j), line, arc_steps(i, j, dx, dy, verb == "C")[0], *numbers[4:6])


def _rate(feed_mm_min: float, steps: int, length_mm: float, top: int = MAX_RATE) -> int:
    if steps == 0 or length_mm <= 0:
        return MIN_RATE
    rate = feed_mm_min / 60.0 * steps / length_mm
    return int(min(top, max(MIN_RATE, round(rate))))


def arc_steps(i: int, j: int, dx: int, dy: int, cw: bool) -> tuple:
    """(steps, length in steps) of a point-by-point arc: its steps are the
    total variation of x plus that of y along the circle."""
    x0, y0 = -i, -j
    r = math.hypot(x0, y0)
    a0 = math.atan2(y0, x0)
    a1 = math.atan2(dy - j, dx - i)
    sweep = (a0 - a1) if cw else (a1 - a0)
    sweep %= 2 * math.pi
    if sweep == 0:
        sweep = 2 * math.pi
    sign = -1 if cw else 1
    # Extremes lie at multiples of 90 degrees; add up the monotone pieces.
    total, a, end = 0.0, a0, a0 + sign * sweep
    px, py = math.cos(a), math.sin(a)
    while True:
        k = math.floor(a / (math.pi / 2)) + 1 if sign > 0 else math.ceil(a / (math.pi / 2)) - 1
        nxt = k * math.pi / 2
        done = (nxt >= end) if sign > 0 else (nxt <= end)
        a = end if done else nxt
        qx, qy = math.cos(a), math.sin(a)
        total += abs(qx - px) + abs(qy - py)
        px, py = qx, qy
        if done:
            break
    return round(total * r), r * sweep


def _unit(x: float, y: float) -> Vec:
    r = math.hypot(x, y)
    return (x / r, y / r) if r else (0.0, 0.0)


def _tangent(x: float, y: float, cw: bool) -> Vec:
    """Direction of travel on a circle at (x, y) from its centre."""
    return _unit(y, -x) if cw else _unit(-y, x)


def _split_line(dx: int, dy: int) -> List[tuple]:
    pieces = max(1, math.ceil(max(abs(dx), abs(dy)) / MAX_DELTA))
    out, px, py = [], 0, 0
    for k in range(1, pieces + 1):
        x, y = round(dx * k / pieces), round(dy * k / pieces)
        out.append((x - px, y - py))
        px, py = x, y
    return out


MotionConverter = Callable[[object, float], List["BoardCommand"]]


def cartesian_motion(steps_per_mm: float) -> MotionConverter:
    """Board commands for one StepMove of a cartesian machine: lines (split
    beyond the board's 16-bit range) and native arcs."""
    def convert(item: StepMove, feed: float) -> List[BoardCommand]:
        if item.kind == "arc":
            n, length = arc_steps(item.i, item.j, item.dx, item.dy, item.cw)
            rate = _rate(feed, n, length / steps_per_mm, MAX_ARC_RATE)     # as the board would cap it
            return [BoardCommand("C" if item.cw else "A", (item.dx, item.dy, item.i, item.j),
                                 item.line, n, rate,
                                 dir_in=_tangent(-item.i, -item.j, item.cw),
                                 dir_out=_tangent(item.dx - item.i, item.dy - item.j, item.cw))]
        out = []
        if item.dx == 0 and item.dy == 0:
            return out
        for dx, dy in _split_line(item.dx, item.dy):
            out.append(straight(dx, dy, item.line, feed, math.hypot(dx, dy) / steps_per_mm))
        return out
    return convert


def straight(dx: int, dy: int, line: int, feed_mm_min: float, length_mm: float) -> BoardCommand:
    """A board line of (dx, dy) steps that should take length_mm / feed to draw."""
    n = abs(dx) + abs(dy)
    u = _unit(dx, dy)
    return BoardCommand("L", (dx, dy), line, n, _rate(feed_mm_min, n, length_mm), dir_in=u, dir_out=u)


def z_axis_motion(z_steps_per_mm: float) -> MotionConverter:
    """Board commands for one ZMove: `Z dz` from the start rounded to steps
    to the end rounded to steps, both absolute so that errors never add up;
    split beyond the board's 16-bit range."""
    def convert(item: ZMove, feed: float) -> List[BoardCommand]:
        dz = round_step(item.z * z_steps_per_mm) - round_step(item.sz * z_steps_per_mm)
        pieces = math.ceil(abs(dz) / MAX_DELTA)      # none for a move under half a step
        out, done = [], 0
        for k in range(1, pieces + 1):
            to = round(dz * k / pieces)
            step, done = to - done, to
            out.append(BoardCommand("Z", (step,), item.line, abs(step),
                                    _rate(feed, abs(step), abs(step) / z_steps_per_mm)))
        return out
    return convert


def to_commands(items: Iterable[object], motion: MotionConverter,
                rapid_feed: float = 6000.0,
                z_motion: Optional[MotionConverter] = None) -> List[BoardCommand]:
    """Board commands for a program's items; `motion` turns each move into
    board motion for the machine, `z_motion` each ZMove; pen changes only
    when needed."""
    return list(iter_commands(items, motion, rapid_feed, z_motion))


def iter_commands(items: Iterable[object], motion: MotionConverter, rapid_feed: float = 6000.0,
                  z_motion: Optional[MotionConverter] = None) -> Iterator[BoardCommand]:
    """to_commands one item at a time."""
    pen: Optional[str] = None
    changes = 0

    def set_pen(want: str, line: int) -> Iterator[BoardCommand]:
        nonlocal pen
        if want != pen:
            pen = want
            yield BoardCommand("P", (1 if want == "down" else 0,), line)

    for item in items:
        if isinstance(item, PenChange):
            yield from set_pen(item.pen, item.line)
        elif isinstance(item, Dwell):
            ms = int(round(item.seconds * 1000))
            while ms > 0:
                yield BoardCommand("D", (min(ms, 65535),), item.line)
                ms -= 65535
        elif isinstance(item, Pause):
            # M0: the board has no operator pause; the pen comes to rest here.
            yield BoardCommand("D", (1,), item.line)
        elif isinstance(item, ToolChange):
            if not item.wait:
                continue              # the pen in the holder: nothing to do
            # the bridge holds the job here (link/board_session.py): the pen must be up first
            yield from set_pen("up", item.line)
            yield BoardCommand(PEN_CHANGE, (changes,), item.line, note=change_label(item))
            changes += 1
        elif isinstance(item, ZMove):
            if z_motion is None:
                raise ValueError(f"line {item.line}: a Z move for a machine without a Z axis")
            yield from z_motion(item, rapid_feed if item.rapid else item.feed)
        else:
            yield from set_pen("up" if item.rapid else item.pen, item.line)
            yield from motion(item, rapid_feed if item.rapid else item.feed)
