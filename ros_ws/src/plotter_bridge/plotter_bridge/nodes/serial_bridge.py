"""serial_bridge: owns the serial port and speaks the firmware protocol.

Publishes `position` (geometry_msgs/PointStamped in metres, REP-103, frame
`plotter`; z is the Z axis of a board built with one, else 0) and `state`
(plotter_interfaces/BoardState, reliable, transient local; its `_mm` fields
in millimetres) from the board's status reports; offers `estop`, `hold`,
`resume`, `reset` and `set_origin` (std_srvs/Trigger) and `job_status`
(plotter_interfaces/JobStatus); serves `stream_commands`
(plotter_interfaces/action/StreamCommands) to run a job of board commands,
one job at a time: a goal that comes while one runs is rejected (the
streamer queues jobs; the bridge only runs them).  An accepted job runs to
its end whatever its client does: only a cancel, an e-stop or reset, a
board alarm or reset, or the port away longer than `reconnect_timeout` end
it early (link/board_session.py).  At a pen change in a job (`M6 k`) the
board is held with the pen up and `state` is PEN_CHANGE, naming the next
pen from the goal's `pen_changes`; `resume`, or the board's own pause /
resume key, goes on.

A port that cannot be opened is logged at ERROR at once, naming it and the
reason, and again at each attempt (attempts come further apart, up to 10 s);
`state` is then DISCONNECTED with the reason in `last_error`, and
/diagnostics says the same.

A background thread pumps the board session (link/board_session.py: the link,
reconnection, reset detection, confirmed real-time bytes) so that streaming
never waits on the ROS executor; ROS callbacks talk to it under its lock.
When the port vanishes the state is DISCONNECTED and the port is opened
again with back-off; a job goes on from where the board is, or is aborted
with the reason (see link/board_session.py).
"""
from __future__ import annotations

import re
import select
import sys
import threading
import time
from typing import List, Optional, Sequence, Tuple

from collections import OrderedDict
from dataclasses import dataclass, field

from geometry_msgs.msg import PointStamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Trigger

from plotter_interfaces.action import StreamCommands
from plotter_interfaces.msg import BoardState
from plotter_interfaces.srv import JobStatus

from plotter_bridge.link.board_session import (CONNECTING, DISCONNECTED, QUEUE_SIZE, BoardSession, Job, JobResult,
                                               SessionConfig)
from plotter_bridge.link.command_store import CommandStore, goal_commands
from plotter_bridge.link.follow import follow_state_name
from plotter_bridge.link.homing import HomingConfig, home, homing_config
from plotter_bridge.gcode.pens import label_colour
from plotter_bridge.link.protocol import PEN_CHANGE, Status, pen_change_number
from plotter_bridge.link.serial_port import open_port

from .jobs import Waker
from .main import DEFAULT_NAMESPACE, run_node
from .params import BAUD, MACHINE, NodeParameters, ParamSpec, check_machine, machine_of
from .qos import latched
from .telemetry import MM, BridgeTelemetry

STATE_CODES = {"Idle": BoardState.IDLE, "Run": BoardState.RUNNING,
               "Hold": BoardState.HOLD, "Alarm": BoardState.ALARM}
STATE_NAMES = {BoardState.IDLE: "IDLE", BoardState.RUNNING: "RUNNING", BoardState.HOLD: "HOLD",
               BoardState.ALARM: "ALARM", BoardState.DISCONNECTED: "DISCONNECTED",
               BoardState.PEN_CHANGE: "PEN_CHANGE"}
MAX_COMMAND_LEN = 40            # the firmware accepts 48 characters with N and checksum
_WIRE_CONTROL = re.compile(r"[*?!~N$]")   # the line framing's and the real-time bytes (PROTOCOL.md)
# In ASCII text: a control character but the line feed, or one of _WIRE_CONTROL's.
_STORE_SUSPECT = re.compile(r"[\x00-\x09\x0b-\x1f\x7f*?!~N$]")
MAX_JOB_COMMANDS = 4_000_000   # a 64 MB program of short lines, with its pen commands
IO_SWITCH_INTERVAL = 0.0002     # s; see main()


def store_is_clean(commands: CommandStore) -> bool:
    """validate_commands' rule for each command, over a CommandStore's text at once (a million
    commands in a tenth of a second): none empty or too long, printable ASCII, no _WIRE_CONTROL."""
    text = commands.text
    return text.isascii() and not text.startswith("\n") and "\n\n" not in text \
        and commands.longest() <= MAX_COMMAND_LEN and not _STORE_SUSPECT.search(text)


def validate_commands(commands: Sequence[str]) -> Optional[str]:
    """Why a job cannot be sent, or None."""
    if not commands:
        return "empty job"
    if len(commands) > MAX_JOB_COMMANDS:
        return f"job too large: {len(commands)} commands (limit {MAX_JOB_COMMANDS})"
    if isinstance(commands, CommandStore) and store_is_clean(commands):
        return None         # the rule below, over the whole text at once: a million commands in a blink
    for k, c in enumerate(commands):
        if not c or len(c) > MAX_COMMAND_LEN or not c.isascii() or not c.isprintable() \
                or _WIRE_CONTROL.search(c):
            return f"command {k + 1} is not a board motion command: {c[:60]!r}"
    return None


# A pen change ("M6 k", pen_change_number) in a clean CommandStore's text (spaces its only blanks).
_STORE_PEN_CHANGE = re.compile(r"^ *" + PEN_CHANGE + r" +([0-9]+) *$", re.MULTILINE)


def validate_goal(commands: Sequence[str], lines: Sequence[int], pen_changes: Sequence[str] = ()) -> Optional[str]:
    why = validate_commands(commands)
    if why is None and lines and len(lines) != len(commands):
        why = "lines and commands differ in length"
    if why is None and pen_changes and isinstance(commands, CommandStore) and store_is_clean(commands):
        # the loop below over the text at once: a million commands of a job without a wrong one
        # in a blink (the first step of a big job waits for this)
        if all(int(m.group(1)) < len(pen_changes) for m in _STORE_PEN_CHANGE.finditer(commands.text)):
            return None
    if why is None and pen_changes:         # (without them any pen change is told as "pen k")
        for k, c in enumerate(commands):
            change = pen_change_number(c)
            if change is not None and pen_changes and change >= len(pen_changes):
                why = f"command {k + 1} ({c}) is a pen change the goal's pen_changes do not name"
                break
    return why


def pen_label(pen_changes: List[str], change: int) -> str:
    """What the operator is told at pen change `change` (from 0)."""
    return pen_changes[change] if change < len(pen_changes) and pen_changes[change] else f"pen {change + 1}"


IO_IDLE_WAIT = 0.01    # s: the most a command queued from ROS waits for the serial thread


def wait_readable(port, timeout: float) -> None:
    """Until the port has bytes to read, at most `timeout` seconds: a reply
    is acted on when it arrives, not at the next tick of a timer (at 115200
    baud a line takes 2.3 ms on the wire, and the next one may only go out
    once the board has acknowledged the one before it)."""
    try:
        fd = port.fileno()
    except Exception:  # a port without a file descriptor (some pyserial URLs)
        fd = None
    if fd is None:
        time.sleep(timeout)
        return
    try:
        select.select([fd], [], [], timeout)
    except (OSError, ValueError):
        time.sleep(timeout)


SPECS = (
    ParamSpec("port", "/dev/ttyUSB0", "serial port of the board, or any pyserial URL (socket://host:port, "
                                      "a pty path)", read_only=True),
    BAUD,
    ParamSpec("status_hz", 25.0, "status polls per second (the position topic's rate); at most what 5 % of the "
                                 "link's bytes carry while commands wait to be sent", "Hz", low=1.0, high=200.0),
    ParamSpec("ack_timeout", 0.5, "time without an acknowledgement before lines are sent again", "s",
              low=0.01, high=10.0),
    ParamSpec("reconnect_timeout", 30.0, "how long a job waits for a vanished port before it is aborted", "s",
              low=0.0, high=3600.0),
    ParamSpec("frame_id", "plotter", "frame of the position, paths and markers", read_only=True),
    ParamSpec("homing", False, "the machine has its limit switches wired at the -X and -Y ends: `home` seeks "
                               "them (without, a seek would run the carriage into the frame)"),
    ParamSpec("homing_seek", 1200.0, "feed of the homing cycle's seek and pull-off", "mm/min", low=1.0,
              high=30000.0),
    ParamSpec("homing_locate", 120.0, "feed of the homing cycle's slow second approach", "mm/min", low=1.0,
              high=30000.0),
    ParamSpec("homing_pull_off", 2.0, "how far the homing cycle backs off a switch; the origin is there", "mm",
              low=0.05, high=50.0),
    ParamSpec("homing_travel", 250.0, "the longest seek for a switch", "mm", low=1.0, high=400.0),
    *MACHINE,
)
JOB_MEMORY = 256                # finished jobs the job_status service still knows
FEEDBACK_PERIOD = 0.1           # s between a job's feedback messages


def check_bridge(values) -> Optional[str]:
    for name in ("port", "frame_id"):
        if not str(values[name]).strip():
            return f"{name} = '': must be a name, not empty"
    why = check_machine(values)
    if why is None and values["machine"] == "cartesian":
        try:
            bridge_homing(values)
        except ValueError as exc:
            return str(exc)
    return why


HOME_CONNECT_WAIT_S = 5.0     # how long `home` waits for a board that has not answered yet


def bridge_homing(values) -> HomingConfig:
    """The homing cycle's settings in steps, from the parameters in mm."""
    spm = machine_of(values).steps_per_mm
    return homing_config(float(values["homing_seek"]), float(values["homing_locate"]),
                         float(values["homing_pull_off"]), float(values["homing_travel"]), spm)


@dataclass
class _Running:
    """The stream_commands goal the board is working on."""
    goal_handle: object
    job: Job
    done: Future
    canceling: bool = False
    pen_changes: List[str] = field(default_factory=list)


class SerialBridge(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("serial_bridge", namespace=namespace, **kwargs)
        self.params = NodeParameters(self, SPECS, cross=check_bridge, on_change=self._apply)
        p = self.params
        self.machine = machine_of(p.values())
        self.steps_per_mm = self.machine.steps_per_mm
        self.frame_id = str(p["frame_id"])
        self.port_name = str(p["port"])
        config = SessionConfig(ack_timeout=float(p["ack_timeout"]), status_interval=1.0 / float(p["status_hz"]),
                               baud=int(p["baud"]), reconnect_timeout=float(p["reconnect_timeout"]))

        self.pub_position = self.create_publisher(PointStamped, "position", 10)
        self.pub_state = self.create_publisher(BoardState, "state", latched())
        group = ReentrantCallbackGroup()
        for name, handler in (("estop", self._srv_estop), ("hold", self._srv_hold),
                              ("resume", self._srv_resume), ("reset", self._srv_reset),
                              ("set_origin", self._srv_set_origin), ("home", self._srv_home)):
            self.create_service(Trigger, name, handler, callback_group=group)
        self.create_service(JobStatus, "job_status", self._srv_job_status, callback_group=group)
        self._waker = Waker(self)
        # Goals are taken one at a time, in order (a mutually exclusive group):
        # the one the board works on, or a refusal.
        self._action = ActionServer(self, StreamCommands, "stream_commands", self._execute,
                                    goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=MutuallyExclusiveCallbackGroup())
        self._running: Optional[_Running] = None
        self._reserved = False          # a job or the homing cycle has the board
        self._reserve_lock = threading.Lock()
        self._finished: "OrderedDict[str, JobResult]" = OrderedDict()
        self._telemetry = BridgeTelemetry(self, self.steps_per_mm, self.frame_id, self.port_name,
                                          to_pen=self._pen_steps if self.machine.kind != "cartesian" else None)
        self.session = BoardSession(self._open_port, config, on_status=self._on_status,
                                    on_change=self._on_change, log=self._log, log_error=self._log_error)
        self.create_timer(FEEDBACK_PERIOD, self._tick, callback_group=group)
        self._alive = True
        self._io = threading.Thread(target=self._io_loop, name="serial-io", daemon=True)
        self._io.start()
        self.get_logger().info(f"serial bridge on {self.port_name} at {config.baud} baud")

    def _apply(self, names: List[str]) -> None:
        """Parameters changed while running: the session takes them at its next poll."""
        p = self.params
        with self.session.lock:
            cfg = self.session.config
            cfg.ack_timeout = float(p["ack_timeout"])
            cfg.status_interval = 1.0 / float(p["status_hz"])
            cfg.reconnect_timeout = float(p["reconnect_timeout"])
            if self.session.link is not None:
                self.session.link.ack_timeout = cfg.ack_timeout
                self.session.link.status_interval = cfg.status_interval
        self.get_logger().info("parameters applied: " + ", ".join(f"{n} = {p[n]}" for n in names))

    # --- serial I/O thread ---------------------------------------------------
    def _open_port(self):
        return open_port(self.port_name, int(self.params["baud"]))

    def _io_loop(self) -> None:
        while self._alive:
            self.session.pump()
            port = self.session.port
            if port is None:
                time.sleep(0.02)
            else:
                # Woken by the board's bytes; else when a status request is due, and
                # every IO_IDLE_WAIT for commands queued meanwhile (a loop every
                # millisecond took a tenth of a core at rest).
                wait_readable(port, max(0.001, self.session.quiet_for(IO_IDLE_WAIT)))

    def _log(self, text: str) -> None:
        self.get_logger().info(text)

    def _log_error(self, text: str) -> None:
        self.get_logger().error(text)

    # --- session callbacks (I/O thread, session lock held) ------------------------
    def _on_status(self, st: Status) -> None:
        stamp = self.get_clock().now().to_msg()
        p = PointStamped()
        p.header.stamp = stamp
        p.header.frame_id = self.frame_id
        x_mm, y_mm = self.machine.pen_mm((st.x, st.y))
        z_mm = st.z / self.machine.z_steps_per_mm if st.z is not None else 0.0
        p.point.x, p.point.y, p.point.z = x_mm * MM, y_mm * MM, z_mm * MM
        self.pub_position.publish(p)
        s = self._state_msg(STATE_CODES.get(st.state, BoardState.IDLE))
        s.header.stamp = stamp
        s.x_steps, s.y_steps = st.x, st.y
        s.x_mm, s.y_mm = x_mm, y_mm
        if st.z is not None:
            s.has_z, s.z_steps, s.z_mm = True, st.z, z_mm
        if st.sensors is not None:
            s.has_sensors, s.sensors, s.follow_state = True, st.sensors, st.follow
            s.follow_state_name = follow_state_name(st.follow)
            s.followed_steps = st.followed
        s.pen_down = st.pen_down
        s.queue_free = st.queue_free
        self.pub_state.publish(s)
        self._telemetry.on_status(st, self.session.link.stats, self.session.firmware,
                                  self.session.last_error, self.session.job)

    def _on_change(self) -> None:
        # An open port whose board has not answered (an error says so) is no
        # more use than a missing one.
        if self.session.connection == DISCONNECTED or \
                (self.session.connection == CONNECTING and self.session.last_error):
            self._telemetry.on_link_lost(self.session.last_error)
            s = self._state_msg(BoardState.DISCONNECTED)
            st = self._status()
            if st is not None:         # the last position the board reported
                s.x_steps, s.y_steps = st.x, st.y
                s.x_mm, s.y_mm = self.machine.pen_mm((st.x, st.y))
                if st.z is not None:
                    s.has_z, s.z_steps, s.z_mm = True, st.z, st.z / self.machine.z_steps_per_mm
            self.pub_state.publish(s)

    def _state_msg(self, state: int) -> BoardState:
        s = BoardState()
        s.header.stamp = self.get_clock().now().to_msg()
        s.header.frame_id = self.frame_id
        s.state = state
        s.state_name = STATE_NAMES[state]
        s.position_known = self.session.position_known
        s.queue_size = QUEUE_SIZE
        s.last_error = self.session.last_error
        s.firmware_version = self.session.firmware
        s.link_baud = int(self.params["baud"])
        s.next_seq = self.session.link.next_seq if self.session.link else 0
        running = self._running
        job = running.job if running is not None else None
        if job is not None and job.submitted:
            s.current_line = job.line_of(job.started - 1)
            s.lines_done = job.line_of(job.started - 2) if job.started > 1 else 0
            change = job.pen_change
            if change is not None and state in (BoardState.IDLE, BoardState.HOLD):     # held for it
                s.state, s.state_name = BoardState.PEN_CHANGE, STATE_NAMES[BoardState.PEN_CHANGE]
                s.next_pen = pen_label(running.pen_changes, change)
                s.next_pen_colour = label_colour(s.next_pen)
        return s

    # --- action: stream a job ------------------------------------------------
    def _on_goal(self, goal) -> GoalResponse:
        try:
            why = validate_goal(goal_commands(goal), goal.lines, goal.pen_changes)
        except ValueError as exc:
            why = str(exc)
        if why is None and not self._reserve():
            why = "another job is running, or the homing cycle (the board takes one job at a time)"
        if why:
            self.get_logger().warn(f"stream_commands goal rejected: {why}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _reserve(self) -> bool:
        """Take the board for a job or the homing cycle; False if something has it."""
        with self._reserve_lock:
            if self._reserved:
                return False
            self._reserved = True
            return True

    @staticmethod
    def _job_id(goal_handle) -> str:
        return bytes(goal_handle.goal_id.uuid).hex()

    async def _execute(self, goal_handle):
        """The job runs on the serial thread; this coroutine only waits for
        its end (the feedback timer completes `done`), holding no executor
        thread meanwhile."""
        req = goal_handle.request
        commands = goal_commands(req)
        lines = req.lines if len(req.lines) else [0] * len(commands)
        result = StreamCommands.Result()
        job_id = self._job_id(goal_handle)
        try:
            # Refused here, not in _on_goal, so that the client hears why.
            why = self.machine.refuses(req.machine)
            if why is None:
                try:
                    job = self.session.start_job(commands, lines)
                except RuntimeError as exc:       # the last job has not let go of the board yet
                    why = str(exc)
            if why is not None:
                result.message = why
                self.get_logger().warn(f"job {job_id[:8]} refused: {why}")
                goal_handle.abort()
                return result
            running = _Running(goal_handle, job, Future(), pen_changes=list(req.pen_changes))
            self._running = running
            outcome: JobResult = await self._waker.wait(running.done)
        finally:
            self._running = None
            self._reserved = False
        self._remember(job_id, outcome)
        result.x_mm, result.y_mm = self._position_mm()
        st = self._status()
        if st is not None and st.follow is not None:
            result.follow_state, result.followed_steps = st.follow, st.followed
        result.message, result.executed, result.completed = outcome.message, outcome.executed, outcome.completed
        result.success = outcome.success
        if goal_handle.is_cancel_requested and not result.success:
            self.get_logger().info(f"job {job_id[:8]} canceled after {outcome.completed} commands")
            goal_handle.canceled()
        elif result.success:
            goal_handle.succeed()
        else:
            self.get_logger().warn(f"job {job_id[:8]} failed: {result.message}")
            goal_handle.abort()
        return result

    def _tick(self) -> None:
        """Feedback of the running job; passes a cancel request on; ends the job."""
        running = self._running
        if running is None or running.done.done():
            return
        job = running.job
        if running.goal_handle.is_cancel_requested and not running.canceling:
            running.canceling = True
            self.session.cancel(job, timeout=0.0)
        if job.result is not None:
            running.done.set_result(job.result)
            return
        fb = StreamCommands.Feedback()
        fb.total = job.total
        fb.acknowledged, fb.executed, fb.current_line = self.session.progress(job)
        fb.x_mm, fb.y_mm = self._position_mm()
        st = self._status()
        if st is not None and st.sensors is not None:
            fb.sensors, fb.follow_state, fb.followed_steps = st.sensors, st.follow, st.followed
        running.goal_handle.publish_feedback(fb)

    def pen_change_waiting(self) -> Optional[Tuple[int, str]]:
        """(the job's pen change, from 0, and what it asks for) while the running job waits at one."""
        running = self._running
        change = running.job.pen_change if running is not None else None
        return None if change is None else (change, pen_label(running.pen_changes, change))

    def _remember(self, job_id: str, outcome: JobResult) -> None:
        self._finished[job_id] = outcome
        while len(self._finished) > JOB_MEMORY:
            self._finished.popitem(last=False)

    def _srv_job_status(self, request, response):
        running = self._running
        if running is not None and self._job_id(running.goal_handle) == request.job_id:
            response.known, response.running = True, True
            _, started, _ = self.session.progress(running.job)
            response.executed, response.completed = started, max(started - 1, 0)
            response.message = "running"
            return response
        outcome = self._finished.get(request.job_id)
        if outcome is not None:
            response.known, response.success, response.message = True, outcome.success, outcome.message
            response.executed, response.completed = outcome.executed, outcome.completed
        return response

    def _pen_steps(self, motor: tuple) -> tuple:
        """Telemetry draws in the trace's units: the pen's mm times steps_per_mm."""
        x, y = self.machine.pen_mm(motor)
        return x * self.steps_per_mm, y * self.steps_per_mm

    def z_mm(self) -> Optional[float]:
        """The Z axis as the board last reported it; None without one."""
        st = self._status()
        return None if st is None or st.z is None else st.z / self.machine.z_steps_per_mm

    def _status(self) -> Optional[Status]:
        """The board's last status report (None before the first)."""
        return self.session.link.status if self.session.link else None

    def _position_mm(self) -> tuple:
        st = self._status()
        if st is None:
            return 0.0, 0.0
        return self.machine.pen_mm((st.x, st.y))

    # --- services ---------------------------------------------------------------
    def _realtime(self, what: str, response):
        response.success, response.message = self.session.realtime(what)
        return response

    def _srv_estop(self, request, response):
        return self._realtime("estop", response)

    def _srv_hold(self, request, response):
        return self._realtime("hold", response)

    def _srv_resume(self, request, response):
        return self._realtime("resume", response)

    def _srv_reset(self, request, response):
        return self._realtime("reset", response)

    def _srv_set_origin(self, request, response):
        response.success, response.message = self.session.set_origin()
        return response

    def _srv_home(self, request, response):
        if self.machine.kind != "cartesian":
            response.success, response.message = False, "homing: only on the XY table (machine cartesian)"
        elif not bool(self.params["homing"]):
            response.success, response.message = False, (
                "homing is off: set homing:=true on a machine with its limit switches wired at the -X and "
                "-Y ends (firmware/README.md); without them a seek would run into the frame")
        elif not self.session.wait_connected(HOME_CONNECT_WAIT_S):
            # (a `plotter home` typed as the bridge starts finds the board still answering its first query)
            response.success, response.message = False, (
                f"board not connected (waited {HOME_CONNECT_WAIT_S:g} s): is it plugged in and powered?")
        elif not self._reserve():
            response.success, response.message = False, "a job is running: home when the board is idle"
        else:
            try:
                self.get_logger().info("homing cycle: seeking the -X, then the -Y limit switch")
                config = bridge_homing(self.params.values())
                response.success, response.message = home(self.session, config, log=self.get_logger().info)
            finally:
                self._reserved = False
            (self.get_logger().info if response.success else self.get_logger().error)(response.message)
        return response

    def destroy_node(self) -> None:
        self._alive = False
        self._io.join(timeout=2)
        self.session.close()
        super().destroy_node()


def main(args=None) -> int:
    # A thread that wants the interpreter waits up to the switch interval (5 ms)
    # for the one that has it, e.g. a telemetry timer building a long path; the
    # serial thread must answer an ok well within a line's 2.3 ms.  A setting of
    # the whole process, so it is made here, where the process starts.
    sys.setswitchinterval(IO_SWITCH_INTERVAL)
    return run_node(SerialBridge, "serial_bridge", args)


if __name__ == "__main__":
    sys.exit(main())
