"""`plotter stream`, `resume`, `jobs`, `watch`, `state` and the board's
buttons (`hold`, `estop`, `reset`, `set-origin`): the node graph from the
command line.

With `--port` or `--mock` a job runs on a node graph of its own, in this
process (nodes/local_graph.py), which owns the serial port; without either
it goes to the plotter already running in `--namespace` (client.py).
`run_program_text`, `run_goal_on_graph` and `connection_args` also serve
the subcommands other packages add (plotter_shapes: `draw`, `svg`, `text`).
ROS is imported only when one of these runs, so `plotter check` stays quick.
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

from plotter_bridge.gcode.dialect import DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP, DEFAULT_PEN_UP_Z
from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.link.protocol import DEFAULT_BAUD
from plotter_bridge.motion.kinematics import DEFAULT_Z_STEPS_PER_MM

from .check import dialect_args, gcode_options, listing, write_refusal
from .command import EXIT_BAD_PROGRAM, EXIT_FAILED, EXIT_OK, Command
from .progress import ProgressDisplay

DEFAULT_MARLIN_PEN = (DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP)
HANGING_AREA = (0.0, 800.0, 0.0, 1000.0)   # seed 003's board below its pulleys, mm


EXIT_INTERRUPTED = 130       # Ctrl-C: the job was cancelled
# Options of a graph of the command's own: a running plotter has its settings in its nodes' parameters.
LOCAL_ONLY = ("baud", "steps_per_mm", "trace", "faults", "seq_log", "journal", "area", "z_axis", "no_fit_arcs",
              "z_steps_per_mm", "z_range", "arc_tolerance", "park")


def connection_args(p: argparse.ArgumentParser) -> None:
    """The arguments of every subcommand that runs a program: where the board is, the machine."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--port", metavar="PORT",
                       help="serial port or pyserial URL of the board: run the plotter's nodes in this command")
    where.add_argument("--mock", action="store_true",
                       help="run on a simulated board (the firmware core) in this command")
    p.add_argument("--baud", type=int, default=None,
                   help=f"with --port: baud rate (default {DEFAULT_BAUD}, the firmware's default image)")
    p.add_argument("--steps-per-mm", type=float, default=None, metavar="N",
                   help="with --port/--mock: motor steps per mm (default 80)")
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
    p.add_argument("--namespace", default="/plotter",
                   help="ROS namespace of the nodes (default /plotter); without --port or --mock, the running "
                        "plotter the job goes to")
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
    p.add_argument("--no-fit-arcs", action="store_true",
                   help="with --port/--mock: send drawn chords as they are written (the streamer's fit_arcs off); "
                        "by default a run of chords that one arc or line holds goes as that arc or line")
    p.add_argument("--arc-tolerance", type=float, default=None, metavar="MM",
                   help="with --port/--mock: how far the fitted arcs and lines may stray from the chords "
                        "(the streamer's arc_tolerance; default 0.02)")
    p.add_argument("--park", type=float, nargs=2, metavar=("X", "Y"), default=None,
                   help="with --port/--mock: where the pen waits, lifted, at a pen change (M6 once something is "
                        "drawn, or between an SVG's layers; default 0 0)")
    p.add_argument("--no-pen-wait", action="store_true",
                   help="at a pen change go on at once (one pen for every layer); by default the command says "
                        "which pen comes next and waits for Enter or plotter resume")
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
    if args.arc_tolerance is not None and not (math.isfinite(args.arc_tolerance) and 0 < args.arc_tolerance <= 1.0):
        raise ValueError(f"--arc-tolerance {args.arc_tolerance:g}: a tolerance above 0 and at most 1 mm")
    return GraphOptions(gcode=gcode_options(args), port=args.port or "", mock=args.mock,
                        baud=args.baud or DEFAULT_BAUD,
                        steps_per_mm=args.steps_per_mm or 80.0, trace=args.trace,
                        namespace=args.namespace, faults=faults, seq_log=args.seq_log,
                        journal_dir=args.journal, machine=args.machine,
                        area=tuple(args.area) if args.area else HANGING_AREA if args.machine == "hanging" else None,
                        z_axis=args.z_axis, z_steps_per_mm=z_steps_per_mm,
                        z_range=tuple(args.z_range) if args.z_range else None,
                        fit_arcs=not args.no_fit_arcs,
                        arc_tolerance=0.02 if args.arc_tolerance is None else args.arc_tolerance,
                        park=tuple(args.park) if args.park else (0.0, 0.0))


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


def pen_prompt(args: argparse.Namespace, err: TextIO, go_on, give_up=None):
    """What says at each pen change which pen comes next and goes on when the user says (cli/pens.py)."""
    from .pens import PenPrompt, read_enter
    return PenPrompt(err, go_on, None if getattr(args, "no_pen_wait", False) else read_enter(sys.stdin), give_up)


def write_pictures(args: argparse.Namespace, text: str, name: str, start: tuple,
                   trace_path: str, samples: List[tuple], err: TextIO) -> None:
    """--svg/--png: what was drawn (the mock's step trace, else reported positions) over the program,
    framed by the work area (--area); none when the board drew nothing (a refused program)."""
    from .picture import Area, program_polylines, runs_by_pen, runs_near_path, write_picture
    if trace_path:
        from plotter_bridge.sim.trace import read_trace
        spm = args.steps_per_mm or 80.0
        trace = [(x / spm, y / spm) for _, x, y in read_trace(Path(trace_path))]
        moved = bool(trace)
    else:
        moved = len({(round(x, 3), round(y, 3)) for x, y, _ in samples}) > 1
    if not moved:
        err.write(f"no picture: the board did not move for {name}\n")
        return
    programmed = program_polylines(text, start, gcode_options(args)) if text else []
    runs = runs_near_path(trace, programmed) if trace_path else runs_by_pen(samples)
    area = getattr(args, "area", None) or (HANGING_AREA if getattr(args, "machine", "") == "hanging" else None)
    frame = Area(*area) if area else Area()
    for path in (args.svg, args.png):
        if path:
            write_picture(path, runs, programmed, frame, title=name)
            err.write(f"picture: {path}\n")


def run_program_text(text: str, name: str, args: argparse.Namespace,
                     out: TextIO = sys.stdout, err: TextIO = sys.stderr) -> int:
    from plotter_bridge.gcode.parser import parse_program
    resume_id = getattr(args, "resume_id", "")
    try:
        # Syntax first (the work area is checked from the pen's real position); a running
        # plotter's streamer reads in its own dialect unless the command names one.
        if not resume_id and (args.port or args.mock or getattr(args, "dialect", None)):
            program = parse_program(text, z_axis=getattr(args, "z_axis", False), options=gcode_options(args))
            for line in listing(name, [], program.notes):
                err.write(line + "\n")
    except GCodeError as exc:
        write_refusal(name, exc, err)
        return EXIT_BAD_PROGRAM
    except ValueError as exc:  # bad dialect options
        err.write(f"{exc}\n")
        return EXIT_BAD_PROGRAM
    svg_out, png_out = getattr(args, "svg", ""), getattr(args, "png", "")
    if (png_out and Path(png_out).suffix.lower() != ".png") or \
            (svg_out and Path(svg_out).suffix.lower() != ".svg"):
        err.write("--svg takes an .svg file, --png a .png file\n")
        return EXIT_BAD_PROGRAM
    if not (args.port or args.mock):
        from plotter_interfaces.action import RunProgram
        goal = RunProgram.Goal(program=text, name=name, resume=resume_id, dialect=getattr(args, "dialect", None) or "")
        return run_goal_on_graph(args, name, RunProgram, "run_program", goal, "" if resume_id else text, out, err)
    from dataclasses import replace
    from plotter_bridge.nodes.local_graph import LocalGraph
    from .pens import watch_session
    from plotter_bridge.nodes.serial_bridge import IO_SWITCH_INTERVAL
    # The serial bridge runs in this process: see serial_bridge.main().
    sys.setswitchinterval(IO_SWITCH_INTERVAL)
    try:
        options = _graph_options(args)
    except ValueError as exc:
        err.write(f"{exc}\n")
        return EXIT_BAD_PROGRAM
    pictures = bool(svg_out or png_out)
    with tempfile.TemporaryDirectory(prefix="plotter-") as tmp:
        if pictures and options.mock and not options.trace:
            options = replace(options, trace=str(Path(tmp) / "trace.csv"))
        bar = None if args.quiet else ProgressDisplay(name, err, err.isatty())
        with LocalGraph(options) as graph:
            recorder = StateRecorder(graph.client_node) if pictures else None
            prompt = pen_prompt(args, err, graph.bridge.session.continue_job,
                                lambda: graph.bridge.session.cancel(graph.bridge.session.job, timeout=0))
            watching = watch_session(prompt, graph.bridge.pen_change_waiting)
            start = recorder.start() if recorder else (0.0, 0.0)
            try:
                result = graph.run_program(text, name, progress=bar, resume=resume_id)
            except KeyboardInterrupt:
                if bar:
                    bar.close(False)
                err.write(f"{name}: canceled\n")
                return EXIT_INTERRUPTED
            finally:
                watching.set()
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


def client_refusal(args: argparse.Namespace) -> str:
    """Why the options do not fit a job for a running plotter ("" if they do)."""
    given = [name for name in LOCAL_ONLY if getattr(args, name, None) not in (None, False, "")]
    if getattr(args, "machine", "cartesian") != "cartesian":
        given.append("machine")
    if getattr(args, "pen_up_z", DEFAULT_PEN_UP_Z) != DEFAULT_PEN_UP_Z:
        given.append("pen_up_z")
    if tuple(getattr(args, "marlin_pen", DEFAULT_MARLIN_PEN)) != DEFAULT_MARLIN_PEN:
        given.append("marlin_pen")
    if not given:
        return ""
    return (f"{', '.join('--' + g.replace('_', '-') for g in given)}: only with --port or --mock "
            f"(a running plotter takes its settings from its nodes' parameters)")


def run_goal_on_graph(args: argparse.Namespace, name: str, action_type, action: str, goal, text: str,
                      out: TextIO = sys.stdout, err: TextIO = sys.stderr) -> int:
    """Send a goal to the plotter running in --namespace and wait for it,
    showing its progress; Ctrl-C cancels it.  `text`: the program, for
    --svg/--png."""
    why = client_refusal(args)
    if why:
        err.write(f"{why}\n")
        return EXIT_BAD_PROGRAM
    from plotter_bridge.nodes.qos import latched
    from plotter_interfaces.msg import BoardState
    from .client import GraphClient, Missing
    svg_out, png_out = getattr(args, "svg", ""), getattr(args, "png", "")
    display = None if args.quiet else ProgressDisplay(name, err, err.isatty())
    with GraphClient(args.namespace) as client:
        recorder = StateRecorder(client.node) if (svg_out or png_out) else None
        prompt = pen_prompt(args, err, lambda: client.trigger("resume"))
        client.node.create_subscription(BoardState, "state", prompt.on_state, latched())
        try:
            start = recorder.start() if recorder else (0.0, 0.0)
            outcome = client.run_goal(action_type, action, goal, display or (lambda fb: None))
        except Missing as exc:
            err.write(f"{name}: {exc}\n")
            return EXIT_FAILED
        except KeyboardInterrupt:
            if display:
                display.close(False)
            err.write(f"{name}: canceled; the pen stopped where it was\n")
            return EXIT_INTERRUPTED
    if display:
        display.close(outcome.status == "succeeded")
    if recorder:
        write_pictures(args, text, name, start, "", recorder.samples, err)
    if outcome.status == "rejected":
        err.write(f"{name}: the plotter rejected the job (its queue is full: see its log)\n")
        return EXIT_FAILED
    r = outcome.result
    if outcome.status == "succeeded":
        out.write(f"{name}: done, pen at X{r.x_mm:.3f} Y{r.y_mm:.3f} mm\n")
        return EXIT_OK
    err.write(f"{name}: {outcome.status}: {r.message}\n")
    if getattr(r, "job_id", ""):
        err.write(f"to finish it from where it stopped: plotter resume {r.job_id}\n")
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
    p.add_argument("resume_id", metavar="JOB_ID", nargs="?", default="",
                   help="id of an interrupted job (see plotter jobs); without it, go on after plotter hold or at "
                        "a pen change")
    connection_args(p)


def run_resume(args: argparse.Namespace) -> int:
    if not args.resume_id:
        if args.port or args.mock:
            sys.stderr.write("plotter resume without JOB_ID acts on a running plotter: no --port or --mock\n")
            return EXIT_BAD_PROGRAM
        return run_trigger("resume", args)
    return run_program_text("", f"job {args.resume_id}", args)


_RESUME = Command("resume", "go on after plotter hold or at a pen change; with JOB_ID, finish an interrupted job "
                            "from its last completed line (from the journal)", _configure_resume, run_resume)


def _configure_jobs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--journal", metavar="DIR", default="",
                   help="job journal directory (default $ROS_HOME/plotter_journal)")


def run_jobs(args: argparse.Namespace, out: TextIO = sys.stdout) -> int:
    from plotter_bridge.link.journal import Journal, default_journal_dir, job_summaries
    for j in job_summaries(Journal(args.journal or default_journal_dir())):
        out.write(f"{j.job_id}  {j.when}  {j.state:<11} {j.completed:>6}/{j.total:<6} {j.name}  {j.note()}\n")
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
        # The topic is in metres (REP-103); people read a plotter in millimetres.
        out.write(f"{s.sec}.{s.nanosec:09d}  X {msg.point.x * 1000:9.3f}  Y {msg.point.y * 1000:9.3f} mm\n")
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


# ---------------------------------------------------------------- state, buttons

def _configure_namespace(p: argparse.ArgumentParser) -> None:
    p.add_argument("--namespace", default="/plotter", help="namespace of the plotter (default /plotter)")


STATE_FIELDS = ("state_name", "x_mm", "y_mm", "z_mm", "x_steps", "y_steps", "pen_down", "position_known",
                "queue_free", "queue_size", "current_line", "lines_done", "last_error", "firmware_version",
                "link_baud")


def run_state(args: argparse.Namespace, out: TextIO = sys.stdout, err: TextIO = sys.stderr) -> int:
    from .client import GraphClient, Missing
    with GraphClient(args.namespace) as client:
        try:
            st = client.state()
        except Missing as exc:
            err.write(f"state: {exc}\n")
            return EXIT_FAILED
    for name in STATE_FIELDS:
        value = getattr(st, name)
        out.write(f"{name}: {value!r}\n" if isinstance(value, str) else f"{name}: {value}\n")
    return EXIT_OK


_STATE = Command("state", "print the board's state once (like ros2 topic echo --once /plotter/state)",
                 _configure_namespace, run_state)

BUTTONS = {"hold": ("hold", "feed hold: the pen stops on its path; plotter resume goes on"),
           "estop": ("estop", "emergency stop: the board stops at once and waits for a reset"),
           "reset": ("reset", "reset the board after an alarm, keeping the position"),
           "set-origin": ("set_origin", "make where the pen is the origin (0, 0)"),
           "home": ("home", "the homing cycle: seek the -X and -Y limit switches, back off, make that the "
                            "origin (serial_bridge's homing:=true)")}
HOME_WAIT_S = 600.0      # s the homing cycle may take: two seeks over the whole table at the slowest feed


def run_trigger(command: str, args: argparse.Namespace, out: TextIO = sys.stdout,
                err: TextIO = sys.stderr) -> int:
    from .client import GraphClient, Missing
    service = BUTTONS[command][0] if command in BUTTONS else command
    with GraphClient(args.namespace) as client:
        try:
            ok, message = client.trigger(service, HOME_WAIT_S) if service == "home" else client.trigger(service)
        except Missing as exc:
            err.write(f"{command}: {exc}\n")
            return EXIT_FAILED
    (out if ok else err).write(f"{command}: {message}\n")
    return EXIT_OK if ok else EXIT_FAILED


def _button(command: str) -> Command:
    return Command(command, BUTTONS[command][1], _configure_namespace,
                   lambda args: run_trigger(command, args))


COMMANDS = (_STREAM, _RESUME, _JOBS, _WATCH, _STATE, *(_button(c) for c in BUTTONS))
