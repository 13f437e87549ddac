"""How long the board takes for each planned command and how far the pen
goes with it: a job's progress as a share of the drawing's length, and the
time left, from the plan rather than from program lines (a program of one
long line and one hundred short ones is not half done after the long one).

The board ramps at its table's acceleration (FIRMWARE_ACCEL steps/s^2 at
`$0=1`) between the rates the planner gave each command: entry (the exit of
the command before, 0 after a pen change, a dwell or a Z move), cruise and
exit.  Pen changes wait the pen delay (`$3`), dwells their time.
"""
from __future__ import annotations

import itertools
import math
import threading
from array import array
from typing import Callable, Iterable, Iterator, List, Tuple

from plotter_bridge.link.protocol import FIRMWARE_ACCEL

from .commands import BoardCommand, arc_steps, from_text

PEN_DELAY_S = 0.150       # the firmware's default pen settle delay ($3)

PenMm = Callable[[Tuple[float, float]], Tuple[float, float]]     # motor steps -> pen mm


def trapezoid_seconds(steps: float, entry: float, cruise: float, exit_: float,
                      acceleration: float = FIRMWARE_ACCEL) -> float:
    """Time to take `steps` steps starting at `entry` steps/s, cruising at
    `cruise` and leaving at `exit_`, ramping at `acceleration`."""
    if steps <= 0 or cruise <= 0:
        return 0.0
    v0, v1 = min(entry, cruise), min(exit_, cruise)
    a2 = 2.0 * acceleration
    up, down = (cruise ** 2 - v0 ** 2) / a2, (cruise ** 2 - v1 ** 2) / a2
    if up + down <= steps:
        return (cruise - v0) / acceleration + (cruise - v1) / acceleration + (steps - up - down) / cruise
    peak = max(v0, v1, math.sqrt((a2 * steps + v0 ** 2 + v1 ** 2) / 2.0))   # no room to cruise
    return (peak - v0) / acceleration + (peak - v1) / acceleration


def command_seconds(commands: Iterable[BoardCommand], acceleration: float = FIRMWARE_ACCEL,
                    pen_delay: float = PEN_DELAY_S) -> List[float]:
    """Seconds the board spends on each command."""
    return list(iter_command_seconds(commands, acceleration, pen_delay))


def iter_command_seconds(commands: Iterable[BoardCommand], acceleration: float = FIRMWARE_ACCEL,
                         pen_delay: float = PEN_DELAY_S) -> Iterator[float]:
    entry = 0.0
    for c in commands:
        if c.is_motion:
            yield trapezoid_seconds(c.steps, entry, c.rate, c.exit_rate, acceleration)
            entry = c.exit_rate
            continue
        if c.verb == "Z":
            yield trapezoid_seconds(c.steps, 0.0, c.rate, c.exit_rate, acceleration)
        elif c.verb == "P":
            yield pen_delay
        elif c.verb == "D":
            yield c.args[0] / 1000.0
        else:
            yield 0.0
        entry = 0.0


def pen_lengths(commands: Iterable[BoardCommand], start: Tuple[int, int], pen_mm: PenMm,
                steps_per_mm: float) -> List[float]:
    """Millimetres the pen travels with each command (pen up or down), from
    the motor position `start`: lines between their ends as the machine puts
    the pen there (a hanging machine's chords are short), arcs along the
    circle."""
    return list(iter_pen_lengths(commands, start, pen_mm, steps_per_mm))


def iter_pen_lengths(commands: Iterable[BoardCommand], start: Tuple[int, int], pen_mm: PenMm,
                     steps_per_mm: float) -> Iterator[float]:
    x, y = start
    for c in commands:
        if not c.is_motion:
            yield 0.0
            continue
        dx, dy = c.args[0], c.args[1]
        if c.verb == "L":
            (ax, ay), (bx, by) = pen_mm((x, y)), pen_mm((x + dx, y + dy))
            yield math.hypot(bx - ax, by - ay)
        else:
            yield arc_steps(c.args[2], c.args[3], dx, dy, c.verb == "C")[1] / steps_per_mm
        x, y = x + dx, y + dy


class JobProgress:
    """A running job's share of the drawing done and time left, from the
    commands the board has started (the bridge's feedback)."""

    def __init__(self, lengths: Iterable[float], seconds: Iterable[float]) -> None:
        # Only the sums up to each command, as plain doubles: an update costs the same for any job
        # size, and a command's own figures are the difference of two (16 bytes a command in all).
        self._length_before = array("d", [0.0])
        self._length_before.extend(itertools.accumulate(lengths))
        self._seconds_before = array("d", [0.0])
        self._seconds_before.extend(itertools.accumulate(seconds))
        self._running = -1                  # the command the board works on (-1: none yet)
        self._started_at = 0.0              # when it was first seen running

    def __len__(self) -> int:
        return len(self._length_before) - 1

    @classmethod
    def of_commands(cls, texts: Iterable[str], start: Tuple[int, int], pen_mm: PenMm,
                    steps_per_mm: float) -> "JobProgress":
        """The progress model of a job's commands as sent (BoardCommand.text), read once, a command at
        a time."""
        for_lengths, for_seconds = itertools.tee(from_text(t) for t in texts)
        lengths, seconds = array("d"), array("d")
        for length, second in zip(iter_pen_lengths(for_lengths, start, pen_mm, steps_per_mm),
                                  iter_command_seconds(for_seconds)):
            lengths.append(length)
            seconds.append(second)
        return cls(lengths, seconds)

    @property
    def total_length(self) -> float:
        return self._length_before[-1]

    @property
    def total_seconds(self) -> float:
        return self._seconds_before[-1]

    def update(self, started: int, now: float) -> Tuple[float, float]:
        """(fraction of the length done, seconds left) with `started`
        commands begun, the last of them running, at time `now`."""
        n = len(self)
        if n == 0:
            return 1.0, 0.0
        running = min(started, n) - 1
        if running != self._running:
            self._running, self._started_at = running, now
        if running < 0:
            return 0.0, self.total_seconds
        done = self._length_before[running]
        left = self.total_seconds - self._seconds_before[running]
        # Within the running command, as far as its planned time says.
        seconds = self._seconds_before[running + 1] - self._seconds_before[running]
        spent = min(max(now - self._started_at, 0.0), seconds)
        if seconds > 0:
            done += spent / seconds * (self._length_before[running + 1] - self._length_before[running])
        left -= spent
        fraction = done / self.total_length if self.total_length > 0 else running / n
        return min(max(fraction, 0.0), 1.0), max(left, 0.0)


class JobPosition:
    """The pen's position (mm) a job reports: each feedback's while it runs,
    then its result's for good.  Feedback and the result come by different
    ways, and on a multi-threaded executor a feedback message sent before the
    result can be handled after it, so a feedback after the result is dropped."""

    def __init__(self, start: Tuple[float, float] = (0.0, 0.0)) -> None:
        self._lock = threading.Lock()
        self._xy = start
        self._ended = False

    def feedback(self, xy: Tuple[float, float]) -> None:
        with self._lock:
            if not self._ended:
                self._xy = xy

    def result(self, xy: Tuple[float, float]) -> None:
        with self._lock:
            self._xy = xy
            self._ended = True

    @property
    def xy(self) -> Tuple[float, float]:
        with self._lock:
            return self._xy
