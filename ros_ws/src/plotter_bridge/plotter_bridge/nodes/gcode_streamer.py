"""gcode_streamer: runs G-code programs on the plotter.

Takes programs from the `program` topic (std_msgs/String; run one after the
other) and from the `run_program` action (plotter_interfaces/RunProgram,
with progress and cancel).  Each program is parsed and checked against the
work area completely before anything moves; then it is converted to board
commands and streamed through the serial bridge's `stream_commands` action,
which keeps the board's queue full.

Every job is journalled (link/journal.py, parameter `journal_dir`) before it is
sent, with the board's progress as the bridge reports it.  The streamer
renews the job's lease on `job_lease` while it runs; if the streamer dies the
lease runs out and the bridge stops the job at a command boundary.  A
`run_program` goal with `resume` set to the job's id (`plotter resume ID`)
then finishes it from the first command not completed.

With `z_mode:=axis` (a machine with a third axis, firmware ZAXIS=1) G-code Z
moves that axis, from where the board reports it, inside `z_min`..`z_max`
(gcode/parser.py says in which order with X and Y); `z_mode:=pen`, the default,
keeps Z for the pen.

Inputs are checked before anything moves: an oversized or malformed program,
a bad name or an unknown job id is refused with the reason (an aborted goal,
or a message on `program_error` for the topic), and the node goes on.
"""
from __future__ import annotations

import math
import queue
import sys
import threading
import time
import uuid
from dataclasses import dataclass, replace
from typing import Optional, Tuple

from action_msgs.msg import GoalStatus
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.action.client import ClientGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from std_msgs.msg import String
from unique_identifier_msgs.msg import UUID

from plotter_interfaces.action import RunProgram, StreamCommands
from plotter_interfaces.msg import BoardState

from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.link.journal import (DONE, INTERRUPTED, RUNNING, Journal, JobRecord, Progress,
                                         default_journal_dir, resume_commands)
from plotter_bridge.link.protocol import MAX_RATE
from plotter_bridge.motion.compiler import MAX_PROGRAM_BYTES, StreamerConfig, compile_program
from plotter_bridge.motion.planner import link_baud

from .main import run_node
from .params import declare_machine
from .qos import latched

DEFAULT_NAMESPACE = "/plotter"   # `-r __ns:=/plotter2` runs a second plotter beside it
MAX_NAME_LEN = 200
TOPIC_QUEUE = 8                  # programs from the topic waiting their turn


@dataclass
class Outcome:
    success: bool
    message: str
    lines_done: int = 0
    job_id: str = ""


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


class GCodeStreamer(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("gcode_streamer", namespace=namespace, **kwargs)
        d = ParameterDescriptor
        self.declare_parameter("rapid_feed", 6000.0, d(description="G0 travel rate, mm/min"))
        self.declare_parameter("x_min", 0.0, d(description="work area, mm from the power-on origin"))
        self.declare_parameter("x_max", 200.0, d(description="work area, mm"))
        self.declare_parameter("y_min", 0.0, d(description="work area, mm"))
        self.declare_parameter("y_max", 200.0, d(description="work area, mm"))
        self.declare_parameter("z_min", -50.0, d(description="z_mode axis: travel of Z, mm from the power-on origin"))
        self.declare_parameter("z_max", 50.0, d(description="z_mode axis: travel of Z, mm"))
        self.declare_parameter("acceleration", 1000.0, d(description="maximum acceleration, mm/s^2 (within the firmware's ramp)"))
        self.declare_parameter("junction_deviation", 0.05, d(description="corner rule of the look-ahead planner, mm"))
        self.declare_parameter("lookahead", True, d(description="plan speeds across commands; false stops at every command"))
        self.declare_parameter("link_baud", -1, d(description="slow commands shorter than their time on the serial link "
                                                          "down to its pace (planner.cap_for_link) at this baud rate; "
                                                          "-1: serial_bridge's, 0: off"))
        self.declare_parameter("tolerance", 0.1, d(description="hanging machine: largest pen deviation from the programmed path, mm"))
        self.declare_parameter("dialect", "linuxcnc", d(description="G-code dialect: linuxcnc, grbl (M3 S power word) or "
                                                               "marlin (M300 pen servo, G4 P in ms)"))
        self.declare_parameter("pen_up_z", 0.0, d(description="z_mode pen: Z above this lifts the pen, at or below lowers it, mm"))
        self.declare_parameter("marlin_pen_down", 30.0, d(description="dialect marlin: the M300 S angle that lowers the pen"))
        self.declare_parameter("marlin_pen_up", 50.0, d(description="dialect marlin: the M300 S angle that lifts the pen"))
        self.machine = declare_machine(self)
        self.declare_parameter("journal_dir", "", d(description="directory of the job journal ('' = $ROS_HOME/plotter_journal)"))
        self.declare_parameter("lease", 2.0, d(description="seconds the bridge goes on with a job after this node stops renewing it"))
        self.config = self._read_config()
        self.lease = float(self.get_parameter("lease").value)
        if not (math.isfinite(self.lease) and 0.1 <= self.lease <= 3600.0):
            raise ValueError("lease must be 0.1..3600 s")
        self.journal = Journal(str(self.get_parameter("journal_dir").value) or default_journal_dir())
        group = ReentrantCallbackGroup()
        self.pub_error = self.create_publisher(String, "program_error", 10)
        self.create_subscription(String, "program", self._on_program, 10, callback_group=group)
        self._bridge = ActionClient(self, StreamCommands, "stream_commands", callback_group=group)
        self._server = ActionServer(self, RunProgram, "run_program", self._execute,
                                    goal_callback=lambda _: GoalResponse.ACCEPT,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=group)
        self._board: Optional[BoardState] = None
        self._board_changed = threading.Condition()
        self.create_subscription(BoardState, "state", self._on_state, latched(), callback_group=group)
        self._busy = threading.Lock()      # one program on the board at a time
        self._last_xy = (0.0, 0.0)
        self.pub_lease = self.create_publisher(String, "job_lease", 10)
        self._topic_jobs: "queue.Queue[str]" = queue.Queue(TOPIC_QUEUE)
        self._worker = threading.Thread(target=self._topic_worker, daemon=True)
        self._worker.start()

    def _read_config(self) -> StreamerConfig:
        g = lambda n: float(self.get_parameter(n).value)  # noqa: E731
        names = ("steps_per_mm", "rapid_feed", "x_min", "x_max", "y_min", "y_max", "z_min", "z_max",
                 "acceleration", "junction_deviation", "tolerance", "pen_up_z", "marlin_pen_down", "marlin_pen_up")
        v = dict(zip(names, (g(n) for n in names)))
        if not all(math.isfinite(x) for x in v.values()) or v["steps_per_mm"] <= 0 or v["rapid_feed"] <= 0 \
                or v["x_min"] >= v["x_max"] or v["y_min"] >= v["y_max"] or v["z_min"] >= v["z_max"] \
                or v["acceleration"] <= 0 or v["junction_deviation"] < 0 or v["tolerance"] <= 0:
            raise ValueError(f"bad gcode_streamer parameters: {v}")
        return StreamerConfig(v["steps_per_mm"], v["rapid_feed"],
                              WorkArea(v["x_min"], v["x_max"], v["y_min"], v["y_max"], v["z_min"], v["z_max"]),
                              v["acceleration"], v["junction_deviation"],
                              bool(self.get_parameter("lookahead").value),
                              self.machine.kind, self.machine.hanging, v["tolerance"],
                              z_mode=self.machine.z_mode, z_steps_per_mm=self.machine.z_steps_per_mm,
                              dialect=str(self.get_parameter("dialect").value), pen_up_z=v["pen_up_z"],
                              marlin_pen_down=v["marlin_pen_down"], marlin_pen_up=v["marlin_pen_up"])

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

    # --- programs from the topic ---------------------------------------------
    def _on_program(self, msg: String) -> None:
        why = check_request(msg.data, "topic", "")
        if why is None:
            try:
                self._topic_jobs.put_nowait(msg.data)
            except queue.Full:
                why = f"{TOPIC_QUEUE} programs already waiting: program dropped"
        if why:
            self.get_logger().error(f"program refused: {why}")
            self.pub_error.publish(String(data=why))

    def _topic_worker(self) -> None:
        while self.context.ok():
            try:
                text = self._topic_jobs.get(timeout=0.5)
            except queue.Empty:
                continue
            try:
                out = self.run(text, "topic", None)
            except Exception as exc:  # a bad program must never stop the worker
                out = Outcome(False, f"internal error: {exc}")
            if not out.success:
                self.pub_error.publish(String(data=out.message))

    # --- the action ------------------------------------------------------------
    def _execute(self, goal_handle):
        req = goal_handle.request
        name = req.name or "program"
        why = check_request(req.program, name, req.resume)
        try:
            out = Outcome(False, why) if why else self.run(req.program, name, goal_handle, req.resume)
        except Exception as exc:  # never leave a goal hanging
            self.get_logger().error(f"{name}: internal error: {exc}")
            out = Outcome(False, f"internal error: {exc}")
        if not out.success:
            self.get_logger().error(out.message)
        result = RunProgram.Result()
        result.success, result.message, result.lines_done = out.success, out.message, out.lines_done
        result.job_id = out.job_id
        result.x_mm, result.y_mm = self._last_xy
        if goal_handle.is_cancel_requested and not out.success:
            goal_handle.canceled()
        elif out.success:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    def run(self, text: str, name: str, goal_handle, resume: str = "") -> Outcome:
        """Run one program, or resume a journalled job."""
        with self._busy:
            board = self._board_state()
            if board is None or board.state == BoardState.DISCONNECTED:
                return Outcome(False, "board not connected (no state from serial_bridge)")
            if not board.position_known:
                return Outcome(False, "position unknown after a board reset: call set_origin first")
            start = (board.x_steps, board.y_steps)
            if resume:
                return self._resume(resume, board, goal_handle)
            try:
                config = replace(self.config, link_seq=board.next_seq,
                                 link_baud=link_baud(int(self.get_parameter("link_baud").value), board.link_baud))
                commands = compile_program(text, config, start, board.z_steps)
            except GCodeError as exc:
                return Outcome(False, str(exc))
            if not commands:
                return Outcome(True, "nothing to do")
            z_line = next((c.line for c in commands if c.verb == "Z"), None)
            if z_line is not None and not board.has_z:
                return Outcome(False, f"line {z_line}: a Z move, and the board reports no Z axis "
                                      f"(firmware built without ZAXIS=1)")
            rapid = int(min(MAX_RATE, self.config.rapid_feed / 60.0 * self.config.motor_steps_per_mm()))
            record = JobRecord(uuid.uuid4().hex, name, [c.text for c in commands], [c.line for c in commands],
                               start, bool(board.pen_down), rapid, board.z_steps if board.has_z else None)
            return self._stream(record, goal_handle)

    def _resume(self, job_id: str, board: BoardState, goal_handle) -> Outcome:
        try:
            record, progress = self.journal.load(job_id)
        except (KeyError, ValueError) as exc:
            return Outcome(False, str(exc).strip("'\""))
        if progress.resumed_by:
            return Outcome(False, f"job {job_id} was already resumed as {progress.resumed_by}")
        completed = progress.completed
        status, result = self._bridge_result(job_id)
        if status == GoalStatus.STATUS_SUCCEEDED or progress.state == DONE:
            self.journal.update(job_id, Progress(len(record.commands), DONE, "done"))
            return Outcome(True, f"{record.name}: already done", record.lines[-1] if record.lines else 0, job_id)
        if status in (GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED):
            completed = max(completed, int(result.completed))
        elif status != GoalStatus.STATUS_UNKNOWN:
            return Outcome(False, f"job {job_id} is still running on the bridge")
        z_at = board.z_steps if board.has_z else None
        commands, lines = resume_commands(record, completed, (board.x_steps, board.y_steps), bool(board.pen_down),
                                          z_at)
        new = JobRecord(uuid.uuid4().hex, f"{record.name} (resumed)", commands, lines,
                        (board.x_steps, board.y_steps), bool(board.pen_down), record.rapid_rate, z_at)
        self.journal.update(job_id, Progress(completed, INTERRUPTED, progress.message, new.job_id))
        line = record.lines[completed] if completed < len(record.lines) else 0
        self.get_logger().info(f"resuming {record.name} at command {completed + 1} of "
                               f"{len(record.commands)} (line {line}) as job {new.job_id}")
        return self._stream(new, goal_handle)

    def _bridge_result(self, job_id: str) -> Tuple[int, Optional[StreamCommands.Result]]:
        """What the bridge says about one of its goals (kept for a while after it ends)."""
        if not self._bridge.wait_for_server(timeout_sec=5.0):
            return GoalStatus.STATUS_UNKNOWN, None
        accepted = StreamCommands.Impl.SendGoalService.Response(accepted=True)
        handle = ClientGoalHandle(self._bridge, UUID(uuid=list(bytes.fromhex(job_id))), accepted)
        future = handle.get_result_async()
        if not _wait(future, 5.0 + self.lease * 2):
            return GoalStatus.STATUS_UNKNOWN, None
        res = future.result()
        return res.status, res.result

    def _stream(self, record: JobRecord, goal_handle) -> Outcome:
        job_id = record.job_id
        self.journal.create(record)
        total_lines = max(record.lines, default=0)
        if not self._bridge.wait_for_server(timeout_sec=10.0):
            self.journal.update(job_id, Progress(0, INTERRUPTED, "serial bridge not available"))
            return Outcome(False, "serial bridge not available (stream_commands)", 0, job_id)
        goal = StreamCommands.Goal()
        goal.commands = record.commands
        goal.lines = record.lines
        goal.lease = self.lease
        progress = Progress()

        def relay(fb_msg):
            fb = fb_msg.feedback
            self._last_xy = (fb.x_mm, fb.y_mm)
            progress.completed = max(progress.completed, int(fb.executed) - 1)
            if goal_handle is not None:
                out = RunProgram.Feedback()
                out.current_line = fb.current_line
                out.total_lines = total_lines
                out.progress = float(fb.executed) / max(1, fb.total)
                out.x_mm, out.y_mm = fb.x_mm, fb.y_mm
                goal_handle.publish_feedback(out)

        lease = String(data=job_id)
        self.pub_lease.publish(lease)
        send = self._bridge.send_goal_async(goal, feedback_callback=relay,
                                            goal_uuid=UUID(uuid=list(bytes.fromhex(job_id))))
        if not _wait(send, 30.0):
            self.journal.update(job_id, Progress(0, INTERRUPTED, "serial bridge did not answer"))
            return Outcome(False, "serial bridge did not answer", 0, job_id)
        inner = send.result()
        if not inner.accepted:
            self.journal.update(job_id, Progress(0, INTERRUPTED, "serial bridge refused the job"))
            return Outcome(False, "serial bridge refused the job (busy, disconnected or bad commands)", 0, job_id)
        res_future = inner.get_result_async()
        last_renew = time.monotonic()
        while not res_future.done():
            if goal_handle is not None and goal_handle.is_cancel_requested:
                inner.cancel_goal_async()
                _wait(res_future, 10.0)
                break
            _wait(res_future, min(0.05, self.lease / 4))
            if time.monotonic() - last_renew >= self.lease / 4:
                self.pub_lease.publish(lease)
                last_renew = time.monotonic()
            self.journal.update(job_id, Progress(progress.completed, RUNNING))
        res = res_future.result().result if res_future.done() else None
        if res is None:
            return Outcome(False, "canceled", 0, job_id)
        self._last_xy = (res.x_mm, res.y_mm)
        completed = len(record.commands) if res.success else int(res.completed)
        self.journal.update(job_id, Progress(completed, DONE if res.success else INTERRUPTED, res.message))
        lines_done = record.lines[completed - 1] if completed else 0
        if res.success:
            return Outcome(True, f"{record.name}: done", total_lines, job_id)
        if goal_handle is not None and goal_handle.is_cancel_requested:
            return Outcome(False, "canceled", lines_done, job_id)
        return Outcome(False, f"{record.name}: {res.message}", lines_done, job_id)


def _wait(future, timeout: float) -> bool:
    event = threading.Event()
    future.add_done_callback(lambda _: event.set())
    return event.wait(timeout) or future.done()


def main(args=None) -> int:
    return run_node(GCodeStreamer, "gcode_streamer", args)


if __name__ == "__main__":
    sys.exit(main())
