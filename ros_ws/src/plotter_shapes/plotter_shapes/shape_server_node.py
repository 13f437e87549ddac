"""ROS 2 node that turns shape requests into G-code programs for the streamer.

Interfaces (names relative to the node's namespace)::

    sub   shape         plotter_interfaces/msg/ShapeGoal    one shape to draw
    pub   program       std_msgs/msg/String                 its G-code program
    pub   shape_error   std_msgs/msg/String                 why a shape was refused
    action server  draw         plotter_interfaces/action/DrawShape
    action client  run_program  plotter_interfaces/action/RunProgram (the streamer)

Namespace: ``/plotter`` unless the node is started with a namespace remap
(``--ros-args -r __ns:=/other``), which takes precedence. So a plain
``ros2 run plotter_shapes shape_server`` serves ``/plotter/shape``,
``/plotter/program``, ``/plotter/shape_error`` and ``/plotter/draw``, the
same names the streamer uses in its namespace::

    ros2 topic pub --once /plotter/shape plotter_interfaces/msg/ShapeGoal \\
        "{shape: star, size: 40.0}"
    ros2 action send_goal --feedback /plotter/draw plotter_interfaces/action/DrawShape \\
        "{shape: {shape: car, x: 100.0, y: 100.0, size: 60.0, reverse: true}}"

Topic: every ``shape`` message is validated and built (see
plotter_shapes.geometry for the figures); the program text (G-code lines
joined by newlines) is published on ``program``, which the streamer runs. A
bad message (unknown shape, NaN/infinite numbers, size out of range...) is
logged and its reason, e.g. ``"size: must be a finite number, got nan"``, is
published on ``shape_error``; the node keeps running.

Action: a ``draw`` goal is built the same way and sent as a ``run_program``
goal to the streamer; its feedback (progress, line, pen position) is relayed,
and cancelling the ``draw`` goal cancels the ``run_program`` goal. The result
carries the streamer's outcome and final pen position. A bad shape aborts the
goal with the reason in ``message`` (and on ``shape_error``); so does a missing
streamer (no ``run_program`` server within ``server_timeout`` seconds).

Defaults rule: message fields cannot be "not given", so a goal with
``size == 0`` gets ``default_size``, and a goal at ``x == 0`` and ``y == 0``
is placed at (``work_x``, ``work_y``), the work-area centre: a figure centred
on the work area's corner could never be drawn, so ``{shape: star, size:
40.0}`` draws a 40 mm star in the middle. A ``line`` always starts at its
(x, y). ``feed == 0`` means ``default_feed``.

Parameters: ``default_feed`` (mm/min, 1500), ``default_size`` (mm, 40),
``work_x`` / ``work_y`` (mm, 100 / 100), ``server_timeout`` (s, 2.0).
"""

from __future__ import annotations

import math
import sys
import threading
import time
import traceback
from typing import Optional

from action_msgs.msg import GoalStatus
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from std_msgs.msg import String

from plotter_interfaces.action import DrawShape, RunProgram
from plotter_interfaces.msg import ShapeGoal

from plotter_bridge.nodes.main import run_node

from plotter_shapes.geometry import (
    DEFAULT_FEED_MM_MIN,
    DEFAULT_SIZE_MM,
    MAX_FEED_MM_MIN,
    MAX_SIZE_MM,
    MIN_SIZE_MM,
    ShapeError,
    goal_program,
)

NODE_NAME = "shape_server"
#: Namespace used when the node is started without a namespace remap.
DEFAULT_NAMESPACE = "/plotter"
#: How often a waiting ``draw`` goal looks at cancel requests (s).
_POLL_S = 0.05
#: How long the streamer's action server may be missing during a run before
#: the ``draw`` goal is aborted (s).
_SERVER_LOST_S = 5.0


class ShapeServer(Node):
    """Shape requests in, G-code programs out (topic and action)."""

    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__(NODE_NAME, namespace=namespace, **kwargs)
        self._group = ReentrantCallbackGroup()

        self.add_on_set_parameters_callback(self._check_parameters)
        self.declare_parameter(
            "default_feed", DEFAULT_FEED_MM_MIN,
            ParameterDescriptor(
                description="Feed (mm/min) of a shape whose feed is 0.",
                additional_constraints=f"0 < default_feed <= {MAX_FEED_MM_MIN:g}",
            ),
        )
        self.declare_parameter(
            "default_size", DEFAULT_SIZE_MM,
            ParameterDescriptor(
                description="Size (mm) of a shape whose size is 0: radius of a "
                            "circle or arc, overall width of the other figures.",
                additional_constraints=f"{MIN_SIZE_MM:g} <= default_size <= {MAX_SIZE_MM:g}",
            ),
        )
        self.declare_parameter(
            "work_x", 100.0,
            ParameterDescriptor(
                description="X (mm) of the anchor of a shape with size 0 at x = y = 0 "
                            "(the work-area centre).",
            ),
        )
        self.declare_parameter(
            "work_y", 100.0,
            ParameterDescriptor(
                description="Y (mm) of the anchor of a shape with size 0 at x = y = 0 "
                            "(the work-area centre).",
            ),
        )
        self.declare_parameter(
            "server_timeout", 2.0,
            ParameterDescriptor(
                description="Seconds a draw goal waits for the streamer's run_program "
                            "action server before it is aborted.",
                additional_constraints="server_timeout > 0",
            ),
        )

        self._program_pub = self.create_publisher(String, "program", 10)
        self._error_pub = self.create_publisher(String, "shape_error", 10)
        self._shape_sub = self.create_subscription(
            ShapeGoal, "shape", self._on_shape, 10, callback_group=self._group
        )
        self._run_client = ActionClient(
            self, RunProgram, "run_program", callback_group=self._group
        )
        self._draw_server = ActionServer(
            self,
            DrawShape,
            "draw",
            execute_callback=self._execute_draw,
            goal_callback=lambda _goal: GoalResponse.ACCEPT,
            cancel_callback=lambda _handle: CancelResponse.ACCEPT,
            callback_group=self._group,
        )
        self.get_logger().info(
            f"ready: '{self.resolve_topic_name('shape')}' -> "
            f"'{self.resolve_topic_name('program')}', action '{self.resolve_topic_name('draw')}'"
        )

    # Parameters -------------------------------------------------------------

    @staticmethod
    def _check_parameters(params) -> SetParametersResult:
        for param in params:
            value = param.value
            if param.name in ("default_feed", "default_size", "work_x", "work_y",
                              "server_timeout"):
                if isinstance(value, bool) or not isinstance(value, (int, float)) \
                        or not math.isfinite(value):
                    return SetParametersResult(
                        successful=False, reason=f"{param.name}: must be a finite number")
            if param.name == "default_feed" and not 0.0 < value <= MAX_FEED_MM_MIN:
                return SetParametersResult(
                    successful=False,
                    reason=f"default_feed: must be in (0, {MAX_FEED_MM_MIN:g}] mm/min")
            if param.name == "default_size" and not MIN_SIZE_MM <= value <= MAX_SIZE_MM:
                return SetParametersResult(
                    successful=False,
                    reason=f"default_size: must be in [{MIN_SIZE_MM:g}, {MAX_SIZE_MM:g}] mm")
            if param.name == "server_timeout" and not value > 0.0:
                return SetParametersResult(
                    successful=False, reason="server_timeout: must be positive")
        return SetParametersResult(successful=True)

    def _float_param(self, name: str) -> float:
        return float(self.get_parameter(name).value)

    # Shapes -----------------------------------------------------------------

    def make_program(self, goal: ShapeGoal) -> tuple[str, str]:
        """(name, G-code text) for a goal; raises ShapeError."""
        name, lines = goal_program(
            goal.shape, goal.x, goal.y, goal.size, goal.clockwise, goal.reverse,
            goal.feed, goal.x2, goal.y2, goal.start_angle, goal.end_angle,
            default_feed=self._float_param("default_feed"),
            default_size=self._float_param("default_size"),
            default_centre=(self._float_param("work_x"), self._float_param("work_y")),
        )
        return name, "\n".join(lines) + "\n"

    def _report_error(self, text: str) -> None:
        self.get_logger().error(f"shape refused: {text}")
        self._error_pub.publish(String(data=text))

    def _try_make_program(self, goal: ShapeGoal) -> tuple[Optional[tuple[str, str]], str]:
        """((name, program), "") or (None, reason); reports the reason."""
        try:
            return self.make_program(goal), ""
        except ShapeError as exc:
            reason = str(exc)
        except Exception as exc:  # a bad message must never stop the node
            self.get_logger().error(traceback.format_exc())
            reason = f"internal error while building {goal.shape!r}: {exc}"
        self._report_error(reason)
        return None, reason

    def _on_shape(self, goal: ShapeGoal) -> None:
        made, _ = self._try_make_program(goal)
        if made is None:
            return
        name, program = made
        # Each program is published once: right after start-up the streamer's
        # subscription may not be matched yet, so give discovery a moment.
        deadline = time.monotonic() + 3.0
        while self._program_pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.02)
        if self._program_pub.get_subscription_count() == 0:
            self._report_error(f"{name}: no gcode_streamer listens on {self._program_pub.topic_name}")
            return
        self._program_pub.publish(String(data=program))
        self.get_logger().info(
            f"published program '{name}' ({len(program.splitlines())} lines)")

    # Action -----------------------------------------------------------------

    def _wait(self, future, goal_handle=None, on_cancel=None) -> bool:
        """Wait for ``future`` without blocking the executor (other threads
        serve its callbacks). Calls ``on_cancel`` once when the draw goal is
        asked to cancel. False if ROS shuts down or the streamer disappears."""
        done = threading.Event()
        future.add_done_callback(lambda _f: done.set())
        cancel_forwarded = False
        missing_since: Optional[float] = None
        while not done.wait(_POLL_S):
            if not self.context.ok():
                return False
            if (on_cancel is not None and not cancel_forwarded
                    and goal_handle is not None and goal_handle.is_cancel_requested):
                cancel_forwarded = True
                on_cancel()
            if self._run_client.server_is_ready():
                missing_since = None
            else:
                now = time.monotonic()
                if missing_since is None:
                    missing_since = now
                elif now - missing_since > _SERVER_LOST_S:
                    return False
        return True

    def _relay_feedback(self, goal_handle, feedback_msg) -> None:
        inner = feedback_msg.feedback
        if not goal_handle.is_active:
            return
        goal_handle.publish_feedback(DrawShape.Feedback(
            progress=float(inner.progress),
            current_line=int(inner.current_line),
            x_mm=float(inner.x_mm),
            y_mm=float(inner.y_mm),
        ))

    def _execute_draw(self, goal_handle) -> DrawShape.Result:
        result = DrawShape.Result(success=False)

        def finish(message: str, outcome: str) -> DrawShape.Result:
            result.message = message
            if not self.context.ok():
                # Shutting down: the goal ends with the node.
                return result
            if outcome == "succeed":
                goal_handle.succeed()
            elif outcome == "canceled":
                goal_handle.canceled()
            else:
                goal_handle.abort()
                self.get_logger().warning(f"draw aborted: {message}")
            return result

        made, reason = self._try_make_program(goal_handle.request.shape)
        if made is None:
            return finish(reason, "abort")
        name, program = made
        if goal_handle.is_cancel_requested:
            return finish("cancelled before the program was sent", "canceled")

        timeout = self._float_param("server_timeout")
        if not self._run_client.wait_for_server(timeout_sec=timeout):
            return finish(
                f"G-code streamer not available: no action server "
                f"'{self.resolve_topic_name('run_program')}' after {timeout:g} s", "abort")

        send_future = self._run_client.send_goal_async(
            RunProgram.Goal(program=program, name=name),
            feedback_callback=lambda fb: self._relay_feedback(goal_handle, fb),
        )
        if not self._wait(send_future):
            return finish("no answer from the streamer to the run_program goal", "abort")
        run_handle = send_future.result()
        if run_handle is None or not run_handle.accepted:
            return finish(f"the streamer refused program '{name}'", "abort")
        self.get_logger().info(f"drawing '{name}'")

        result_future = run_handle.get_result_async()
        if not self._wait(result_future, goal_handle, run_handle.cancel_goal_async):
            if not self.context.ok():
                return finish("shape server shut down while drawing", "abort")
            run_handle.cancel_goal_async()
            return finish("lost the streamer while drawing", "abort")

        wrapped = result_future.result()
        run = wrapped.result
        result.success = bool(run.success) and wrapped.status == GoalStatus.STATUS_SUCCEEDED
        result.x_mm = float(run.x_mm)
        result.y_mm = float(run.y_mm)
        if result.success:
            return finish(run.message or "done", "succeed")
        message = run.message or f"run_program ended with status {wrapped.status}"
        if goal_handle.is_cancel_requested:
            return finish(message, "canceled")
        return finish(message, "abort")


def main(args: Optional[list[str]] = None) -> int:
    """Entry point: ``ros2 run plotter_shapes shape_server`` or
    ``python -m plotter_shapes.shape_server_node``."""
    return run_node(ShapeServer, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
