"""`plotter follow`: line following (seed 003) on a board built with
FOLLOW=1, or on a mock board with a sheet under its pen.

Without --port or --mock the goal goes to the plotter running in
--namespace: gcode_streamer's `follow_line` action, which does what
follows in its own nodes and reports the length followed.

With --port or --mock the pen goes up to the start (--start X Y, machine mm) as a G-code move
through the streamer, then the board's `F` runs as a job of the bridge's
(link/follow.py turns the goal into it).  The board's status says why the
follow stopped and how many steps it took.  With --mock the sheet is an SVG
placed as `plotter svg` places a drawing (read by plotter_shapes, through
the entry point group SHEET_GROUP), or a G-code file whose pen-down moves
are the black lines, in machine mm as the mock board's trace; the trace is
checked against it: the pen must have stayed on the black.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from importlib.metadata import entry_points
from pathlib import Path
from typing import Optional, TextIO, Tuple

from plotter_bridge.link.follow import FINISHED, FollowError, FollowGoal, follow_command, follow_state_name

from .command import EXIT_BAD_PROGRAM, EXIT_FAILED, EXIT_OK, Command

PLAIN_PERIOD = 2.0      # s between the lines that show a follow on a running plotter
# Readers of sheets other than G-code, by file suffix (name) -> path -> polylines in machine mm.
SHEET_GROUP = "plotter.sheets"


def _configure(p: argparse.ArgumentParser) -> None:
    from .run import connection_args
    p.add_argument("--start", nargs=2, type=float, required=True, metavar=("X", "Y"),
                   help="where the pen starts on the line, machine mm (it goes there with the pen up)")
    p.add_argument("--heading", type=float, default=0.0, metavar="DEG",
                   help="the way to set out along the line, degrees counter-clockwise from +X (default 0)")
    p.add_argument("--feed", type=float, default=0.0, metavar="MM/S",
                   help="follow at this speed (default: the board's most, 250 steps/s)")
    p.add_argument("--lost", type=float, default=5.0, metavar="MM",
                   help="no sensor on black for this far: the line is lost (default 5)")
    p.add_argument("--distance", type=float, default=0.0, metavar="MM",
                   help="stop after this many mm of steps (default: once round to the start)")
    p.add_argument("--width", type=float, default=7.0, metavar="MM",
                   help="the line's width (with --mock, the sheet's lines; default 7)")
    p.add_argument("--gate", type=float, default=None, metavar="MM",
                   help="the start gate's half width (default half the line's width)")
    p.add_argument("--sheet", metavar="LINE.svg", default="",
                   help="with --mock: the black lines under the pen: an SVG placed as plotter svg places it "
                        "(its own size, centred on 100, 100), or a G-code file's pen-down moves")
    connection_args(p)


def run_follow(args: argparse.Namespace, out: Optional[TextIO] = None, err: Optional[TextIO] = None) -> int:
    from plotter_bridge.sim.sheet import SensorRing, SheetError
    out, err = out or sys.stdout, err or sys.stderr
    if args.mock and not args.sheet:
        err.write("plotter follow --mock needs --sheet LINE.svg: the lines under the mock board's pen\n")
        return EXIT_BAD_PROGRAM
    if args.sheet and not args.mock:
        err.write("--sheet goes with --mock: a real board's sheet is the paper under its pen\n")
        return EXIT_BAD_PROGRAM
    if args.machine != "cartesian":
        err.write(f"line following runs on the XY table only, not the {args.machine} machine: "
                  f"its sensors' directions are the motors' axes\n")
        return EXIT_BAD_PROGRAM
    gate = args.width / 2 if args.gate is None else args.gate
    goal = FollowGoal(heading_deg=args.heading, feed_mm_s=args.feed, lost_mm=args.lost,
                      distance_mm=args.distance, gate_mm=gate)
    if not (args.port or args.mock):
        return follow_on_graph(args, goal, out, err)
    steps_per_mm = args.steps_per_mm or 80.0
    try:
        command = follow_command(goal, steps_per_mm)
        sheet = load_sheet(args.sheet, args.width) if args.sheet else None
        if sheet is not None:
            sheet.check_ring(SensorRing())          # the mock board's sensors
    except (FollowError, SheetError) as exc:
        err.write(f"plotter follow: {exc}\n")
        return EXIT_BAD_PROGRAM
    except OSError as exc:
        err.write(f"plotter follow: --sheet {args.sheet}: {exc.strerror or exc}\n")
        return EXIT_BAD_PROGRAM
    from .run import _graph_options
    from plotter_bridge.nodes.local_graph import LocalGraph
    try:
        options = replace(_graph_options(args), sheet=sheet)
    except ValueError as exc:
        err.write(f"{exc}\n")
        return EXIT_BAD_PROGRAM
    x, y = args.start
    with tempfile.TemporaryDirectory(prefix="plotter-") as tmp:
        if options.mock and not options.trace:
            options = replace(options, trace=str(Path(tmp) / "trace.csv"))
        with LocalGraph(options) as graph:
            moved = graph.run_program(f"G21 G90\nG0 X{x:.4f} Y{y:.4f}\n", "start")
            if not moved.success:
                err.write(f"follow: the pen did not reach the start: {moved.message}\n")
                return EXIT_FAILED
            try:
                ok, message = graph.stream_commands([command])
            except KeyboardInterrupt:
                err.write("follow: canceled\n")
                return 130
            status = graph.bridge.session.link.status if graph.bridge.session.link else None
        if not ok:
            err.write(f"follow: {message}\n")
            return EXIT_FAILED
        if status is None or status.follow is None:
            err.write("follow: the board did not report a follow: is it the FOLLOW=1 image?\n")
            return EXIT_FAILED
        why = follow_state_name(status.follow)
        where = f"pen at X{status.x / steps_per_mm:.3f} Y{status.y / steps_per_mm:.3f} mm"
        summary = f"follow: {why} after {status.followed} steps, {where}"
        if sheet is not None:
            off = _first_off_the_black(options.trace, status.followed, sheet, steps_per_mm)
            if off is not None:
                err.write(summary + f"; but the pen left the {args.width:g} mm line at "
                                    f"X{off[0]:.3f} Y{off[1]:.3f} mm\n")
                return EXIT_FAILED
            summary += "; the pen stayed on the line all the way"
    if why not in FINISHED:
        err.write(summary + "\n")
        return EXIT_FAILED
    out.write(summary + "\n")
    return EXIT_OK


def follow_on_graph(args: argparse.Namespace, goal: FollowGoal, out: TextIO, err: TextIO) -> int:
    """The goal as gcode_streamer's follow_line, on the plotter running in --namespace (its own
    parameters say the steps per mm and the work area; it refuses a bad goal with every reason)."""
    from .run import EXIT_INTERRUPTED, client_refusal
    why = client_refusal(args)
    if why:
        err.write(f"{why}\n")
        return EXIT_BAD_PROGRAM
    from plotter_interfaces.action import FollowLine
    from .client import GraphClient, Missing
    x, y = args.start
    request = FollowLine.Goal(start_x_mm=x, start_y_mm=y, heading_deg=goal.heading_deg, feed_mm_s=goal.feed_mm_s,
                              lost_mm=goal.lost_mm, distance_mm=goal.distance_mm, gate_mm=goal.gate_mm)
    show = FollowLines(err) if not args.quiet else (lambda fb: None)
    with GraphClient(args.namespace) as client:
        try:
            outcome = client.run_goal(FollowLine, "follow_line", request, show)
        except Missing as exc:
            err.write(f"follow: {exc}\n")
            return EXIT_FAILED
        except KeyboardInterrupt:
            err.write("follow: canceled; the pen stopped where it was\n")
            return EXIT_INTERRUPTED
    if outcome.status == "rejected":
        err.write("follow: the plotter rejected the goal (its queue is full: see its log)\n")
        return EXIT_FAILED
    r = outcome.result
    if outcome.status == "succeeded":
        out.write(f"follow: {r.message}\n")
        return EXIT_OK
    err.write(f"follow: {r.message}\n")
    return EXIT_FAILED


class FollowLines:
    """A running follow's feedback as plain lines, one per PLAIN_PERIOD at most."""

    def __init__(self, out: TextIO, clock=None) -> None:
        import time
        self.out, self.clock, self._last = out, clock or time.monotonic, -1e9

    def __call__(self, fb) -> None:
        now = self.clock()
        if now - self._last < PLAIN_PERIOD:
            return
        self._last = now
        if fb.jobs_ahead:
            self.out.write(f"follow: waiting, {fb.jobs_ahead} job(s) ahead\n")
        else:
            self.out.write(f"follow: {fb.steps} steps, {fb.length_mm:.1f} mm, sensors {fb.sensors:03b}, "
                           f"X {fb.x_mm:.3f}  Y {fb.y_mm:.3f} mm\n")
        self.out.flush()


def load_sheet(path: str, width_mm: float):
    """A sheet from a G-code file's pen-down moves, or from a file another installed package reads (entry
    point group SHEET_GROUP, by suffix: plotter_shapes reads SVG); SheetError or OSError naming the file."""
    from plotter_bridge.sim.sheet import Sheet, SheetError
    suffix = Path(path).suffix.lower().lstrip(".")
    readers = {p.name: p for p in entry_points(group=SHEET_GROUP)}
    if suffix not in readers:
        if suffix == "svg":
            raise SheetError(f"{path}: SVG sheets need plotter_shapes installed (it reads SVG)")
        return Sheet.from_gcode(path, width_mm)
    try:
        lines = readers[suffix].load()(path)
    except OSError:
        raise
    except ValueError as exc:            # the reader's own refusal (not a drawing, no paths)
        raise SheetError(str(exc)) from None
    return Sheet(lines, width_mm)


def _first_off_the_black(trace: str, steps: int, sheet, steps_per_mm: float) -> Optional[Tuple[float, float]]:
    """Where the follow's steps, the last of the mock board's trace, first left the sheet's black (mm), or None."""
    from plotter_bridge.sim.trace import read_trace
    rows = read_trace(Path(trace))
    for _, x, y in rows[len(rows) - steps:]:
        pen = (x / steps_per_mm, y / steps_per_mm)
        if not sheet.black(pen):
            return pen
    return None


COMMANDS = (Command("follow", "follow a black line with the board's three sensors (a FOLLOW=1 board, or --mock "
                              "with --sheet)", _configure, run_follow),)
