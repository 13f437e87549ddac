"""gcode_streamer: runs G-code programs on the plotter.

Takes programs from the `program` topic (std_msgs/String) and from the
`run_program` action (plotter_interfaces/RunProgram, with progress and
cancel), and runs them one at a time, in the order they arrive, topic and
action alike: a goal that comes while a job runs waits its turn (its
feedback says how many jobs are ahead); past `queue_limit` waiting jobs a
goal is rejected and a topic program dropped, each with a warning.  A goal
cancelled while it waits leaves the queue and never moves the pen.

Each program is parsed and checked against the work area completely before
anything moves; then it is converted to board commands and streamed through
the serial bridge's `stream_commands` action, which keeps the board's queue
full.  A program that cannot run is refused with the reason: for a goal in
its result (aborted), for a topic program on `program_error`, prefixed with
the program's name (its leading comment, which shape_server writes, or
"program"); the node logs every refusal at WARN and every finished job at
INFO with its time.

Every job is journalled (link/journal.py, parameter `journal_dir`) before it is
sent, with the board's progress as the bridge reports it.  Once the bridge
has accepted a job it holds all of it and draws it to the end, whatever
happens to this node: a stall, a lost network or a crash here never cuts a
drawing short.  If the bridge cannot be reached for `bridge_timeout` seconds
the job is reported interrupted, with where it was and the command that
finishes it: a `run_program` goal with `resume` set to the job's id
(`plotter resume ID`) asks the bridge (`job_status`) how far the job got
and finishes it from the first command not completed (or reports it done).

With `z_mode:=axis` (a machine with a third axis, firmware ZAXIS=1) G-code Z
moves that axis, from where the board reports it, inside `z_min`..`z_max`
(gcode/parser.py says in which order with X and Y); `z_mode:=pen`, the default,
keeps Z for the pen.

The `follow_line` action (plotter_interfaces/FollowLine) is line following
on a board built with FOLLOW=1, as a job in the same queue: the pen goes up
to the start as a job of its own (the board starts an `F` only at rest),
then the board's `F` runs as another; the feedback and the result give the
steps, the length followed in mm and why it stopped.  A follow stopped
part-way is not offered a resume: its `F` sent again would start over
from where the pen stands.

Parameters other than the machine's may change while the node runs (`ros2
param set`); a change applies from the next job on.
"""
from __future__ import annotations

import sys
import threading
import time
import traceback
import uuid
from dataclasses import dataclass, replace
from typing import Callable, List, Optional, Tuple, Union

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from std_msgs.msg import String
from unique_identifier_msgs.msg import UUID

from plotter_interfaces.action import FollowLine, RunProgram, StreamCommands
from plotter_interfaces.msg import BoardState
from plotter_interfaces.srv import JobStatus

from plotter_bridge.gcode.dialect import (DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP, DEFAULT_PEN_UP_Z,
                                          DIALECTS, LINUXCNC)
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.parser import program_name
from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.link.follow import (FINISHED, FollowError, FollowTrack, follow_command,
                                        follow_state_name, goal_or_defaults)
from plotter_bridge.link.journal import (DONE, INTERRUPTED, RUNNING, Journal, JobRecord, Progress,
                                         default_journal_dir, resume_commands)
from plotter_bridge.gcode.steps import round_step
from plotter_bridge.link.command_store import CommandStore
from plotter_bridge.link.protocol import MAX_RATE
from plotter_bridge.motion.compiler import MAX_PROGRAM_BYTES, StreamerConfig, compile_program, compile_texts
from plotter_bridge.motion.planner import link_baud
from plotter_bridge.motion.timing import JobPosition, JobProgress

from .action_client import ActionClient
from .jobs import JobQueue, Waker, Worker
from .main import DEFAULT_NAMESPACE, run_node
from .params import (COORDINATE, MACHINE, WORK_AREA, NodeParameters, ParamSpec, check_machine, check_work_area,
                     machine_of, ordered)
from .qos import latched

MAX_NAME_LEN = 200
GOAL_ANSWER_S = 30.0             # s for the bridge to answer a goal (a resume asks it what ran)


@dataclass
class Outcome:
    success: bool
    message: str
    lines_done: int = 0
    job_id: str = ""
    canceled: bool = False
    xy: Optional[Tuple[float, float]] = None    # the pen (mm) when the job ended
    # A job whose every command started, on a board with line sensors: its follow's state and steps at the end.
    follow: Optional[Tuple[int, int]] = None


def _given_up(message, field: str) -> List[str]:
    """A message's program text in a list, the message's own field emptied: run takes it from the
    list, and once it is compiled nothing holds it (a million-line program is 20 MB, its job hours
    long).  Python keeps a call's arguments until the call returns: a list lets it go sooner."""
    text = getattr(message, field)
    setattr(message, field, "")
    return [text]


def check_request(program: str, name: str, resume: str) -> Optional[str]:
    """Why a run_program request is refused before anything else, or None."""
    if len(name) > MAX_NAME_LEN or not name.isprintable():
        return f"bad program name {name[:40]!r}: printable, at most {MAX_NAME_LEN} characters"
    if resume:
        if len(resume) != 32 or any(c not in "0123456789abcdef" for c in resume):
            return f"not a job id: {resume[:40]!r}"
        return None
    size = len(program.encode("utf-8", "surrogateescape"))
    if size > MAX_PROGRAM_BYTES:
        return f"program too large: {size} bytes (limit {MAX_PROGRAM_BYTES})"
    return None


SPECS = (
    ParamSpec("rapid_feed", 6000.0, "G0 travel rate", "mm/min", low=0.0, above=True, high=1e5),
    *WORK_AREA,
    ParamSpec("z_min", -50.0, "z_mode axis: least Z, from the power-on origin", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("z_max", 50.0, "z_mode axis: greatest Z, from the power-on origin", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("acceleration", 1000.0, "largest acceleration (within the firmware's ramp)", "mm/s^2",
              low=0.0, above=True, high=1e5),
    ParamSpec("junction_deviation", 0.05, "corner rule of the look-ahead planner", "mm", low=0.0, high=10.0),
    ParamSpec("lookahead", True, "plan speeds across commands; false stops at every command"),
    ParamSpec("fit_arcs", True, "runs of drawn chords that one arc or line holds within arc_tolerance go to the "
                                "board as that arc or line (gcode/arcfit.py; cartesian machine)"),
    ParamSpec("arc_tolerance", 0.02, "fit_arcs: the fitted path's greatest distance from the chords it replaces",
              "mm", low=0.0, above=True, high=1.0),
    ParamSpec("link_baud", -1, "slow commands shorter than their time on the serial link down to its pace at "
                               "this baud rate (-1: serial_bridge's, 0: off)", "baud", low=-1, high=1_000_000),
    ParamSpec("board_cpu", True, "with link_baud: also slow short commands down to what the board's 8051 parses "
                                 "and plans (motion/planner.py BoardCpu); false: a board that plans in no time"),
    ParamSpec("tolerance", 0.1, "hanging machine: largest pen deviation from the programmed path", "mm",
              low=0.0, above=True, high=10.0),
    ParamSpec("dialect", LINUXCNC, "G-code dialect: linuxcnc, grbl (M3 S power word) or marlin (M300 pen servo, "
                                   "G4 P in ms); a run_program goal may name its own", choices=tuple(DIALECTS)),
    ParamSpec("pen_up_z", DEFAULT_PEN_UP_Z, "z_mode pen: Z above this lifts the pen, at or below lowers it", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("marlin_pen_down", DEFAULT_MARLIN_PEN_DOWN, "dialect marlin: the M300 S angle that lowers the pen",
              "degrees", low=0.0, high=255.0),
    ParamSpec("marlin_pen_up", DEFAULT_MARLIN_PEN_UP, "dialect marlin: the M300 S angle that lifts the pen",
              "degrees", low=0.0, high=255.0),
    ParamSpec("park_pen", True, "at a pen change (M6 after something is drawn, or between an SVG's layers) the "
                                "pen waits at park_x, park_y; false: lifted where it is"),
    ParamSpec("park_x", 0.0, "where the pen waits at a pen change, within the work area", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("park_y", 0.0, "where the pen waits at a pen change, within the work area", "mm",
              low=-COORDINATE, high=COORDINATE),
    *MACHINE,
    ParamSpec("journal_dir", "", "directory of the job journal ('' = $ROS_HOME/plotter_journal)", read_only=True),
    ParamSpec("bridge_timeout", 60.0, "how long a running job waits for a serial bridge that cannot be reached "
                                      "before it is reported interrupted (the bridge goes on drawing it)", "s",
              low=1.0, high=3600.0),
    ParamSpec("queue_limit", 16, "jobs that may wait for their turn; more are refused", "jobs",
              low=1, high=1000, read_only=True),
)


def check_streamer(values) -> Optional[str]:
    if values["marlin_pen_down"] == values["marlin_pen_up"]:
        return f"marlin_pen_down = marlin_pen_up = {values['marlin_pen_up']:g}: the pen angles must differ"
    why = check_work_area(values) or ordered(values, (("z_min", "z_max"),)) or check_machine(values)
    if why is None and values["park_pen"] and not (values["x_min"] <= values["park_x"] <= values["x_max"]
                                                   and values["y_min"] <= values["park_y"] <= values["y_max"]):
        why = (f"park_x, park_y = {values['park_x']:g}, {values['park_y']:g} mm is outside the work area "
               f"X {values['x_min']:g}..{values['x_max']:g}, Y {values['y_min']:g}..{values['y_max']:g}")
    return why


def streamer_config(values) -> StreamerConfig:
    """The compiler's settings from the node's parameter values."""
    machine = machine_of(values)
    names = ("rapid_feed", "x_min", "x_max", "y_min", "y_max", "z_min", "z_max", "acceleration",
             "junction_deviation", "tolerance", "pen_up_z", "marlin_pen_down", "marlin_pen_up")
    v = {k: float(values[k]) for k in names}
    return StreamerConfig(machine.steps_per_mm, v["rapid_feed"],
                          WorkArea(v["x_min"], v["x_max"], v["y_min"], v["y_max"], v["z_min"], v["z_max"]),
                          v["acceleration"], v["junction_deviation"], bool(values["lookahead"]),
                          machine.kind, machine.hanging, v["tolerance"],
                          z_mode=machine.z_mode, z_steps_per_mm=machine.z_steps_per_mm,
                          dialect=str(values["dialect"]), pen_up_z=v["pen_up_z"],
                          marlin_pen_down=v["marlin_pen_down"], marlin_pen_up=v["marlin_pen_up"],
                          fit_arcs=bool(values["fit_arcs"]), arc_tolerance=float(values["arc_tolerance"]),
                          board_cpu=bool(values["board_cpu"]),
                          park=(float(values["park_x"]), float(values["park_y"])) if values["park_pen"] else None)


class GCodeStreamer(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("gcode_streamer", namespace=namespace, **kwargs)
        self.params = NodeParameters(self, SPECS, cross=check_streamer, on_change=self._apply)
        self.machine = machine_of(self.params.values())
        self.config = streamer_config(self.params.values())
        self.journal = Journal(str(self.params["journal_dir"]) or default_journal_dir())
        group = ReentrantCallbackGroup()
        self._waker = Waker(self)
        self._worker = Worker("gcode-job")
        self._queue = JobQueue(int(self.params["queue_limit"]))
        self.pub_error = self.create_publisher(String, "program_error", 10)
        self.create_subscription(String, "program", self._on_program, 10, callback_group=group)
        self._bridge = ActionClient(self, StreamCommands, "stream_commands", callback_group=group)
        self._job_status = self.create_client(JobStatus, "job_status", callback_group=group)
        # Goals are answered one at a time, in the order they come (a mutually
        # exclusive group), and take their place in the queue as they are accepted.
        in_order = MutuallyExclusiveCallbackGroup()
        self._server = ActionServer(self, RunProgram, "run_program", self._execute,
                                    goal_callback=self._on_goal, cancel_callback=self._on_cancel,
                                    handle_accepted_callback=self._on_accepted, callback_group=in_order)
        self._follow_server = ActionServer(self, FollowLine, "follow_line", self._execute_follow,
                                           goal_callback=self._on_goal, cancel_callback=self._on_cancel,
                                           handle_accepted_callback=self._on_accepted, callback_group=in_order)
        self._board: Optional[BoardState] = None
        self._board_changed = threading.Condition()
        self.create_subscription(BoardState, "state", self._on_state, latched(), callback_group=group)
        self._position = JobPosition()

    def _apply(self, names) -> None:
        self.config = streamer_config(self.params.values())
        self.get_logger().info("parameters applied from the next job on: "
                               + ", ".join(f"{n} = {self.params[n]}" for n in names))

    def _on_state(self, msg: BoardState) -> None:
        with self._board_changed:
            self._board = msg
            self._board_changed.notify_all()

    def _board_state(self, timeout: float = 5.0) -> Optional[BoardState]:
        """The bridge's latest state, after waiting a little for a connected
        one (None if it has published none)."""
        with self._board_changed:
            self._board_changed.wait_for(
                lambda: self._board is not None and self._board.state != BoardState.DISCONNECTED, timeout)
            return self._board

    def _refused(self, name: str, why: str) -> None:
        self.get_logger().warn(f"{name}: refused: {why}")

    # --- one job at a time ---------------------------------------------------------
    async def _run_in_turn(self, key, name: str, goal_handle, job: Callable[[], Outcome]) -> Outcome:
        """Wait for the job's turn, then run it on the worker thread."""
        if goal_handle is not None and goal_handle.is_cancel_requested:
            self._queue.give_up(key)                # withdrawn before it started: not entered again
            return Outcome(False, "canceled before it ran", canceled=True)
        turn = self._queue.enter(key)              # a goal's place since it was accepted
        self._tell_waiting()
        if not await self._waker.wait(turn):
            return Outcome(False, "canceled before it ran", canceled=True)
        try:
            if goal_handle is not None and goal_handle.is_cancel_requested:
                return Outcome(False, "canceled before it ran", canceled=True)
            return await self._waker.wait(self._worker.run(self._timed_run, name, job))
        except Exception as exc:  # a bug must not leave the job without an outcome
            self.get_logger().error(f"{name}: internal error: {exc!r}\n{traceback.format_exc()}")
            return Outcome(False, f"internal error: {exc}")
        finally:
            self._queue.leave(key)
            self._tell_waiting()

    def _tell_waiting(self) -> None:
        """Feedback to the goals that wait: how many jobs are ahead of each."""
        for key in self._queue.waiting():
            if isinstance(key, ServerGoalHandle) and key.is_active:
                kind = FollowLine if isinstance(key.request, FollowLine.Goal) else RunProgram
                key.publish_feedback(kind.Feedback(jobs_ahead=self._queue.ahead(key)))

    def _timed_run(self, name: str, job: Callable[[], Outcome]) -> Outcome:
        t0 = time.monotonic()
        # The position is taken here, on the worker, before it can start the next job.
        out = replace(job(), xy=self._position.xy)
        if out.success:
            self.get_logger().info(f"{name}: {out.message} in {time.monotonic() - t0:.1f} s")
        elif out.canceled:
            self.get_logger().info(f"{name}: canceled after {time.monotonic() - t0:.1f} s")
        else:
            self._refused(name, out.message)
        return out

    # --- programs from the topic ---------------------------------------------
    async def _on_program(self, msg: String) -> None:
        name = program_name(msg.data)
        why = check_request(msg.data, name, "")
        if why is None and self._queue.full():
            why = f"{self._queue.limit} jobs already waiting: program dropped"
        if why is None:
            text = _given_up(msg, "data")
            out = await self._run_in_turn(object(), name, None, lambda: self.run(text, name, None))
            why = None if out.success else out.message
        elif why:
            self._refused(name, why)
        if why:
            self.pub_error.publish(String(data=f"{name}: {why}"))

    # --- the action ------------------------------------------------------------
    def _on_accepted(self, goal_handle) -> None:
        """The goal's place in the queue, taken in the order goals are answered: its execute callback
        starts as an executor task, and a multi-threaded executor starts tasks in any order."""
        self._queue.enter(goal_handle)
        goal_handle.execute()

    def _on_goal(self, goal) -> GoalResponse:
        if self._queue.full():
            self.get_logger().warn(f"run_program goal {goal.name or 'program'!r} rejected: "
                                   f"{self._queue.limit} jobs already waiting")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle) -> CancelResponse:
        self._queue.withdraw(goal_handle)      # if it waits; a running job sees the request itself
        return CancelResponse.ACCEPT

    async def _execute(self, goal_handle):
        req = goal_handle.request
        name = req.name or program_name(req.program)
        why = check_request(req.program, name, req.resume)
        if why is None and req.dialect and req.dialect not in DIALECTS:
            why = f"unknown G-code dialect {req.dialect[:20]!r}: one of {', '.join(DIALECTS)}"
        if why:
            self._refused(name, why)
            self._queue.give_up(goal_handle)       # refused: it leaves the queue without running
            self._tell_waiting()
            out = Outcome(False, why)
        else:
            text = _given_up(req, "program")
            out = await self._run_in_turn(goal_handle, name, goal_handle,
                                          lambda: self.run(text, name, goal_handle, req.resume, req.dialect))
        result = RunProgram.Result()
        result.success, result.message, result.lines_done = out.success, out.message, out.lines_done
        result.job_id = out.job_id
        result.x_mm, result.y_mm = out.xy if out.xy is not None else self._position.xy
        end_goal(goal_handle, out.success)
        return result

    # --- follow_line -----------------------------------------------------------
    async def _execute_follow(self, goal_handle):
        req = goal_handle.request
        where = "where the pen is" if req.from_here else f"X{req.start_x_mm:g} Y{req.start_y_mm:g}"
        name = f"follow from {where}"
        track, edge = FollowTrack(), []
        out = await self._run_in_turn(goal_handle, name, goal_handle,
                                      lambda: self.run_follow(req, goal_handle, track, edge))
        result = FollowLine.Result()
        result.x_mm, result.y_mm = out.xy if out.xy is not None else self._position.xy
        result.job_id, result.message = out.job_id, out.message
        if out.follow is not None:
            state, steps = out.follow
            track.end(steps, (result.x_mm, result.y_mm))
            result.reason = follow_state_name(state)
            if edge:
                result.reason, result.message = "limit", f"{edge[0]}; stopped after {steps} steps"
            result.success = out.success and result.reason in FINISHED
            if out.success:
                result.message = (f"{result.reason} after {steps} steps ({track.length_mm:.1f} mm), pen at "
                                  f"X{result.x_mm:.3f} Y{result.y_mm:.3f} mm")
                if result.success:
                    self.get_logger().info(f"{name}: {result.message}")
                else:
                    self._refused(name, result.message)
        elif edge:
            result.reason, result.message = "limit", edge[0]
        else:
            result.reason = "canceled" if out.canceled else "not run"
        result.steps, result.length_mm = track.steps, track.length_mm
        end_goal(goal_handle, result.success)
        return result

    def run_follow(self, req, goal_handle, track: FollowTrack, edge: List[str]) -> Outcome:
        """A follow_line goal as a job: the pen up to the start, then the board's F (on the worker thread).
        The board steers where the line goes: a pen reported beyond the work area stops it (why in edge)."""
        board = self._board_state()
        why = board_refusal(board)
        if why:
            return Outcome(False, why)
        if not board.has_sensors:
            return Outcome(False, "the board reports no line sensors: line following needs the firmware built "
                                  "with FOLLOW=1 (or the mock board with a sheet)")
        if self.machine.kind != "cartesian":
            return Outcome(False, f"line following runs on the XY table only, not the {self.machine.kind} "
                                  f"machine: its sensors' directions are the motors' axes")
        problems: List[str] = []
        goal = goal_or_defaults(req.heading_deg, req.feed_mm_s, req.lost_mm, req.distance_mm, req.gate_mm)
        try:
            command = follow_command(goal, self.machine.steps_per_mm)
        except FollowError as exc:
            problems.append(str(exc))
        texts: List[str] = []
        spm = self.machine.steps_per_mm
        start_steps = (round_step(req.start_x_mm * spm), round_step(req.start_y_mm * spm))
        at_start = (board.x_steps, board.y_steps) == start_steps
        if not req.from_here and not at_start:      # (a pen already there has no way to go)
            start = f"G21 G90\nG0 X{req.start_x_mm:.4f} Y{req.start_y_mm:.4f}\n"
            try:
                moves = compile_program(start, self._job_config(board), (board.x_steps, board.y_steps),
                                        board.z_steps)
                texts = [c.text for c in moves]
            except GCodeError as exc:
                problems.append(f"start X{req.start_x_mm:g} Y{req.start_y_mm:g}: {exc}")
        if problems:
            return Outcome(False, "; ".join(problems))

        area = self.config.area

        def publish(fb) -> None:
            track.add(fb.follow_state, fb.followed_steps, (fb.x_mm, fb.y_mm))
            if track.began and not edge and not area.contains(fb.x_mm, fb.y_mm):
                edge.append(f"the pen left the work area ({area.describe()}) at X{fb.x_mm:.3f} Y{fb.y_mm:.3f} mm")
            goal_handle.publish_feedback(FollowLine.Feedback(steps=track.steps, length_mm=track.length_mm,
                                                             sensors=fb.sensors, x_mm=fb.x_mm, y_mm=fb.y_mm))
        if texts:
            # A job of its own: the board starts an F only at rest, not behind a move (E10).
            to_start = self._record(f"to the start of a follow, X{req.start_x_mm:g} Y{req.start_y_mm:g}",
                                    texts, [1] * len(texts), board)
            moved = self._stream(to_start, goal_handle, publish)
            if not moved.success:
                return replace(moved, message=f"the pen did not reach the start: {moved.message}")
            if goal_handle.is_cancel_requested:
                return Outcome(False, "canceled at the start", 0, moved.job_id, canceled=True)
            board = self._board_state() or board
        # A follow stopped part-way is not finished by sending its F again: the start gate would move.
        return self._stream(self._record("follow", [command], [1], board), goal_handle, publish, resumable=False,
                            stop=lambda: bool(edge))

    def run(self, text: Union[str, List[str]], name: str, goal_handle, resume: str = "",
            dialect: str = "") -> Outcome:
        """Run one program, or resume a journalled job (on the worker thread:
        it waits for the board).  The program may come in a list (_given_up), which gives it up
        once it is compiled."""
        if isinstance(text, list):
            text = text.pop() if text else ""
        board = self._board_state()
        why = board_refusal(board)
        if why:
            return Outcome(False, why)
        start = (board.x_steps, board.y_steps)
        if resume:
            return self._resume(resume, board, goal_handle)
        t0 = time.monotonic()
        try:
            job = compile_texts(text, self._job_config(board, dialect), start, board.z_steps)
        except GCodeError as exc:
            return Outcome(False, str(exc))
        del text                    # the job runs for hours on its commands alone
        # said for every job: the time to the first step of a big one is mostly this
        self.get_logger().info(f"{name}: checked and planned, {len(job.texts)} board commands in "
                               f"{time.monotonic() - t0:.1f} s")
        if not job.texts:
            return Outcome(True, "nothing to do")
        if job.z_line is not None and not board.has_z:
            return Outcome(False, f"line {job.z_line}: a Z move, and the board reports no Z axis "
                                  f"(firmware built without ZAXIS=1)")
        record = self._record(name, job.texts, job.lines, board, job.pens)
        return self._stream(record, goal_handle, self._program_feedback(record, goal_handle))

    def _job_config(self, board: BoardState, dialect: str = "") -> StreamerConfig:
        """The compiler's settings for a job on this board now."""
        return replace(self.config, dialect=dialect or self.config.dialect, link_seq=board.next_seq,
                       link_baud=link_baud(int(self.params["link_baud"]), board.link_baud))

    def _record(self, name: str, commands: List[str], lines: List[int], board: BoardState,
                pens: Optional[List[str]] = None) -> JobRecord:
        rapid = int(min(MAX_RATE, self.config.rapid_feed / 60.0 * self.config.motor_steps_per_mm()))
        return JobRecord(uuid.uuid4().hex, name, commands, lines, (board.x_steps, board.y_steps),
                         bool(board.pen_down), rapid, board.z_steps if board.has_z else None, self.machine.text(),
                         list(pens or []))

    def _program_feedback(self, record: JobRecord, goal_handle) -> Optional[Callable[[object], None]]:
        """run_program's feedback from the bridge's: the line, the share done and the time left."""
        if goal_handle is None:
            return None
        # A million commands take seconds to model: it is built once the bridge runs the job (its
        # first feedback), beside it, and the feedback goes on from when it is there.
        model: List[JobProgress] = []
        begun = threading.Lock()
        total_lines = max(record.lines, default=0)

        def publish(fb) -> None:
            if begun.acquire(blocking=False):
                threading.Thread(target=lambda: model.append(self._timing(record)), name="job timing",
                                 daemon=True).start()
            if not model:
                return
            timing = model[0]
            out = RunProgram.Feedback()
            out.current_line = fb.current_line
            out.total_lines = total_lines
            out.progress, out.seconds_left = timing.update(int(fb.executed), time.monotonic())
            out.x_mm, out.y_mm = fb.x_mm, fb.y_mm
            goal_handle.publish_feedback(out)
        return publish

    def _resume(self, job_id: str, board: BoardState, goal_handle) -> Outcome:
        try:
            record, progress = self.journal.load(job_id)
        except (KeyError, ValueError) as exc:
            return Outcome(False, str(exc).strip("'\""))
        if progress.resumed_by:
            return Outcome(False, f"job {job_id} was already resumed as {progress.resumed_by}")
        completed = progress.completed
        status = self._bridge_job(job_id)
        if (status is not None and status.known and status.success) or progress.state == DONE:
            self.journal.update(job_id, Progress(len(record.commands), DONE, "done"))
            return Outcome(True, "already done", record.lines[-1] if record.lines else 0, job_id)
        if status is not None and status.running:
            return Outcome(False, f"job {job_id} is still running on the bridge")
        if status is not None and status.known:
            completed = max(completed, int(status.completed))
        z_at = board.z_steps if board.has_z else None
        commands, lines = resume_commands(record, completed, (board.x_steps, board.y_steps), bool(board.pen_down),
                                          z_at)
        new = JobRecord(uuid.uuid4().hex, f"{record.name} (resumed)", commands, lines,
                        (board.x_steps, board.y_steps), bool(board.pen_down), record.rapid_rate, z_at,
                        record.machine, record.pens)
        self.journal.update(job_id, Progress(completed, INTERRUPTED, progress.message, new.job_id))
        line = record.lines[completed] if completed < len(record.lines) else 0
        self.get_logger().info(f"resuming {record.name} at command {completed + 1} of "
                               f"{len(record.commands)} (line {line}) as job {new.job_id}")
        return self._stream(new, goal_handle, self._program_feedback(new, goal_handle))

    def _bridge_job(self, job_id: str) -> Optional[JobStatus.Response]:
        """What the bridge knows of one of its jobs, after waiting a little for
        it to end if it still runs; None if the bridge does not answer."""
        if not self._job_status.wait_for_service(timeout_sec=5.0):
            return None
        deadline = time.monotonic() + 5.0
        while True:
            future = self._job_status.call_async(JobStatus.Request(job_id=job_id))
            if not _wait(future, 5.0):
                return None
            status = future.result()
            if not status.running or time.monotonic() > deadline:
                return status
            time.sleep(0.2)

    def _stream(self, record: JobRecord, goal_handle, publish: Optional[Callable[[object], None]] = None,
                resumable: bool = True, stop: Callable[[], bool] = lambda: False) -> Outcome:
        """Stream a journalled job through the bridge; publish(the bridge's feedback) as it runs; cancel it
        as the goal's cancel does once stop() is true.  A job stopped part-way says how to finish it if it is
        resumable."""
        job_id = record.job_id
        self.journal.create(record)
        total_lines = max(record.lines, default=0)
        if not self._bridge.wait_for_server(timeout_sec=10.0):
            self.journal.update(job_id, Progress(0, INTERRUPTED, "serial bridge not available"))
            return Outcome(False, "serial bridge not available (stream_commands)", 0, job_id)
        goal = StreamCommands.Goal()
        if isinstance(record.commands, CommandStore):
            goal.command_text = record.commands.text
        else:
            goal.commands = list(record.commands)
        goal.lines = record.lines
        goal.machine = record.machine
        goal.pen_changes = record.pens
        progress = Progress()

        # This job's own: a late feedback of an earlier job cannot touch it.
        position = self._position = JobPosition(self._position.xy)

        def relay(fb_msg):
            fb = fb_msg.feedback
            position.feedback((fb.x_mm, fb.y_mm))
            progress.completed = max(progress.completed, int(fb.executed) - 1)
            if publish is not None:
                publish(fb)

        send = self._bridge.send_goal_async(goal, feedback_callback=relay,
                                            goal_uuid=UUID(uuid=list(bytes.fromhex(job_id))))
        if not _wait(send, GOAL_ANSWER_S):
            # The bridge may have taken the job and be drawing it: say how to find out.
            why = (f"serial bridge did not answer in {GOAL_ANSWER_S:g} s; if it took the job it draws it: "
                   f"plotter resume {job_id} finishes it or reports it done")
            self.journal.update(job_id, Progress(0, INTERRUPTED, why))
            return Outcome(False, why, 0, job_id)
        inner = send.result()
        if not inner.accepted:
            self.journal.update(job_id, Progress(0, INTERRUPTED, "serial bridge refused the job"))
            return Outcome(False, "serial bridge refused the job (busy, disconnected or bad commands)", 0, job_id)
        res_future = inner.get_result_async()
        journalled = -1
        bridge_seen = time.monotonic()
        bridge_timeout = float(self.params["bridge_timeout"])
        while not res_future.done():
            if not self.context.ok():               # the node is stopping; the bridge draws on
                return Outcome(False, f"the streamer stopped; the bridge goes on with the job: plotter resume "
                                      f"{job_id} finishes it or reports it done", 0, job_id)
            if (goal_handle is not None and goal_handle.is_cancel_requested) or stop():
                inner.cancel_goal_async()
                _wait(res_future, 10.0)
                break
            _wait(res_future, 0.05)
            now = time.monotonic()
            if self._bridge.server_is_ready():
                bridge_seen = now
            elif now - bridge_seen > bridge_timeout:
                why = (f"the serial bridge could not be reached for {bridge_timeout:g} s, after command "
                       f"{progress.completed} of {len(record.commands)}; if it still runs it draws the job on: "
                       f"plotter resume {job_id} finishes it or reports it done")
                self.journal.update(job_id, Progress(progress.completed, INTERRUPTED, why))
                return Outcome(False, why, 0, job_id)
            if progress.completed != journalled:
                self.journal.update(job_id, Progress(progress.completed, RUNNING))
                journalled = progress.completed
        res = res_future.result().result if res_future.done() else None
        if res is None:
            return Outcome(False, "canceled", 0, job_id, canceled=True)
        position.result((res.x_mm, res.y_mm))
        completed = len(record.commands) if res.success else int(res.completed)
        self.journal.update(job_id, Progress(completed, DONE if res.success else INTERRUPTED, res.message))
        lines_done = record.lines[completed - 1] if completed else 0
        follow = (int(res.follow_state), int(res.followed_steps)) if res.executed >= len(record.commands) else None
        if res.success:
            return Outcome(True, "done", total_lines, job_id, follow=follow)
        if goal_handle is not None and goal_handle.is_cancel_requested:
            return Outcome(False, "canceled", lines_done, job_id, canceled=True, follow=follow)
        why = stopped_message(res.message, completed, record, job_id) if resumable else res.message
        return Outcome(False, why, lines_done, job_id, follow=follow)

    def _timing(self, record: JobRecord) -> JobProgress:
        """The job's progress model: the pen's path and the plan's time per command."""
        return JobProgress.of_commands(record.commands, record.start, self.machine.pen_mm, self.machine.steps_per_mm)

    def destroy_node(self) -> None:
        self._worker.shutdown()
        super().destroy_node()


def end_goal(goal_handle, success: bool) -> None:
    """The goal's end state: canceled if a cancel was asked and it did not succeed."""
    if goal_handle.is_cancel_requested and not success:
        goal_handle.canceled()
    elif success:
        goal_handle.succeed()
    else:
        goal_handle.abort()


def board_refusal(board: Optional[BoardState]) -> Optional[str]:
    """Why no job can start on the board as the bridge last reported it, or None."""
    if board is None:
        return "board not connected (no state from serial_bridge)"
    if board.state == BoardState.DISCONNECTED:
        return "board not connected" + (f": {board.last_error}" if board.last_error else "")
    if not board.position_known:
        return "position unknown after a board reset: call set_origin first"
    return None


def stopped_message(why: str, completed: int, record: JobRecord, job_id: str) -> str:
    """A job that ended part-way: why, where, and how to finish it (a
    board reset loses the position, so no resume is offered then)."""
    total = len(record.commands)
    line = record.lines[completed - 1] if completed else 0
    where = f"stopped after command {completed} of {total}" + (f" (line {line})" if line else "")
    if "position is unknown" in why:
        return f"{why}; {where}"
    return f"{why}; {where}: plotter resume {job_id} finishes it"


def _wait(future, timeout: float) -> bool:
    event = threading.Event()
    future.add_done_callback(lambda _: event.set())
    return event.wait(timeout) or future.done()


def main(args=None) -> int:
    return run_node(GCodeStreamer, "gcode_streamer", args)


if __name__ == "__main__":
    sys.exit(main())
