"""gcode_streamer: runs G-code programs on the plotter.

Takes programs from the `program` topic (std_msgs/String; run one after the
other) and from the `run_program` action (plotter_interfaces/RunProgram,
with progress and cancel).  Each program is parsed and checked against the
work area completely before anything moves; then it is converted to board
commands and streamed through the serial bridge's `stream_commands` action,
which keeps the board's queue full.
"""
from __future__ import annotations

import math
import queue
import threading
from typing import Optional

import rclpy
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rcl_interfaces.msg import ParameterDescriptor
from std_msgs.msg import String

from plotter_interfaces.action import RunProgram, StreamCommands
from plotter_interfaces.msg import BoardState
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from .gcode_limits import WorkArea
from .gcode_types import GCodeError
from .program import StreamerConfig, compile_program

DEFAULT_NAMESPACE = "/plotter"   # `-r __ns:=/plotter2` runs a second plotter beside it


class GCodeStreamer(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("gcode_streamer", namespace=namespace, **kwargs)
        d = ParameterDescriptor
        self.declare_parameter("steps_per_mm", 80.0, d(description="motor steps per millimetre, both axes"))
        self.declare_parameter("rapid_feed", 6000.0, d(description="G0 travel rate, mm/min"))
        self.declare_parameter("x_min", 0.0, d(description="work area, mm from the power-on origin"))
        self.declare_parameter("x_max", 200.0, d(description="work area, mm"))
        self.declare_parameter("y_min", 0.0, d(description="work area, mm"))
        self.declare_parameter("y_max", 200.0, d(description="work area, mm"))
        self.declare_parameter("acceleration", 1000.0, d(description="maximum acceleration, mm/s^2 (within the firmware's ramp)"))
        self.declare_parameter("junction_deviation", 0.05, d(description="corner rule of the look-ahead planner, mm"))
        self.declare_parameter("lookahead", True, d(description="plan speeds across commands; false stops at every command"))
        self.config = self._read_config()
        group = ReentrantCallbackGroup()
        self.pub_error = self.create_publisher(String, "program_error", 10)
        self.create_subscription(String, "program", self._on_program, 10, callback_group=group)
        self._bridge = ActionClient(self, StreamCommands, "stream_commands", callback_group=group)
        self._server = ActionServer(self, RunProgram, "run_program", self._execute,
                                    goal_callback=lambda _: GoalResponse.ACCEPT,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT,
                                    callback_group=group)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._board: Optional[BoardState] = None
        self._board_changed = threading.Condition()
        self.create_subscription(BoardState, "state", self._on_state, latched, callback_group=group)
        self._busy = threading.Lock()      # one program on the board at a time
        self._last_xy = (0.0, 0.0)
        self._topic_jobs: "queue.Queue[str]" = queue.Queue()
        self._worker = threading.Thread(target=self._topic_worker, daemon=True)
        self._worker.start()

    def _read_config(self) -> StreamerConfig:
        g = lambda n: float(self.get_parameter(n).value)  # noqa: E731
        names = ("steps_per_mm", "rapid_feed", "x_min", "x_max", "y_min", "y_max",
                 "acceleration", "junction_deviation")
        v = dict(zip(names, (g(n) for n in names)))
        if not all(math.isfinite(x) for x in v.values()) or v["steps_per_mm"] <= 0 or v["rapid_feed"] <= 0 \
                or v["x_min"] >= v["x_max"] or v["y_min"] >= v["y_max"] or v["acceleration"] <= 0 \
                or v["junction_deviation"] < 0:
            raise ValueError(f"bad gcode_streamer parameters: {v}")
        return StreamerConfig(v["steps_per_mm"], v["rapid_feed"],
                              WorkArea(v["x_min"], v["x_max"], v["y_min"], v["y_max"]),
                              v["acceleration"], v["junction_deviation"],
                              bool(self.get_parameter("lookahead").value))

    def _on_state(self, msg: BoardState) -> None:
        with self._board_changed:
            self._board = msg
            self._board_changed.notify_all()

    def _board_position(self, timeout: float = 10.0) -> Optional[tuple]:
        """Where the pen is now (steps), from the bridge's state; None if unknown."""
        with self._board_changed:
            self._board_changed.wait_for(lambda: self._board is not None, timeout)
            b = self._board
        if b is None or b.state == BoardState.DISCONNECTED:
            return None
        return (b.x_steps, b.y_steps)

    # --- programs from the topic ---------------------------------------------
    def _on_program(self, msg: String) -> None:
        self._topic_jobs.put(msg.data)

    def _topic_worker(self) -> None:
        while self.context.ok():
            try:
                text = self._topic_jobs.get(timeout=0.5)
            except queue.Empty:
                continue
            ok, message, _ = self.run(text, "topic", None)
            if not ok:
                self.pub_error.publish(String(data=message))

    # --- the action ------------------------------------------------------------
    def _execute(self, goal_handle):
        req = goal_handle.request
        ok, message, done = self.run(req.program, req.name or "program", goal_handle)
        result = RunProgram.Result()
        result.success, result.message, result.lines_done = ok, message, done
        result.x_mm, result.y_mm = self._last_xy
        if goal_handle.is_cancel_requested and not ok:
            goal_handle.canceled()
        elif ok:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    def run(self, text: str, name: str, goal_handle) -> tuple:
        """Run one program; returns (success, message, lines done)."""
        with self._busy:
            start = self._board_position()
            if start is None:
                return False, "board not connected (no state from serial_bridge)", 0
            try:
                commands = compile_program(text, self.config, start)
            except GCodeError as exc:
                self.get_logger().error(f"{name}: {exc}")
                return False, str(exc), 0
            total_lines = max((c.line for c in commands), default=0)
            if not commands:
                return True, "nothing to do", 0
            if not self._bridge.wait_for_server(timeout_sec=10.0):
                return False, "serial bridge not available (stream_commands)", 0
            goal = StreamCommands.Goal()
            goal.commands = [c.text for c in commands]
            goal.lines = [c.line for c in commands]

            def relay(fb_msg):
                fb = fb_msg.feedback
                self._last_xy = (fb.x_mm, fb.y_mm)
                if goal_handle is not None:
                    out = RunProgram.Feedback()
                    out.current_line = fb.current_line
                    out.total_lines = total_lines
                    out.progress = float(fb.executed) / max(1, fb.total)
                    out.x_mm, out.y_mm = fb.x_mm, fb.y_mm
                    goal_handle.publish_feedback(out)

            send = self._bridge.send_goal_async(goal, feedback_callback=relay)
            if not _wait(send, 10.0):
                return False, "serial bridge did not answer", 0
            inner = send.result()
            if not inner.accepted:
                return False, "serial bridge refused the job (busy, disconnected or bad commands)", 0
            res_future = inner.get_result_async()
            while not res_future.done():
                if goal_handle is not None and goal_handle.is_cancel_requested:
                    inner.cancel_goal_async()
                    _wait(res_future, 10.0)
                    return False, "canceled", 0
                _wait(res_future, 0.05)
            res = res_future.result().result
            self._last_xy = (res.x_mm, res.y_mm)
            idx = min(res.executed, len(commands))
            lines_done = commands[idx - 1].line if idx else 0
            if res.success:
                return True, f"{name}: done", total_lines
            return False, f"{name}: {res.message}", lines_done


def _wait(future, timeout: float) -> bool:
    event = threading.Event()
    future.add_done_callback(lambda _: event.set())
    return event.wait(timeout) or future.done()


def main(args=None) -> None:
    rclpy.init(args=args)
    node = None
    try:
        node = GCodeStreamer()
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
