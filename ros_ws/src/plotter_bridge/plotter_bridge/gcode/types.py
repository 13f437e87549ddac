"""Data types of the G-code front end: errors and the items a program becomes.

All coordinates are machine coordinates in millimetres, measured from the
power-on origin (after G92 offsets and inch conversion); feeds are mm/min.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Union

PEN_UP = "up"
PEN_DOWN = "down"


class GCodeError(ValueError):
    """A program is rejected; ``line`` is the 1-based physical line of the file."""

    def __init__(self, line: int, message: str) -> None:
        super().__init__(line, message)
        self.line = line
        self.message = message

    def __str__(self) -> str:
        return f"line {self.line}: {self.message}"


class GCodeErrors(GCodeError):
    """Every refused line of one program, in line order: the whole reason it
    is refused at once.  ``line`` and ``message`` are the first one's, so a
    caller that shows one error shows the first; ``str()`` shows them all,
    one per line of text, each as ``line N: why``."""

    def __init__(self, errors: Sequence[GCodeError], notes: Sequence["Note"] = (), more: int = 0) -> None:
        if not errors:
            raise ValueError("GCodeErrors needs at least one error")
        self.errors: List[GCodeError] = sorted(errors, key=lambda e: e.line)
        self.notes: List[Note] = list(notes)   # what the program says that has no effect, for the listing
        self.more = more                      # refused lines beyond those listed
        super().__init__(self.errors[0].line, self.errors[0].message)

    def __str__(self) -> str:
        tail = [f"... and {self.more} more refused line{'s' if self.more != 1 else ''}"] if self.more else []
        return "\n".join([str(e) for e in self.errors] + tail)


def all_errors(exc: GCodeError) -> List[GCodeError]:
    """The single errors of a GCodeError: itself, or each of a GCodeErrors'."""
    return list(exc.errors) if isinstance(exc, GCodeErrors) else [exc]


@dataclass(frozen=True)
class Move:
    """One straight line or circular arc from (sx, sy) to (x, y).

    ``kind`` is ``"line"`` or ``"arc"``. Arcs have their centre (cx, cy) and
    direction (``cw`` True for G2, False for G3); an arc whose end equals its
    start is a full circle. ``rapid`` moves (G0) always travel with the pen up
    at the rapid rate. ``n`` is the block's N word, if it had one.
    """

    line: int
    kind: str
    sx: float
    sy: float
    x: float
    y: float
    feed: float
    pen: str
    rapid: bool = False
    cx: Optional[float] = None
    cy: Optional[float] = None
    cw: Optional[bool] = None
    n: Optional[int] = None

    @property
    def is_full_circle(self) -> bool:
        return self.kind == "arc" and self.x == self.sx and self.y == self.sy


@dataclass(frozen=True)
class ZMove:
    """The Z axis alone from ``sz`` to ``z`` (mm), when G-code Z is a third
    axis rather than the pen (gcode.parse with ``z_axis``). ``rapid`` moves
    (G0) go at the rapid rate; ``feed`` is the rate in mm/min either way."""

    line: int
    sz: float
    z: float
    feed: float
    rapid: bool = False


@dataclass(frozen=True)
class Dwell:
    """G4: wait ``seconds`` before the next item."""

    line: int
    seconds: float


@dataclass(frozen=True)
class PenChange:
    """The program's pen state changes to ``pen`` ("up" or "down") here.

    Every Move also carries the pen position it is made with, so a consumer
    may ignore these except where no move follows (e.g. a final M5).
    """

    line: int
    pen: str


@dataclass(frozen=True)
class Pause:
    """M0: stop until the operator resumes."""

    line: int


@dataclass(frozen=True)
class ToolChange:
    """M6 after something was drawn: the job stops with the pen up for the
    operator to put in the next pen (tool ``tool``, the T word in force), and
    goes on when told.  ``label`` is the line's comment, which says which pen
    or layer comes next (``plotter svg`` writes ``(layer 2 "red" #ff0000)``).
    An M6 before anything is drawn names the pen already in the holder and
    does not stop (``wait`` False): only a preview uses it."""

    line: int
    tool: int
    label: str = ""
    wait: bool = True


@dataclass(frozen=True)
class Note:
    """A line the dialect accepts without acting on it (M8 coolant, G54 the
    only coordinate system, ...): ``plotter check`` lists these."""

    line: int
    text: str

    def __str__(self) -> str:
        return f"line {self.line}: note: {self.text}"


Item = Union[Move, ZMove, Dwell, PenChange, Pause, ToolChange]
