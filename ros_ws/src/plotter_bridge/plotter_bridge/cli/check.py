"""``plotter check FILE``: validates a G-code program without moving anything
and prints the moves it would make, like grbl's check mode (``--z-axis``:
G-code Z as a third axis, see gcode/parser.py; ``--dialect``: see
gcode/dialect.py).  Lines the dialect accepts without acting on them are
listed on stderr as notes, ``FILE:line N: note: ...``, and a refused program
has every refused line listed there, ``FILE:line N: why``, in one run; with
``--json`` each note and refusal is also a record on stdout, in line order
with the moves.  No ROS.
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
from dataclasses import dataclass
from typing import Dict, Iterable, Iterator, List, Sequence, TextIO

from plotter_bridge.gcode.dialect import (DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP, DEFAULT_PEN_UP_Z,
                                          DIALECTS, LINUXCNC, GCodeOptions)
from plotter_bridge.gcode.geometry import arc_length
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.parser import DEFAULT_RAPID_RATE, GCodeError, Item, Move, Reading, decode_program, read_items
from plotter_bridge.gcode.limits import within_limits
from plotter_bridge.gcode.steps import round_step, to_steps
from plotter_bridge.gcode.pens import change_label
from plotter_bridge.gcode.types import GCodeErrors, Dwell, Note, Pause, PenChange, ToolChange, ZMove, all_errors
from plotter_bridge.motion.kinematics import DEFAULT_Z_STEPS_PER_MM

from .command import EXIT_BAD_PROGRAM, EXIT_OK, Command

SPOOL_BYTES = 8 * 1024 * 1024     # of the table held in memory; the rest waits in a temporary file


def dialect_args(p: argparse.ArgumentParser) -> None:
    """The options that say how a program is read: its dialect and pen rules."""
    p.add_argument("--dialect", choices=tuple(DIALECTS), default=None,
                   help="G-code dialect (default linuxcnc; for a running plotter, its streamer's): grbl takes "
                        "M3 S<power> for the pen, "
                        "marlin M300 S<angle> and G4 P in milliseconds")
    p.add_argument("--pen-up-z", type=float, default=DEFAULT_PEN_UP_Z, metavar="MM",
                   help=f"Z above this lifts the pen, at or below lowers it (default {DEFAULT_PEN_UP_Z:g})")
    p.add_argument("--marlin-pen", type=float, nargs=2, default=(DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP),
                   metavar=("DOWN", "UP"),
                   help=f"with --dialect marlin: the M300 S angles that lower and lift the pen "
                        f"(default {DEFAULT_MARLIN_PEN_DOWN:g} {DEFAULT_MARLIN_PEN_UP:g})")


def gcode_options(args: argparse.Namespace) -> GCodeOptions:
    """GCodeOptions from dialect_args' options; ValueError for bad ones."""
    down, up = getattr(args, "marlin_pen", (DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP))
    return GCodeOptions(getattr(args, "dialect", None) or LINUXCNC, getattr(args, "pen_up_z", DEFAULT_PEN_UP_Z),
                        down, up)


def _configure_check(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.gcode", help="G-code program to check")
    p.add_argument("--json", action="store_true",
                   help="one JSON object per move and line (machine mm)")
    p.add_argument("--steps-per-mm", type=float, default=80.0, metavar="N",
                   help="motor steps per mm, for the step counts (default 80)")
    p.add_argument("--rapid-rate", type=float, default=DEFAULT_RAPID_RATE,
                   metavar="MM_PER_MIN",
                   help=f"feed of G0 moves (default {DEFAULT_RAPID_RATE:g} mm/min)")
    p.add_argument("--z-axis", action="store_true",
                   help="G-code Z moves a third axis (firmware ZAXIS=1), not the pen")
    p.add_argument("--z-steps-per-mm", type=float, default=DEFAULT_Z_STEPS_PER_MM, metavar="N",
                   help=f"with --z-axis: steps per mm of Z (default {DEFAULT_Z_STEPS_PER_MM:g})")
    defaults = WorkArea()
    for name in ("x_min", "x_max", "y_min", "y_max", "z_min", "z_max"):
        p.add_argument("--" + name.replace("_", "-"), type=float,
                       default=getattr(defaults, name), metavar="MM",
                       help=f"work area limit (default {getattr(defaults, name):g})")
    p.add_argument("--area", type=float, nargs=4, metavar=("X_MIN", "X_MAX", "Y_MIN", "Y_MAX"),
                   help="work area in mm, as plotter stream takes it (instead of --x-min ... --y-max)")
    p.add_argument("--no-limits", action="store_true",
                   help="do not check the moves against the work area")
    p.add_argument("--fit-arcs", type=float, metavar="MM", default=None,
                   help="show the moves as the streamer sends them: each run of drawn chords that one arc or line "
                        "holds within MM as that arc or line (gcode/arcfit.py; the streamer fits within 0.02 mm "
                        "unless its fit_arcs is off)")
    p.add_argument("--svg", metavar="OUT.svg", default="",
                   help="write a preview of the plan: each pen's paths in its colour, the pen-up travel dashed, "
                        "the lengths and the board's time (for the default board, 9600 baud) in the title")
    p.add_argument("--png", metavar="OUT.png", default="", help="the same preview as PNG")
    p.add_argument("--park", type=float, nargs=2, metavar=("X", "Y"), default=(0.0, 0.0),
                   help="where the pen waits at a pen change, for the preview (default 0 0, as the streamer's)")
    dialect_args(p)


def _number(value: float) -> float:
    value = round(value, 6)
    return 0.0 if value == 0.0 else value


def move_record(move: Move) -> dict:
    """The JSON object of one move (see ``plotter check --json``)."""
    record = {"line": move.line, "type": move.kind, "x": _number(move.x),
              "y": _number(move.y)}
    if move.kind == "arc":
        record.update(cx=_number(move.cx), cy=_number(move.cy), cw=bool(move.cw))
    record.update(feed=_number(move.feed), pen=move.pen)
    return record


def z_record(move: ZMove) -> dict:
    """The JSON object of one Z move (``plotter check --z-axis --json``)."""
    return {"line": move.line, "type": "z", "z": _number(move.z), "feed": _number(move.feed),
            "rapid": move.rapid}


def _message_record(entry) -> dict:
    """The JSON object of a note or a refusal (``plotter check --json``)."""
    if isinstance(entry, Note):
        return {"line": entry.line, "type": "note", "message": entry.text}
    return {"line": entry.line, "type": "error", "message": entry.message}


def _length(move: Move) -> float:
    if move.kind == "arc":
        return arc_length((move.sx, move.sy), (move.x, move.y), (move.cx, move.cy),
                          bool(move.cw))
    return math.hypot(move.x - move.sx, move.y - move.sy)


TABLE_HEADER = (f"{'line':>5} {'N':>5}  {'move':<10} {'pen':<4} {'feed':>8} "
                f"{'X':>10} {'Y':>10} {'centre X':>10} {'centre Y':>10}  steps\n")


def _table_row(item: Item, steps_per_mm: float, z_steps_per_mm: float = 1.0) -> str:
    """One item's row of the table (TABLE_HEADER), or "" for an item it does not show."""
    if isinstance(item, Move):
        kind = "rapid" if item.rapid else item.kind
        if item.kind == "arc":
            kind = ("circle " if item.is_full_circle else "arc ") + \
                   ("cw" if item.cw else "ccw")
        centre = (f"{item.cx:10.4f} {item.cy:10.4f}" if item.kind == "arc"
                  else " " * 21)
        # an arc of more than 180 degrees is sent as two pieces
        pieces = []
        for step in to_steps([item], steps_per_mm):
            text = f"{step.x},{step.y}"
            if step.kind == "arc":
                text += f" c{step.i:+d},{step.j:+d}"
            pieces.append(text)
        n = "" if item.n is None else str(item.n)
        return (f"{item.line:>5} {n:>5}  {kind:<10} {item.pen:<4} "
                f"{item.feed:8.1f} {item.x:10.4f} {item.y:10.4f} {centre}  "
                f"{' | '.join(pieces)}\n")
    if isinstance(item, ZMove):
        kind = "rapid z" if item.rapid else "z"
        return (f"{item.line:>5} {'':>5}  {kind:<10} {'':<4} {item.feed:8.1f} "
                f"{'Z ' + format(item.z, '.4f'):>21} {'':21}  z{round_step(item.z * z_steps_per_mm)}\n")
    if isinstance(item, Dwell):
        return f"{item.line:>5} {'':>5}  dwell {item.seconds:g} s\n"
    if isinstance(item, PenChange):
        return f"{item.line:>5} {'':>5}  pen {item.pen}\n"
    if isinstance(item, Pause):
        return f"{item.line:>5} {'':>5}  pause (M0/M1)\n"
    if isinstance(item, ToolChange) and item.wait:
        return f"{item.line:>5} {'':>5}  pen change (M6): {change_label(item)}\n"
    return ""


@dataclass
class Summary:
    """The check's last line, added up an item at a time."""
    moves: int = 0
    rapids: int = 0
    arcs: int = 0
    z_moves: int = 0
    changes: int = 0
    drawn: float = 0.0
    travel: float = 0.0
    move_minutes: float = 0.0
    z_minutes: float = 0.0
    dwell: float = 0.0
    x_min: float = 0.0          # the end points, and the origin
    x_max: float = 0.0
    y_min: float = 0.0
    y_max: float = 0.0

    def add(self, item: Item) -> None:
        if isinstance(item, Move):
            length = _length(item)
            self.moves += 1
            self.rapids += item.rapid
            self.arcs += item.kind == "arc"
            if item.pen == "down" and not item.rapid:
                self.drawn += length
            else:
                self.travel += length
            self.move_minutes += length / item.feed
            self.x_min, self.x_max = min(self.x_min, item.x), max(self.x_max, item.x)
            self.y_min, self.y_max = min(self.y_min, item.y), max(self.y_max, item.y)
        elif isinstance(item, ZMove):
            self.z_moves += 1
            self.z_minutes += abs(item.z - item.sz) / item.feed
        elif isinstance(item, Dwell):
            self.dwell += item.seconds
        elif isinstance(item, ToolChange) and item.wait:
            self.changes += 1

    def line(self, path: str, notes: int = 0) -> str:
        seconds = 60.0 * (self.move_minutes + self.z_minutes) + self.dwell
        changes = self.changes
        return (f"{path}: OK, {self.moves} moves ({self.rapids} rapid, "
                f"{self.moves - self.rapids - self.arcs} lines, {self.arcs} arcs"
                + (f", {self.z_moves} Z moves" if self.z_moves else "")
                + (f", {changes} pen change{'s' if changes != 1 else ''}" if changes else "")
                + f"); drawn {self.drawn:.1f} mm, "
                f"travel {self.travel:.1f} mm, about {seconds:.0f} s at the programmed feeds; "
                f"end points within X {self.x_min:.2f}..{self.x_max:.2f}, "
                f"Y {self.y_min:.2f}..{self.y_max:.2f} mm"
                + (f"; {notes} note{'s' if notes != 1 else ''}: lines accepted without effect" if notes else ""))


def listing(name: str, errors: Sequence[GCodeError], notes: Sequence[Note]) -> List[str]:
    """NAME:line N: why for each refusal and note, in line order; a note said on many lines
    (an E word on every move) is one entry, at its first line, with the count of the others."""
    by_text: Dict[str, List[int]] = {}
    for note in notes:
        by_text.setdefault(note.text, []).append(note.line)
    entries = [(e.line, f"{name}:{e}") for e in errors]
    for text, lines in by_text.items():
        more = f" (and {len(lines) - 1} more line{'s' if len(lines) > 2 else ''} from line {lines[1]} on)" \
            if len(lines) > 1 else ""
        entries.append((lines[0], f"{name}:line {lines[0]}: note: {text}{more}"))
    return [text for _line, text in sorted(entries, key=lambda e: e[0])]


def write_refusal(name: str, exc: GCodeError, err: TextIO) -> None:
    """Every refused line of a program (and its notes), each as NAME:line N: why, in line order."""
    errors = all_errors(exc)
    notes = exc.notes if isinstance(exc, GCodeErrors) else []
    for text in listing(name, errors, notes):
        err.write(text + "\n")
    more = exc.more if isinstance(exc, GCodeErrors) else 0
    if more:
        err.write(f"{name}: ... and {more} more refused lines\n")
    count = len(errors) + more
    err.write(f"{name}: refused: {count} line{'s' if count != 1 else ''} the plotter cannot do; nothing moved\n")


def run_check(args: argparse.Namespace, out: TextIO = None, err: TextIO = None) -> int:
    out = out or sys.stdout
    err = err or sys.stderr
    try:
        with open(args.file, "rb") as f:
            data = f.read()
    except OSError as exc:
        err.write(f"{args.file}: cannot read: {exc.strerror or exc}\n")
        return EXIT_BAD_PROGRAM
    if not (args.steps_per_mm > 0 and math.isfinite(args.steps_per_mm)):
        err.write("--steps-per-mm must be a positive number\n")
        return EXIT_BAD_PROGRAM
    if (args.svg and not args.svg.lower().endswith(".svg")) or (args.png and not args.png.lower().endswith(".png")):
        err.write("--svg takes an .svg file, --png a .png file\n")
        return EXIT_BAD_PROGRAM
    if not (args.rapid_rate > 0 and math.isfinite(args.rapid_rate)):
        err.write("--rapid-rate must be a positive number\n")
        return EXIT_BAD_PROGRAM
    if not (args.z_steps_per_mm > 0 and math.isfinite(args.z_steps_per_mm)):
        err.write("--z-steps-per-mm must be a positive number\n")
        return EXIT_BAD_PROGRAM
    try:
        options = gcode_options(args)
    except ValueError as exc:
        err.write(f"{exc}\n")
        return EXIT_BAD_PROGRAM
    x_min, x_max, y_min, y_max = args.area or (args.x_min, args.x_max, args.y_min, args.y_max)
    if not (x_min < x_max and y_min < y_max and all(map(math.isfinite, (x_min, x_max, y_min, y_max)))):
        err.write(f"work area X {x_min:g}..{x_max:g}, Y {y_min:g}..{y_max:g}: each minimum must be "
                  f"below its maximum\n")
        return EXIT_BAD_PROGRAM
    area = None if args.no_limits else WorkArea(x_min, x_max, y_min, y_max, args.z_min, args.z_max)
    try:
        fit = None
        if args.fit_arcs is not None:
            from plotter_bridge.motion.compiler import board_fit
            fit = board_fit(args.fit_arcs, area, args.steps_per_mm)
    except ValueError as exc:
        err.write(f"--fit-arcs: {exc}\n")
        return EXIT_BAD_PROGRAM
    # Read, checked and written a line at a time: the table waits in a spool (on disk past a few MB)
    # until the whole program has passed, so that a refused one prints nothing of it.
    reading, outside, before = Reading(), [], [0]
    items = read_items(decode_program(data), reading, rapid_rate=args.rapid_rate, z_axis=args.z_axis,
                       options=options)
    if area is not None:
        items = within_limits(items, area, outside)
    if fit is not None:
        from plotter_bridge.gcode.arcfit import iter_fit_arcs

        def counted(items: Iterable[Item]) -> Iterator[Item]:
            for item in items:
                before[0] += isinstance(item, Move)
                yield item
        items = iter_fit_arcs(counted(items), fit)
    summary = Summary()
    noted = 0
    with tempfile.SpooledTemporaryFile(max_size=SPOOL_BYTES, mode="w+") as spool:
        if not args.json:
            spool.write(TABLE_HEADER)
        for item in items:
            summary.add(item)
            if args.json:
                if not isinstance(item, (Move, ZMove)):
                    continue
                while noted < len(reading.notes) and reading.notes[noted].line <= item.line:
                    spool.write(json.dumps(_message_record(reading.notes[noted])) + "\n")
                    noted += 1
                spool.write(json.dumps(move_record(item) if isinstance(item, Move) else z_record(item)) + "\n")
            else:
                spool.write(_table_row(item, args.steps_per_mm, args.z_steps_per_mm))
        try:
            reading.raise_errors(outside)
        except GCodeError as exc:
            write_refusal(args.file, exc, err)
            if args.json:
                notes = exc.notes if isinstance(exc, GCodeErrors) else []
                for line in sorted([*notes, *all_errors(exc)], key=lambda e: e.line):
                    out.write(json.dumps(_message_record(line)) + "\n")
            return EXIT_BAD_PROGRAM
        for text in listing(args.file, [], reading.notes):
            err.write(text + "\n")
        if args.json:
            for note in reading.notes[noted:]:
                spool.write(json.dumps(_message_record(note)) + "\n")
        spool.seek(0)
        shutil.copyfileobj(spool, out)
    if args.json:
        return EXIT_OK
    fitted = "" if fit is None else (f"; with arcs fitted within {args.fit_arcs:g} mm, {before[0]} moves became "
                                     f"{summary.moves}")
    out.write(summary.line(args.file, len(reading.notes)) + fitted + "\n")
    if args.svg or args.png:
        return write_plan(args, decode_program(data), area, options, out, err)
    return EXIT_OK


def write_plan(args: argparse.Namespace, text: str, area, options: GCodeOptions, out: TextIO, err: TextIO) -> int:
    """--svg/--png: the job as the streamer would plan it for the default board, drawn, and its figures."""
    from plotter_bridge.link.protocol import DEFAULT_BAUD
    from plotter_bridge.motion.compiler import StreamerConfig
    from plotter_bridge.motion.preview import preview_program
    from .picture import Area, write_preview
    try:
        config = StreamerConfig(args.steps_per_mm, args.rapid_rate, area, z_mode="axis" if args.z_axis else "pen",
                                z_steps_per_mm=args.z_steps_per_mm, dialect=options.dialect,
                                pen_up_z=options.pen_up_z, marlin_pen_down=options.marlin_pen_down,
                                marlin_pen_up=options.marlin_pen_up, link_baud=DEFAULT_BAUD,
                                arc_tolerance=args.fit_arcs or 0.02, park=tuple(args.park))
        preview = preview_program(text, config)
    except (GCodeError, ValueError) as exc:
        err.write(f"{args.file}: no preview: {exc}\n")
        return EXIT_BAD_PROGRAM
    out.write(f"{args.file}: plan: {preview.summary()}\n")
    frame = Area(area.x_min, area.x_max, area.y_min, area.y_max) if area is not None else Area()
    for path in (args.svg, args.png):
        if path:
            write_preview(path, preview, frame, title=args.file)
            err.write(f"preview: {path}\n")
    return EXIT_OK


COMMANDS = (Command("check", "validate a G-code program and print the moves it would make",
                    _configure_check, run_check),)
