"""`plotter stream`, `resume`, `jobs` and `watch`: the node graph from the command line.

`run_program_text` and `connection_args` also serve the subcommands other
packages add (plotter_shapes: `draw`, `svg`, `text`).  ROS is imported only
when one of these runs, so `plotter check` stays quick.
A program is parsed before any node starts, and checked against the work
area from the pen's actual position before anything moves.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import List, TextIO

from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.motion.kinematics import DEFAULT_Z_STEPS_PER_MM

from .check import dialect_args, gcode_options
from .command import EXIT_BAD_PROGRAM, EXIT_FAILED, EXIT_OK, Command

HANGING_AREA = (0.0, 800.0, 0.0, 1000.0)   # seed 003's board below its pulleys, mm


def connection_args(p: argparse.ArgumentParser) -> None:
    """The arguments of every subcommand that runs a program: where the board is, the machine."""
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--port", metavar="PORT", help="serial port or pyserial URL of the board")
    where.add_argument("--mock", action="store_true", help="run on a simulated board (the firmware core)")
    p.add_argument("--baud", type=int, default=115200, help="baud rate (default 115200)")
    p.add_argument("--steps-per-mm", type=float, default=80.0, metavar="N",
                   help="motor steps per mm (default 80)")
    p.add_argument("--trace", metavar="OUT.csv", default="",
                   help="with --mock: write every step (t_s,x_steps,y_steps)")
    p.add_argument("--faults", default="", metavar="SPEC",
                   help="with --mock: faults on the serial line and board events, e.g. "
                        "drop=0.01,corrupt=0.01,dup=0.001,delay=0.001,seed=1,unplug_at=STEPS,unplug_for=S,"
                        "reset_at=STEPS")
    p.add_argument("--seq-log", metavar="OUT.csv", default="",
                   help="with --mock: sequence numbers of the commands the board started")
    p.add_argument("--journal", metavar="DIR", default="",
                   help="job journal directory (default $ROS_HOME/plotter_journal)")
    p.add_argument("--namespace", default="/plotter", help="ROS namespace of the nodes (default /plotter)")
    p.add_argument("--machine", choices=("cartesian", "hanging"), default="cartesian",
                   help="kinematics: an XY table (default), or seed 003's hanging two-string plotter")
    p.add_argument("--area", type=float, nargs=4, metavar=("X_MIN", "X_MAX", "Y_MIN", "Y_MAX"), default=None,
                   help="work area in mm (default 0 200 0 200; hanging: 0 800 0 1000)")
    p.add_argument("--z-axis", action="store_true",
                   help="G-code Z moves a third axis (pen height, engraving depth; firmware built with "
                        "ZAXIS=1) instead of lifting and lowering the pen")
    p.add_argument("--z-steps-per-mm", type=float, default=None, metavar="N",
                   help=f"with --z-axis: motor steps per mm of Z (default {DEFAULT_Z_STEPS_PER_MM:g})")
    p.add_argument("--z-range", type=float, nargs=2, metavar=("Z_MIN", "Z_MAX"), default=None,
                   help="with --z-axis: travel of Z in mm from the power-on origin (default -50 50)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--svg", metavar="OUT.svg", default="",
                   help="write a picture of what the board drew, the programmed path underneath")
    p.add_argument("--png", metavar="OUT.png", default="", help="the same picture as PNG")


def _graph_options(args: argparse.Namespace):
    """GraphOptions from the connection arguments; ValueError for bad ones."""
    from plotter_bridge.sim.faults import parse_faults
    from plotter_bridge.nodes.local_graph import GraphOptions
    faults = parse_faults(args.faults)
    if (args.faults or args.seq_log) and not args.mock:
        raise ValueError("--faults and --seq-log need --mock")
    if (args.z_range or args.z_steps_per_mm is not None) and not args.z_axis:
        raise ValueError("--z-range and --z-steps-per-mm need --z-axis")
    z_steps_per_mm = DEFAULT_Z_STEPS_PER_MM if args.z_steps_per_mm is None else args.z_steps_per_mm
    if not (math.isfinite(z_steps_per_mm) and z_steps_per_mm > 0):
        raise ValueError("--z-steps-per-mm must be a positive number")
    if args.z_range and not args.z_range[0] < args.z_range[1]:
        raise ValueError("--z-range: Z_MIN must be below Z_MAX")
    return GraphOptions(gcode=gcode_options(args), port=args.port or "", mock=args.mock, baud=args.baud,
                        steps_per_mm=args.steps_per_mm, trace=args.trace,
                        namespace=args.namespace, faults=faults, seq_log=args.seq_log,
                        journal_dir=args.journal, machine=args.machine,
                        area=tuple(args.area) if args.area else HANGING_AREA if args.machine == "hanging" else None,
                        z_axis=args.z_axis, z_steps_per_mm=z_steps_per_mm,
                        z_range=tuple(args.z_range) if args.z_range else None)


def reliability_report(graph) -> str:
    """What the mock board's faults did and how the link coped, one line."""
    stats = graph.bridge.session.link.stats if graph.bridge.session.link else None
    c = graph.board.fault_counts()
    line = (f"faults: {c.dropped} dropped, {c.corrupted} corrupted, {c.duplicated} duplicated, "
            f"{c.delayed} delayed of {c.bytes} bytes; {graph.board.unplugs} unplugs, "
            f"{graph.board.resets} resets")
    if stats:
        line += (f"; link: {stats.lines_sent} lines sent, {stats.retransmissions} retransmitted, "
                 f"{stats.resend_requests} resend requests, {stats.timeouts} time-outs, "
                 f"{stats.garbled_replies} damaged replies, {stats.reconnects} reconnects")
    return line


class ProgressBar:
    def __init__(self, total_lines: int, out: TextIO) -> None:
        self.total = max(1, total_lines)
        self.out = out
        self._last = 0.0

    def __call__(self, fb) -> None:
        now = time.monotonic()
        if now - self._last < 0.1 and fb.progress < 1.0:
            return
        self._last = now
        width = 30
        done = int(width * min(1.0, fb.progress))
        self.out.write(f"\r[{'#' * done}{'.' * (width - done)}] {fb.progress * 100:5.1f}%  "
                       f"line {fb.current_line}/{fb.total_lines}  X{fb.x_mm:8.3f} Y{fb.y_mm:8.3f}")
        self.out.flush()

    def close(self, success: bool) -> None:
        if success:
            self.out.write(f"\r[{'#' * 30}] 100.0%{' ' * 40}")
        self.out.write("\n")


class StateRecorder:
    """The bridge's reported positions and pen states while a program runs."""

    def __init__(self, node) -> None:
        from plotter_bridge.nodes.qos import latched
        from plotter_interfaces.msg import BoardState
        self._disconnected = BoardState.DISCONNECTED
        self.samples: List[tuple] = []
        self.first = threading.Event()
        node.create_subscription(BoardState, "state", self._on_state, latched())

    def _on_state(self, msg) -> None:
        if msg.state == self._disconnected:
            return
        self.samples.append((msg.x_mm, msg.y_mm, msg.pen_down))
        self.first.set()

    def start(self, timeout: float = 10.0) -> tuple:
        """Where the pen is before the program (mm); (0, 0) if the bridge says nothing."""
        self.first.wait(timeout)
        return self.samples[-1][:2] if self.samples else (0.0, 0.0)


def write_pictures(args: argparse.Namespace, text: str, name: str, start: tuple,
                   trace_path: str, samples: List[tuple], err: TextIO) -> None:
    """--svg/--png: what was drawn (the mock's step trace, else reported positions) over the program."""
    from .picture import program_polylines, runs_by_pen, runs_near_path, write_picture
    programmed = program_polylines(text, start, gcode_options(args)) if text else []
    if trace_path:
        from plotter_bridge.sim.trace import read_trace
        spm = args.steps_per_mm
        runs = runs_near_path(((x / spm, y / spm) for _, x, y in read_trace(Path(trace_path))), programmed)
    else:
        runs = runs_by_pen(samples)
    for path in (args.svg, args.png):
        if path:
            write_picture(path, runs, programmed, title=name)
            err.write(f"picture: {path}\n")


def run_program_text(text: str, name: str, args: argparse.Namespace,
                     out: TextIO = sys.stdout, err: TextIO = sys.stderr) -> int:
    from plotter_bridge.gcode.parser import parse_program
    resume_id = getattr(args, "resume_id", "")
    try:
        if not resume_id:
            # Syntax first; the work area is checked from the pen's real position.
            program = parse_program(text, z_axis=getattr(args, "z_axis", False), options=gcode_options(args))
            for note in program.notes:
                err.write(f"{name}:{note}\n")
    except ValueError as exc:  # GCodeError, or bad dialect options
        err.write(f"{name}:{exc}\n" if isinstance(exc, GCodeError) else f"{exc}\n")
        return EXIT_BAD_PROGRAM
    svg_out, png_out = getattr(args, "svg", ""), getattr(args, "png", "")
    if (png_out and Path(png_out).suffix.lower() != ".png") or \
            (svg_out and Path(svg_out).suffix.lower() != ".svg"):
        err.write("--svg takes an .svg file, --png a .png file\n")
        return EXIT_BAD_PROGRAM
    from dataclasses import replace
    from plotter_bridge.nodes.local_graph import LocalGraph
    try:
        options = _graph_options(args)
    except ValueError as exc:
        err.write(f"{exc}\n")
        return EXIT_BAD_PROGRAM
    pictures = bool(svg_out or png_out)
    with tempfile.TemporaryDirectory(prefix="plotter-") as tmp:
        if pictures and options.mock and not options.trace:
            options = replace(options, trace=str(Path(tmp) / "trace.csv"))
        bar = None if args.quiet else ProgressBar(text.count("\n") + 1, err)
        with LocalGraph(options) as graph:
            recorder = StateRecorder(graph.client_node) if pictures else None
            start = recorder.start() if recorder else (0.0, 0.0)
            result = graph.run_program(text, name, progress=bar, resume=resume_id)
            report = reliability_report(graph) if options.mock and (args.faults or args.seq_log) else ""
        if bar:
            bar.close(result.success)
        if report:
            err.write(report + "\n")
        if pictures:
            write_pictures(args, "" if resume_id else text, name, start,
                           options.trace if options.mock else "", recorder.samples, err)
    if result.success:
        z = "" if result.z_mm is None else f" Z{result.z_mm:.3f}"
        out.write(f"{name}: done, pen at X{result.x_mm:.3f} Y{result.y_mm:.3f}{z} mm\n")
        return EXIT_OK
    err.write(f"{name}: {result.message}\n")
    if result.job_id:
        err.write(f"to finish it from where it stopped: plotter resume {result.job_id} "
                  f"{'--mock' if args.mock else '--port ' + args.port}\n")
    return EXIT_FAILED


# ---------------------------------------------------------------- stream

def _configure_stream(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.gcode", help="G-code program to draw")
    dialect_args(p)
    connection_args(p)


def run_stream(args: argparse.Namespace) -> int:
    try:
        with open(args.file, "rb") as f:
            data = f.read()
    except OSError as exc:
        sys.stderr.write(f"{args.file}: {exc.strerror}\n")
        return EXIT_BAD_PROGRAM
    from plotter_bridge.gcode.parser import decode_program
    try:
        text = decode_program(data)
    except GCodeError as exc:
        sys.stderr.write(f"{args.file}:{exc}\n")
        return EXIT_BAD_PROGRAM
    return run_program_text(text, args.file, args)


_STREAM = Command("stream", "stream a G-code program to the board (or a mock board) and wait for it",
                  _configure_stream, run_stream)


# ---------------------------------------------------------------- resume, jobs

def _configure_resume(p: argparse.ArgumentParser) -> None:
    p.add_argument("resume_id", metavar="JOB_ID", help="id of an interrupted job (see plotter jobs)")
    connection_args(p)


def run_resume(args: argparse.Namespace) -> int:
    return run_program_text("", f"job {args.resume_id}", args)


_RESUME = Command("resume", "finish an interrupted job from its last completed line (from the journal)",
                  _configure_resume, run_resume)


def _configure_jobs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--journal", metavar="DIR", default="",
                   help="job journal directory (default $ROS_HOME/plotter_journal)")


def run_jobs(args: argparse.Namespace, out: TextIO = sys.stdout) -> int:
    from plotter_bridge.link.journal import Journal, default_journal_dir
    journal = Journal(args.journal or default_journal_dir())
    for job_id, prog, mtime in journal.jobs():
        record, _ = journal.load(job_id)
        when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(mtime))
        note = f"resumed as {prog.resumed_by}" if prog.resumed_by else prog.message
        out.write(f"{job_id}  {when}  {prog.state:<11} {prog.completed:>6}/{len(record.commands):<6} "
                  f"{record.name}  {note}\n")
    return EXIT_OK


_JOBS = Command("jobs", "list the journalled jobs, newest first", _configure_jobs, run_jobs)


# ---------------------------------------------------------------- watch

def _configure_watch(p: argparse.ArgumentParser) -> None:
    p.add_argument("--namespace", default="/plotter", help="namespace of the plotter (default /plotter)")
    p.add_argument("--count", type=int, default=0, help="stop after this many messages (0: never)")
    p.add_argument("--timeout", type=float, default=0.0, help="stop after this many seconds (0: never)")


def run_watch(args: argparse.Namespace, out: TextIO = sys.stdout) -> int:
    import rclpy
    from geometry_msgs.msg import PointStamped
    rclpy.init(args=[])
    node = rclpy.create_node("plotter_watch")
    seen = [0]
    topic = args.namespace.rstrip("/") + "/position"

    def show(msg: PointStamped) -> None:
        seen[0] += 1
        s = msg.header.stamp
        out.write(f"{s.sec}.{s.nanosec:09d}  X {msg.point.x:9.3f}  Y {msg.point.y:9.3f} mm\n")
        out.flush()

    node.create_subscription(PointStamped, topic, show, 10)
    start = time.monotonic()
    try:
        while rclpy.ok():
            rclpy.spin_once(node, timeout_sec=0.1)
            if args.count and seen[0] >= args.count:
                break
            if args.timeout and time.monotonic() - start > args.timeout:
                break
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return EXIT_OK if (seen[0] or not args.count) else EXIT_FAILED


_WATCH = Command("watch", "print live positions (like ros2 topic echo /plotter/position)",
                  _configure_watch, run_watch)




COMMANDS = (_STREAM, _RESUME, _JOBS, _WATCH)
