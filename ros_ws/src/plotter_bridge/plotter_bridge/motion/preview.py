"""A job's plan before paper: the pen-down paths of each pen (layer), the
pen-up travel, their lengths, and how long the board will take.

The geometry is the compiled job's own (motion/compiler.py compile_stream: the
park travel at pen changes added, chords fitted to arcs), and the time is
the planner's (motion/timing.py command_seconds on the same commands): the
figure the job's progress then counts down.  A pen change waits for the
operator, which no plan can time: the time is the board's, without it.

The job is read as a stream and its paths are kept within a budget of points
(gcode/thinning.py): a million-segment drawing gives a picture of the same size as a
hundred-thousand-segment one.  The lengths and the time are the whole job's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Tuple, Union

from plotter_bridge.gcode.pens import change_label, label_colour
from plotter_bridge.gcode.polylines import Polyline, arc_points
from plotter_bridge.gcode.thinning import Thinning
from plotter_bridge.gcode.types import Item, Move, ToolChange

from .compiler import StreamerConfig, compile_stream
from .timing import iter_command_seconds

MAX_PREVIEW_POINTS = 100000    # points of a preview's paths at most, pen-down and travel together
PALETTE = ("#1f1f1f", "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2")


@dataclass
class PenLayer:
    """What one pen draws: its name, its colour (#rrggbb), its paths (mm) and their length."""
    name: str
    colour: str
    lines: List[Polyline] = field(default_factory=list)
    length_mm: float = 0.0


@dataclass
class Preview:
    layers: List[PenLayer]
    travel: List[Polyline]
    travel_mm: float
    seconds: float                  # the board's time, pen changes not counted
    commands: int
    tolerance_mm: float = 0.0       # how far a drawn path may be from the job's (gcode/thinning.py); 0: exact

    @property
    def drawn_mm(self) -> float:
        return sum(layer.length_mm for layer in self.layers)

    @property
    def changes(self) -> int:
        return max(0, len(self.layers) - 1)

    def summary(self) -> str:
        pens = (f" with {len(self.layers)} pens ({self.changes} pen change{'s' if self.changes != 1 else ''}, "
                f"not timed)" if self.changes else "")
        thinned = f"; drawn here to within {self.tolerance_mm:.2g} mm" if self.tolerance_mm else ""
        return (f"drawn {self.drawn_mm:.1f} mm{pens}, pen-up travel {self.travel_mm:.1f} mm, "
                f"{duration(self.seconds)} on the board ({self.commands} commands){thinned}")

    def as_json(self) -> dict:
        def pts(line: Polyline) -> list:
            return [[round(x, 3), round(y, 3)] for x, y in line]
        return {"layers": [{"name": layer.name, "colour": layer.colour, "length_mm": round(layer.length_mm, 2),
                            "lines": [pts(line) for line in layer.lines]} for layer in self.layers],
                "travel": [pts(line) for line in self.travel], "travel_mm": round(self.travel_mm, 2),
                "drawn_mm": round(self.drawn_mm, 2), "seconds": round(self.seconds, 2),
                "changes": self.changes, "tolerance_mm": round(self.tolerance_mm, 3), "summary": self.summary()}


def duration(seconds: float) -> str:
    """A time as people say it: 42 s, 3 min 05 s, 1 h 02 min."""
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def _path(m: Move) -> Polyline:
    if m.kind == "arc":
        return arc_points(m.sx, m.sy, m.x, m.y, m.cx, m.cy, bool(m.cw))
    return [(m.sx, m.sy), (m.x, m.y)]


def _length(line: Polyline) -> float:
    return sum(math.dist(a, b) for a, b in zip(line, line[1:]))


def _layer(change: ToolChange, k: int, thinning: "Thinning") -> PenLayer:
    label = change_label(change)
    colour = label_colour(label)
    # 'layer 2 "red" #ff0000': the name is what comes before the colour written last
    name = label[:-len(colour)].strip() if colour and label.lower().endswith(colour) else label
    return PenLayer(name or f"pen {k + 1}", colour or PALETTE[k % len(PALETTE)], thinning.group())


class PreviewBuilder:
    """A Preview built from a job's items and commands as they are compiled."""

    def __init__(self, budget: int = MAX_PREVIEW_POINTS) -> None:
        self.thinning = Thinning(budget)
        self.layers: List[PenLayer] = []
        self.travel = self.thinning.group()
        self.travel_mm = 0.0
        self.seconds = 0.0
        self.commands = 0
        self._drawing = False          # the last move drew: the next drawn one may join its path

    def add_item(self, item: Item) -> None:
        if isinstance(item, ToolChange):
            if item.wait or not any(layer.lines for layer in self.layers):
                self.layers = [layer for layer in self.layers if layer.lines]
                self.layers.append(_layer(item, len(self.layers), self.thinning))
            self._drawing = False
            return
        if not isinstance(item, Move):
            return
        path = _path(item)
        if item.rapid or item.pen != "down":
            self.thinning.add(self.travel, path, join=not self._drawing)
            self.travel_mm += _length(path)
            self._drawing = False
            return
        if not self.layers:
            self.layers.append(PenLayer("pen 1", PALETTE[0], self.thinning.group()))
        layer = self.layers[-1]
        self.thinning.add(layer.lines, path, join=self._drawing)
        layer.length_mm += _length(path)
        self._drawing = True

    def add_seconds(self, seconds: float) -> None:
        self.seconds += seconds
        self.commands += 1

    def preview(self) -> Preview:
        layers = [layer for layer in self.layers if layer.lines] or [PenLayer("pen 1", PALETTE[0])]
        return Preview(layers, self.travel, self.travel_mm, self.seconds, self.commands,
                       self.thinning.tolerance)


def preview_program(text: Union[str, bytes], config: StreamerConfig = StreamerConfig(),
                    start_steps: Tuple[int, int] = (0, 0), budget: int = MAX_PREVIEW_POINTS) -> Preview:
    """The preview of a G-code program for a pen now at start_steps, read as a stream: what it holds
    does not grow with the program (gcode/thinning.py).  GCodeError as compile_program."""
    builder = PreviewBuilder(budget)
    for seconds in iter_command_seconds(compile_stream(text, config, start_steps, observe=builder.add_item)):
        builder.add_seconds(seconds)
    return builder.preview()
