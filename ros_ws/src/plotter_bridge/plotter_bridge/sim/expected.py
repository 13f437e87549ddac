"""What the board should draw: the steps the firmware core takes for a
program, and a drawn step trace held against them.

The firmware's own C core (firmware_core.py) steps the board commands here,
so the expected positions are the board's to the step; a mock board's trace
(trace.py) of the same commands must match them exactly, times aside.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, List, Optional, Sequence, Tuple

from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from .firmware_core import FirmwareCore, find_library

Point = Tuple[int, int]


def step_positions(commands: Iterable[str], start: Point = (0, 0), library: Optional[Path] = None,
                   limit: Optional[int] = None) -> List[Point]:
    """The position after every step the firmware core takes for these board
    command lines (BoardCommand.text), the pen starting at `start` (steps);
    with `limit`, the first that many.  The core's own main loop takes them
    as its queue frees, as on the board."""
    core = FirmwareCore(library or find_library())
    try:
        # The core starts at 0 after its reset; its moves are relative.
        x0, y0 = start[0] - core.position[0], start[1] - core.position[1]
        positions: List[Point] = []
        last = core.position
        for _ in core.interrupts(commands):
            here = core.position
            if here != last:
                positions.append((here[0] + x0, here[1] + y0))
                last = here
                if limit is not None and len(positions) >= limit:
                    break
        return positions
    finally:
        core.close()


def program_steps(text: str, config: StreamerConfig, start: Point = (0, 0),
                  library: Optional[Path] = None, limit: Optional[int] = None) -> List[Point]:
    """Every step position of a G-code program compiled as gcode_streamer
    compiles it for a pen at `start` (steps): a cartesian machine's, whose
    motor steps are the pen's.  Raises GCodeError for a program it refuses."""
    commands = compile_program(text, config, start)
    return step_positions((c.text for c in commands), start, library, limit)


def mm(value: int, steps_per_mm: float) -> str:
    """Steps as millimetres with one decimal, more only when they matter."""
    text = f"{value / steps_per_mm:.4f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def where(point: Point, steps_per_mm: float) -> str:
    return f"X {mm(point[0], steps_per_mm)} Y {mm(point[1], steps_per_mm)} mm"


def first_difference(drawn: Sequence[Point], expected: Sequence[Point]) -> int:
    """Index of the first step where the two differ; the shorter length when
    one is the start of the other."""
    for k, (a, b) in enumerate(zip(drawn, expected)):
        if a != b:
            return k
    return min(len(drawn), len(expected))


def drawn_whole(drawn: Sequence[Point], expected: Sequence[Point], start: Point, steps_per_mm: float) -> str:
    """'' when the board's step positions are exactly the expected ones, else
    how they differ, in words: where it left the path, stopped short or went
    on.  `start`: where the pen was before the first step."""
    n, total = len(drawn), len(expected)
    k = first_difference(drawn, expected)
    if k < min(n, total):
        return (f"the board left the path at step {k + 1} of {total}: it stepped to "
                f"{where(drawn[k], steps_per_mm)} where the program goes to {where(expected[k], steps_per_mm)}")
    end = expected[-1] if expected else start
    if n < total:
        stop = drawn[-1] if drawn else start
        return (f"the board stepped {n} of {total} steps, it stopped at {where(stop, steps_per_mm)} "
                f"(expected to end at {where(end, steps_per_mm)})")
    if n > total:
        return (f"the board stepped {n} steps, {n - total} more than the {total} programmed, and stopped at "
                f"{where(drawn[-1], steps_per_mm)} (expected to end at {where(end, steps_per_mm)})")
    return ""
