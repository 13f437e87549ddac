"""The subcommands plotter_shapes adds to the ``plotter`` command: ``draw`` (a
built-in shape), ``svg`` (an SVG drawing) and ``text`` (Hershey text).

plotter_bridge's command line finds them through the entry point group
``plotter.commands`` (setup.py), as ros2cli finds the verbs of other packages:
the driver package never imports this one, which depends on it.  Each makes a
G-code program and runs it like ``plotter stream`` (plotter_bridge.cli.run);
without ``--port`` or ``--mock``, ``draw`` sends a ``draw`` goal to the
running shape_server instead, and ``svg`` and ``text`` their program to the
running gcode_streamer.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import List

from plotter_bridge.cli.command import EXIT_BAD_PROGRAM, Command
from plotter_bridge.cli.run import connection_args, run_goal_on_graph, run_program_text

from plotter_shapes.geometry import ShapeError, build_shape, figure_to_gcode
from plotter_shapes.svg_input import Placement, VectorError, parse_layer_order, svg_program
from plotter_shapes.text_input import DEFAULT_FONT, text_program

DEFAULT_FEED = 1500.0      # mm/min for shapes drawn without --feed


def _configure_draw(p: argparse.ArgumentParser) -> None:
    p.add_argument("shape", help="diamond, star, circle, cone, car, line or arc")
    p.add_argument("--size", type=float, default=0.0, metavar="MM",
                   help="radius of a circle/arc, overall size of the others (default 40)")
    p.add_argument("--x", type=float, default=None, metavar="MM", help="anchor or centre X (default 100)")
    p.add_argument("--y", type=float, default=None, metavar="MM", help="anchor or centre Y (default 100)")
    p.add_argument("--x2", type=float, default=0.0, metavar="MM", help="line: end X")
    p.add_argument("--y2", type=float, default=0.0, metavar="MM", help="line: end Y")
    p.add_argument("--start-angle", type=float, default=0.0, metavar="DEG", help="arc: start angle")
    p.add_argument("--end-angle", type=float, default=0.0, metavar="DEG", help="arc: end angle")
    p.add_argument("--ccw", action="store_true", help="circles and arcs counter-clockwise (default clockwise)")
    p.add_argument("--reverse", action="store_true", help="draw the figure backwards")
    p.add_argument("--feed", type=float, default=DEFAULT_FEED, metavar="MM_PER_MIN",
                   help=f"drawing feed (default {DEFAULT_FEED:g})")
    connection_args(p)


def shape_program(args: argparse.Namespace) -> List[str]:
    figure = build_shape(args.shape, args.x, args.y, args.size, not args.ccw, args.reverse,
                         args.feed, args.x2, args.y2, args.start_angle, args.end_angle)
    return figure_to_gcode(figure, args.feed, args.shape)


def run_draw(args: argparse.Namespace) -> int:
    try:
        lines = shape_program(args)
    except ShapeError as exc:
        sys.stderr.write(f"draw: {exc}\n")
        return EXIT_BAD_PROGRAM
    text = "\n".join(lines) + "\n"
    if args.port or args.mock:
        return run_program_text(text, args.shape, args)
    from plotter_interfaces.action import DrawShape
    return run_goal_on_graph(args, args.shape, DrawShape, "draw", DrawShape.Goal(shape=shape_goal(args)), text)


def shape_goal(args: argparse.Namespace):
    """The ShapeGoal of `plotter draw`'s arguments, for the running shape_server
    (x = y = 0 there means the work area's centre, size 0 its default)."""
    from plotter_interfaces.msg import ShapeGoal
    x, y = (0.0, 0.0) if args.x is None and args.y is None else (
        100.0 if args.x is None else args.x, 100.0 if args.y is None else args.y)
    return ShapeGoal(shape=args.shape, x=float(x), y=float(y), size=float(args.size),
                     clockwise=not args.ccw, reverse=args.reverse, feed=float(args.feed),
                     x2=float(args.x2), y2=float(args.y2), start_angle=float(args.start_angle),
                     end_angle=float(args.end_angle))


_DRAW = Command("draw", "draw one of the built-in shapes", _configure_draw, run_draw)


def _drawing_args(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--width", type=float, default=None, metavar="MM",
                   help=f"scale the {what} to this width "
                        f"(default: {'its own size' if what == 'drawing' else 'the font size'})")
    p.add_argument("--x", type=float, default=100.0, metavar="MM", help=f"centre of the {what}, X (default 100)")
    p.add_argument("--y", type=float, default=100.0, metavar="MM", help=f"centre of the {what}, Y (default 100)")
    p.add_argument("--optimize", action="store_true",
                   help="merge paths that meet and reorder them for less pen-up travel (vpype linemerge, linesort)")
    p.add_argument("--feed", type=float, default=DEFAULT_FEED, metavar="MM_PER_MIN",
                   help=f"drawing feed (default {DEFAULT_FEED:g})")
    p.add_argument("--gcode", metavar="OUT.gcode", default="", help="also write the program here")
    p.add_argument("--preview", metavar="OUT.svg|OUT.png", default="",
                   help="only write the plan (each pen in its colour, the pen-up travel, the lengths and the "
                        "board's time, as plotter check --svg/--png) and say its figures: nothing moves")
    connection_args(p)


def _run_drawing(make_program, name: str, args: argparse.Namespace) -> int:
    try:
        lines = make_program()
    except (VectorError, ShapeError) as exc:
        sys.stderr.write(f"{name}: {exc}\n")
        return EXIT_BAD_PROGRAM
    text = "\n".join(lines) + "\n"
    if args.gcode:
        Path(args.gcode).write_text(text)
    if args.preview:
        return write_preview_of(text, name, args)
    return run_program_text(text, name, args)


def write_preview_of(text: str, name: str, args: argparse.Namespace) -> int:
    """--preview: the program's plan for the default board (or --area, --steps-per-mm, --park), drawn."""
    from plotter_bridge.cli.picture import Area, picture_format, write_preview
    from plotter_bridge.gcode.limits import WorkArea
    from plotter_bridge.gcode.types import GCodeError
    from plotter_bridge.link.protocol import DEFAULT_BAUD
    from plotter_bridge.motion.compiler import StreamerConfig
    from plotter_bridge.motion.preview import preview_program
    area = WorkArea(*args.area) if args.area else WorkArea()
    try:
        picture_format(args.preview)
        config = StreamerConfig(args.steps_per_mm or 80.0, area=area, link_baud=args.baud or DEFAULT_BAUD,
                                park=tuple(args.park) if args.park else (0.0, 0.0))
        preview = preview_program(text, config)
    except (GCodeError, ValueError) as exc:
        sys.stderr.write(f"{name}: no preview: {exc}\n")
        return EXIT_BAD_PROGRAM
    write_preview(args.preview, preview, Area(area.x_min, area.x_max, area.y_min, area.y_max), title=Path(name).name)
    sys.stdout.write(f"{name}: plan: {preview.summary()}\npreview: {args.preview}\n")
    return 0


def _configure_svg(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.svg", help="vector drawing to plot")
    p.add_argument("--layers", metavar="N,N,...", default="",
                   help="draw only these layers, in this order (numbered from 1 in the file: its Inkscape layers, "
                        "or else its stroke colours); by default every layer in file order, with a pen change "
                        "between two")
    _drawing_args(p, "drawing")


def run_svg(args: argparse.Namespace) -> int:
    if not Path(args.file).is_file():
        sys.stderr.write(f"{args.file}: no such file\n")
        return EXIT_BAD_PROGRAM
    placement = Placement(args.width, (args.x, args.y))
    return _run_drawing(lambda: svg_program(args.file, placement, args.feed, args.optimize,
                                            parse_layer_order(args.layers) if args.layers else None), args.file, args)


_SVG = Command("svg", "plot an SVG drawing (circles and arcs as arcs, curves as arcs fitted within 0.01 mm)",
               _configure_svg, run_svg)


def _configure_text(p: argparse.ArgumentParser) -> None:
    p.add_argument("text", help="one line of text")
    p.add_argument("--font", default=DEFAULT_FONT, help=f"Hershey font (default {DEFAULT_FONT})")
    p.add_argument("--size", type=float, default=10.0, metavar="MM", help="font size (default 10)")
    _drawing_args(p, "text")


def run_text(args: argparse.Namespace) -> int:
    placement = Placement(args.width, (args.x, args.y))
    return _run_drawing(lambda: text_program(args.text, args.font, args.size, placement, args.feed, args.optimize),
                        args.text, args)


_TEXT = Command("text", "write text in a Hershey font", _configure_text, run_text)


COMMANDS = (_DRAW, _SVG, _TEXT)
