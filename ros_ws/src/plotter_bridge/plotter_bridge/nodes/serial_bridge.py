"""serial_bridge: owns the serial port and speaks the firmware protocol.

Publishes `position` (geometry_msgs/PointStamped, mm, frame `plotter`; z is
the Z axis of a board built with one, else 0) and
`state` (plotter_interfaces/BoardState, reliable, transient local) from the
board's status reports; offers `estop`, `hold`, `resume`, `reset` and
`set_origin` (std_srvs/Trigger); serves `stream_commands`
(plotter_interfaces/action/StreamCommands) to run a job of board commands.

A background thread pumps the board session (link/board_session.py: the link,
reconnection, reset detection, confirmed real-time bytes) so that streaming
never waits on the ROS executor; ROS callbacks talk to it under its lock.
When the port vanishes the state is DISCONNECTED and the port is opened
again with back-off; a job goes on from where the board is, or is aborted
with the reason (see link/board_session.py).
"""
from __future__ import annotations

import math
import select
import sys
import threading
import time
from typing import List, Optional

from geometry_msgs.msg import PointStamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rcl_interfaces.msg import ParameterDescriptor
from std_msgs.msg import String
from std_srvs.srv import Trigger

from plotter_interfaces.action import StreamCommands
from plotter_interfaces.msg import BoardState

from plotter_bridge.link.board_session import DISCONNECTED, QUEUE_SIZE, BoardSession, Job, SessionConfig
from plotter_bridge.link.protocol import Status

from .main import run_node
from .params import declare_machine
from .qos import latched
from .telemetry import BridgeTelemetry

STATE_CODES = {"Idle": BoardState.IDLE, "Run": BoardState.RUNNING,
               "Hold": BoardState.HOLD, "Alarm": BoardState.ALARM}
STATE_NAMES = {BoardState.IDLE: "IDLE", BoardState.RUNNING: "RUNNING", BoardState.HOLD: "HOLD",
               BoardState.ALARM: "ALARM", BoardState.DISCONNECTED: "DISCONNECTED"}
MAX_COMMAND_LEN = 40            # the firmware accepts 48 characters with N and checksum
MAX_JOB_COMMANDS = 1_000_000
MAX_LEASE_S = 3600.0
IO_SWITCH_INTERVAL = 0.0002     # s; see SerialBridge.__init__
DEFAULT_NAMESPACE = "/plotter"   # `-r __ns:=/plotter2` runs a second plotter beside it


def validate_commands(commands: List[str]) -> Optional[str]:
    """Why a job cannot be sent, or None."""
    if not commands:
        return "empty job"
    if len(commands) > MAX_JOB_COMMANDS:
        return f"job too large: {len(commands)} commands (limit {MAX_JOB_COMMANDS})"
    for k, c in enumerate(commands):
        if not c or len(c) > MAX_COMMAND_LEN or not c.isascii() or not c.isprintable() \
                or any(ch in c for ch in "*?!~N$"):
            return f"command {k + 1} is not a board motion command: {c[:60]!r}"
    return None


def validate_goal(commands: List[str], lines: List[int], lease: float) -> Optional[str]:
    why = validate_commands(commands)
    if why is None and lines and len(lines) != len(commands):
        why = "lines and commands differ in length"
    if why is None and not (math.isfinite(lease) and 0.0 <= lease <= MAX_LEASE_S):
        why = f"lease {lease} outside 0..{MAX_LEASE_S:g} s"
    return why


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


class SerialBridge(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("serial_bridge", namespace=namespace, **kwargs)
        d = ParameterDescriptor
        self.declare_parameter("port", "/dev/ttyUSB0", d(description="serial port or any pyserial URL (socket://host:port, a pty path)"))
        self.declare_parameter("baud", 115200, d(description="baud rate"))
        self.declare_parameter("status_hz", 25.0, d(description="status polls per second (position topic rate); "
                                                         "at most what 5 % of the link's bytes carry while "
                                                         "commands wait to be sent (link/board_link.py STATUS_SHARE)"))
        self.declare_parameter("ack_timeout", 0.5, d(description="seconds without acknowledgement before resending"))
        self.declare_parameter("reconnect_timeout", 30.0, d(description="seconds a job waits for a vanished port before it is aborted"))
        self.declare_parameter("frame_id", "plotter", d(description="frame of the position topic"))
        self.machine = declare_machine(self)
        self.steps_per_mm = self.machine.steps_per_mm
        self.frame_id = str(self.get_parameter("frame_id").value)
        hz = float(self.get_parameter("status_hz").value)
        config = SessionConfig(ack_timeout=float(self.get_parameter("ack_timeout").value),
                               status_interval=1.0 / min(max(hz, 1.0), 200.0),
                               baud=int(self.get_parameter("baud").value),
                               reconnect_timeout=float(self.get_parameter("reconnect_timeout").value))

        self.pub_position = self.create_publisher(PointStamped, "position", 10)
        self.pub_state = self.create_publisher(BoardState, "state", latched())
        group = ReentrantCallbackGroup()
        for name, handler in (("estop", self._srv_estop), ("hold", self._srv_hold),
                              ("resume", self._srv_resume), ("reset", self._srv_reset),
                              ("set_origin", self._srv_set_origin)):
            self.create_service(Trigger, name, handler, callback_group=group)
        self.create_subscription(String, "job_lease", self._on_lease, 10, callback_group=group)
        self._action = ActionServer(self, StreamCommands, "stream_commands", self._execute,
                                    goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=group)
        self._job: Optional[Job] = None
        self._job_id = ""
        self._reserved = False
        self._telemetry = BridgeTelemetry(self, self.steps_per_mm, self.frame_id,
                                          str(self.get_parameter("port").value), to_pen=self._pen_steps
                                          if self.machine.kind != "cartesian" else None)
        self.session = BoardSession(self._open_port, config, on_status=self._on_status,
                                    on_change=self._on_change, log=self._log)
        self._running = True
        # A thread that wants the interpreter waits up to the switch interval (5 ms)
        # for the one that has it, e.g. a telemetry timer building a long path;
        # the I/O thread must answer an ok well within a line's 2.3 ms.
        sys.setswitchinterval(IO_SWITCH_INTERVAL)
        self._io = threading.Thread(target=self._io_loop, name="serial-io", daemon=True)
        self._io.start()

    # --- serial I/O thread ---------------------------------------------------
    def _open_port(self):
        import serial  # pyserial
        port = str(self.get_parameter("port").value)
        return serial.serial_for_url(port, baudrate=int(self.get_parameter("baud").value), timeout=0)

    def _io_loop(self) -> None:
        while self._running:
            self.session.pump()
            port = self.session.port
            if port is None:
                time.sleep(0.02)
            else:
                wait_readable(port, 0.001)

    def _log(self, text: str) -> None:
        self.get_logger().info(text)

    # --- session callbacks (I/O thread, session lock held) ------------------------
    def _on_status(self, st: Status) -> None:
        stamp = self.get_clock().now().to_msg()
        p = PointStamped()
        p.header.stamp = stamp
        p.header.frame_id = self.frame_id
        p.point.x, p.point.y = self.machine.pen_mm((st.x, st.y))
        if st.z is not None:
            p.point.z = st.z / self.machine.z_steps_per_mm
        self.pub_position.publish(p)
        s = self._state_msg(STATE_CODES.get(st.state, BoardState.IDLE))
        s.header.stamp = stamp
        s.x_steps, s.y_steps = st.x, st.y
        s.x_mm, s.y_mm = p.point.x, p.point.y
        if st.z is not None:
            s.has_z, s.z_steps, s.z_mm = True, st.z, p.point.z
        s.pen_down = st.pen_down
        s.queue_free = st.queue_free
        self.pub_state.publish(s)
        self._telemetry.on_status(st, self.session.link.stats, self.session.firmware,
                                  self.session.last_error, self.session.job)

    def _on_change(self) -> None:
        if self.session.connection == DISCONNECTED:
            self._telemetry.on_link_lost(self.session.last_error)
            s = self._state_msg(BoardState.DISCONNECTED)
            st = self.session.link.status if self.session.link else None
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
        s.link_baud = int(self.get_parameter("baud").value)
        s.next_seq = self.session.link.next_seq if self.session.link else 0
        job = self._job
        if job is not None and job.commands:
            s.current_line = job.line_of(job.started - 1)
            s.lines_done = job.line_of(job.started - 2) if job.started > 1 else 0
        return s

    # --- action: stream a job ------------------------------------------------
    def _on_goal(self, goal) -> GoalResponse:
        why = validate_goal(list(goal.commands), list(goal.lines), float(goal.lease))
        if why:
            self.get_logger().error(f"job refused: {why}")
            return GoalResponse.REJECT
        with self.session.lock:
            if self._reserved:
                self.get_logger().error("job refused: another job is running")
                return GoalResponse.REJECT
            self._reserved = True     # one job at a time
        return GoalResponse.ACCEPT

    def _on_lease(self, msg: String) -> None:
        job = self._job
        if job is not None and msg.data == self._job_id:
            self.session.renew(job)

    def _execute(self, goal_handle):
        req = goal_handle.request
        lines = list(req.lines) or [0] * len(req.commands)
        result = StreamCommands.Result()
        try:
            try:
                job = self.session.start_job(list(req.commands), lines, float(req.lease))
            except RuntimeError as exc:           # the last job has not let go of the board yet
                result.message = str(exc)
                goal_handle.abort()
                return result
            self._job_id = bytes(goal_handle.goal_id.uuid).hex()
            self._job = job
            fb = StreamCommands.Feedback()
            fb.total = len(req.commands)
            while job.result is None:
                if goal_handle.is_cancel_requested:
                    self.session.cancel(job)
                    break
                self.session.wait_job(job, 0.1)
                acknowledged, started, line = self.session.progress(job)
                fb.acknowledged, fb.executed, fb.current_line = acknowledged, started, line
                fb.x_mm, fb.y_mm = self._position_mm()
                goal_handle.publish_feedback(fb)
            r = job.result
            result.x_mm, result.y_mm = self._position_mm()
            result.message = r.message if r else "canceled"
            result.executed = r.executed if r else 0
            result.completed = r.completed if r else 0
            result.success = bool(r and r.success)
            if goal_handle.is_cancel_requested and not result.success:
                goal_handle.canceled()
            elif result.success:
                goal_handle.succeed()
            else:
                self.get_logger().warn(f"job failed: {result.message}")
                goal_handle.abort()
            return result
        finally:
            with self.session.lock:
                self._reserved = False

    def _pen_steps(self, motor: tuple) -> tuple:
        """Telemetry draws in the trace's units: the pen's mm times steps_per_mm."""
        x, y = self.machine.pen_mm(motor)
        return x * self.steps_per_mm, y * self.steps_per_mm

    def z_mm(self) -> Optional[float]:
        """The Z axis as the board last reported it; None without one."""
        st = self.session.link.status if self.session.link else None
        return None if st is None or st.z is None else st.z / self.machine.z_steps_per_mm

    def _position_mm(self) -> tuple:
        st = self.session.link.status if self.session.link else None
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

    def destroy_node(self) -> None:
        self._running = False
        self._io.join(timeout=2)
        self.session.close()
        super().destroy_node()


def main(args=None) -> int:
    return run_node(SerialBridge, "serial_bridge", args)


if __name__ == "__main__":
    sys.exit(main())
