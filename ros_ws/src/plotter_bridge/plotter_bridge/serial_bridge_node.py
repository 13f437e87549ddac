"""serial_bridge: owns the serial port and speaks the firmware protocol.

Publishes `position` (geometry_msgs/PointStamped, mm, frame `plotter`) and
`state` (plotter_interfaces/BoardState, reliable, transient local) from the
board's status reports; offers `estop`, `hold`, `resume`, `reset` and
`set_origin` (std_srvs/Trigger); serves `stream_commands`
(plotter_interfaces/action/StreamCommands) to run a job of board commands.

A background thread pumps the link (BoardLink) so that streaming never waits
on the ROS executor; ROS callbacks talk to it under a lock.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import List, Optional

import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rcl_interfaces.msg import ParameterDescriptor
from std_srvs.srv import Trigger

from plotter_interfaces.action import StreamCommands
from plotter_interfaces.msg import BoardState

from .link import BoardLink, Command
from .protocol import RT_ESTOP, RT_HOLD, RT_RESET, RT_RESUME, Err, Status

STATE_CODES = {"Idle": BoardState.IDLE, "Run": BoardState.RUNNING,
               "Hold": BoardState.HOLD, "Alarm": BoardState.ALARM}
STATE_NAMES = {BoardState.IDLE: "IDLE", BoardState.RUNNING: "RUNNING", BoardState.HOLD: "HOLD",
               BoardState.ALARM: "ALARM", BoardState.DISCONNECTED: "DISCONNECTED"}
MAX_COMMAND_LEN = 40            # the firmware accepts 48 characters with N and checksum
MAX_JOB_COMMANDS = 1_000_000
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


@dataclass
class Job:
    commands: List[Command] = field(default_factory=list)
    error: Optional[str] = None
    acknowledged: int = 0
    status_at_last_ack: int = 0   # status reports seen when the last command was acknowledged


class SerialBridge(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("serial_bridge", namespace=namespace, **kwargs)
        d = ParameterDescriptor
        self.declare_parameter("port", "/dev/ttyUSB0", d(description="serial port or any pyserial URL (socket://host:port, a pty path)"))
        self.declare_parameter("baud", 115200, d(description="baud rate"))
        self.declare_parameter("steps_per_mm", 80.0, d(description="motor steps per millimetre, both axes"))
        self.declare_parameter("status_hz", 25.0, d(description="status polls per second (position topic rate)"))
        self.declare_parameter("ack_timeout", 0.5, d(description="seconds without acknowledgement before resending"))
        self.declare_parameter("frame_id", "plotter", d(description="frame of the position topic"))
        self.steps_per_mm = float(self.get_parameter("steps_per_mm").value)
        if not self.steps_per_mm > 0:
            raise ValueError("steps_per_mm must be positive")
        self.frame_id = str(self.get_parameter("frame_id").value)

        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.pub_position = self.create_publisher(PointStamped, "position", 10)
        self.pub_state = self.create_publisher(BoardState, "state", latched)
        group = ReentrantCallbackGroup()
        for name, handler in (("estop", self._srv_estop), ("hold", self._srv_hold),
                              ("resume", self._srv_resume), ("reset", self._srv_reset),
                              ("set_origin", self._srv_set_origin)):
            self.create_service(Trigger, name, handler, callback_group=group)
        self._action = ActionServer(self, StreamCommands, "stream_commands", self._execute,
                                    goal_callback=self._on_goal, cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=group)

        self._lock = threading.RLock()
        self._link: Optional[BoardLink] = None
        self._port = None
        self._job: Optional[Job] = None
        self._synced = False
        self._last_error = ""
        self._firmware = ""
        self._position_known = True
        self._status_count = 0
        self._running = True
        self._io = threading.Thread(target=self._io_loop, name="serial-io", daemon=True)
        self._io.start()

    # --- serial I/O thread ---------------------------------------------------
    def _open(self) -> None:
        import serial  # pyserial
        port = str(self.get_parameter("port").value)
        self._port = serial.serial_for_url(port, baudrate=int(self.get_parameter("baud").value), timeout=0)
        hz = float(self.get_parameter("status_hz").value)
        self._link = BoardLink(self._port, ack_timeout=float(self.get_parameter("ack_timeout").value),
                               status_interval=1.0 / max(hz, 1.0),
                               on_status=self._on_status, on_error=self._on_error,
                               on_banner=self._on_banner, on_message=self._on_message,
                               on_ack=self._on_ack)
        self._synced = False
        self._link.request_status()
        self.get_logger().info(f"connected to {port}")

    def _io_loop(self) -> None:
        backoff = 0.2
        while self._running:
            try:
                with self._lock:
                    if self._link is None:
                        self._open()
                        backoff = 0.2
                    self._link.poll()
            except Exception as exc:  # serial.SerialException, OSError: port gone
                with self._lock:
                    if self._link is not None:
                        self.get_logger().warn(f"serial link lost: {exc}")
                        self._last_error = f"disconnected: {exc}"
                        self._fail_job(f"serial link lost: {exc}")
                    self._close_port()
                self._publish_disconnected()
                time.sleep(backoff)
                backoff = min(backoff * 2, 5.0)
                continue
            time.sleep(0.001)

    def _close_port(self) -> None:
        self._link = None
        if self._port is not None:
            try:
                self._port.close()
            except Exception:
                pass
        self._port = None

    # --- link callbacks (I/O thread, lock held) ---------------------------------
    def _on_status(self, st: Status) -> None:
        self._status_count += 1
        if not self._synced:
            self._link.sync(st.next_seq, st.queue_free)
            self._synced = True
        stamp = self.get_clock().now().to_msg()
        p = PointStamped()
        p.header.stamp = stamp
        p.header.frame_id = self.frame_id
        p.point.x = st.x / self.steps_per_mm
        p.point.y = st.y / self.steps_per_mm
        self.pub_position.publish(p)
        s = BoardState()
        s.header.stamp = stamp
        s.header.frame_id = self.frame_id
        s.state = STATE_CODES.get(st.state, BoardState.IDLE)
        s.state_name = STATE_NAMES[s.state]
        s.x_steps, s.y_steps = st.x, st.y
        s.x_mm, s.y_mm = p.point.x, p.point.y
        s.position_known = self._position_known
        s.pen_down = st.pen_down
        s.queue_free = st.queue_free
        s.queue_size = 6
        s.last_error = self._last_error
        s.firmware_version = self._firmware
        job = self._job
        if job is not None and job.commands:
            idx = self._executed_index(job, st)
            s.lines_done = idx
            tag = job.commands[min(idx, len(job.commands) - 1)].tag
            s.current_line = int(tag or 0)
        self.pub_state.publish(s)

    def _on_ack(self, cmd: Command) -> None:
        if self._job is not None:
            self._job.acknowledged += 1
            self._job.status_at_last_ack = self._status_count

    def _on_error(self, cmd: Command, err: Err) -> None:
        self._last_error = f"board refused '{cmd.text}': E{err.code} {err.text}"
        self._fail_job(self._last_error)

    def _on_banner(self, text: str) -> None:
        self._firmware = text
        if self._synced:
            # The board restarted under us: its position no longer means anything.
            self._position_known = False
            self._last_error = "board reset: position unknown until set_origin"
            self._fail_job("board reset during the job")
        self._link.sync(0, 6)
        self._synced = True

    def _on_message(self, text: str) -> None:
        if text.startswith("[alarm"):
            self._last_error = text.strip("[]")
            self._fail_job(f"board alarm: {self._last_error}")

    def _fail_job(self, why: str) -> None:
        if self._job is not None and self._job.error is None:
            self._job.error = why
        if self._link is not None:
            self._link.discard()

    def _publish_disconnected(self) -> None:
        s = BoardState()
        s.header.stamp = self.get_clock().now().to_msg()
        s.state = BoardState.DISCONNECTED
        s.state_name = "DISCONNECTED"
        s.position_known = self._position_known
        s.last_error = self._last_error
        self.pub_state.publish(s)

    @staticmethod
    def _executed_index(job: Job, st: Status) -> int:
        """Commands of the job the board has started (from the status S field)."""
        first = job.commands[0].seq
        wire_first = first % 65536
        k = (st.seq - wire_first) % 65536
        if k >= len(job.commands):
            return 0 if (st.next_seq - wire_first) % 65536 == 0 else len(job.commands)
        return k + 1

    # --- action: stream a job ------------------------------------------------
    def _on_goal(self, goal) -> GoalResponse:
        why = validate_commands(list(goal.commands))
        if why is None and goal.lines and len(goal.lines) != len(goal.commands):
            why = "lines and commands differ in length"
        if why:
            self.get_logger().error(f"job refused: {why}")
            return GoalResponse.REJECT
        with self._lock:
            if self._job is not None:
                self.get_logger().error("job refused: another job is running")
                return GoalResponse.REJECT
            self._job = Job()     # reserve: one job at a time
        return GoalResponse.ACCEPT

    def _execute(self, goal_handle):
        req = goal_handle.request
        lines = list(req.lines) or [0] * len(req.commands)
        result = StreamCommands.Result()
        with self._lock:
            job = self._job
            if self._link is None or not self._synced:
                job.error = "board not connected"
            else:
                st = self._link.status
                if st is not None and st.state == "Alarm":
                    job.error = "board in alarm: reset it first"
                else:
                    job.commands = [self._link.submit(c, tag=ln) for c, ln in zip(req.commands, lines)]
        fb = StreamCommands.Feedback()
        fb.total = len(req.commands)
        last_fb = 0.0
        try:
            while True:
                time.sleep(0.01)
                with self._lock:
                    if job.error:
                        break
                    if goal_handle.is_cancel_requested:
                        self._stop_motion()
                        goal_handle.canceled()
                        result.message = "canceled"
                        result.executed = self._progress(job)
                        return result
                    st = self._link.status if self._link else None
                    # Done: everything acknowledged, and a status report newer than the
                    # last acknowledgement shows the board at rest with an empty queue.
                    done = (self._link is not None and self._link.outstanding == 0 and st is not None
                            and self._status_count > job.status_at_last_ack
                            and st.state == "Idle" and st.queue_free == 6)
                    executed = self._progress(job)
                    if time.monotonic() - last_fb > 0.1 or done:
                        last_fb = time.monotonic()
                        fb.acknowledged = job.acknowledged
                        fb.executed = executed
                        idx = min(executed, len(job.commands)) - 1
                        fb.current_line = int(job.commands[max(idx, 0)].tag or 0) if job.commands else 0
                        if st is not None:
                            fb.x_mm, fb.y_mm = st.x / self.steps_per_mm, st.y / self.steps_per_mm
                        goal_handle.publish_feedback(fb)
                    if st is not None:
                        result.x_mm, result.y_mm = st.x / self.steps_per_mm, st.y / self.steps_per_mm
                    if done:
                        result.success = True
                        result.message = "done"
                        result.executed = len(job.commands)
                        goal_handle.succeed()
                        return result
            result.success = False
            result.message = job.error
            result.executed = self._progress(job)
            goal_handle.abort()
            return result
        finally:
            with self._lock:
                self._job = None

    def _progress(self, job: Job) -> int:
        st = self._link.status if self._link else None
        if st is None or not job.commands:
            return 0
        return self._executed_index(job, st)

    def _stop_motion(self) -> None:
        """Stop the board without losing its position: hold, wait, then flush."""
        link = self._link
        if link is None:
            return
        link.realtime(RT_HOLD)
        deadline = time.monotonic() + 3.0
        self._lock.release()
        try:
            while time.monotonic() < deadline:
                time.sleep(0.02)
                st = link.status
                if st is not None and st.state == "Hold":
                    break
            time.sleep(0.05)
        finally:
            self._lock.acquire()
        link.realtime(RT_RESET)
        link.discard()
        self._synced = False
        link.request_status()

    # --- services ---------------------------------------------------------------
    def _rt_service(self, byte: bytes, what: str, response):
        with self._lock:
            if self._link is None:
                response.success, response.message = False, "board not connected"
                return response
            self._link.realtime(byte)
            if byte in (RT_ESTOP, RT_RESET):
                self._fail_job(what)
                self._link.discard()
                self._synced = False
                self._link.request_status()
        response.success, response.message = True, what
        return response

    def _srv_estop(self, request, response):
        return self._rt_service(RT_ESTOP, "emergency stop", response)

    def _srv_hold(self, request, response):
        return self._rt_service(RT_HOLD, "feed hold", response)

    def _srv_resume(self, request, response):
        return self._rt_service(RT_RESUME, "resumed", response)

    def _srv_reset(self, request, response):
        self._last_error = ""
        return self._rt_service(RT_RESET, "reset", response)

    def _srv_set_origin(self, request, response):
        with self._lock:
            if self._link is None or self._job is not None:
                response.success = False
                response.message = "board not connected" if self._link is None else "a job is running"
                return response
            self._link.submit("H")
            self._position_known = True
            self._last_error = ""
        response.success, response.message = True, "origin set"
        return response

    def destroy_node(self) -> None:
        self._running = False
        self._io.join(timeout=2)
        with self._lock:
            self._close_port()
        super().destroy_node()


def main(args=None) -> None:
    rclpy.init(args=args)
    node = None
    try:
        node = SerialBridge()
        executor = MultiThreadedExecutor(num_threads=4)  # action callbacks wait: keep threads free
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
