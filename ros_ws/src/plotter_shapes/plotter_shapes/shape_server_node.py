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

Topic: every ``shape`` message is validated, built (see
plotter_shapes.geometry for the figures) and checked against the work area
(``x_min`` .. ``y_max``, the streamer's parameters of the same names, from
config/plotter.yaml); the program text (G-code lines joined by newlines,
the first a comment naming the shape) is published on ``program``, which
the streamer runs. A shape that cannot be drawn (unknown shape, NaN/infinite
numbers, size out of range, does not fit the work area...) is logged at WARN
and its reason, prefixed with the shape, e.g. ``"star: size: must be a
finite number, got nan"``, is published on ``shape_error``; the node keeps
running.

Action: ``draw`` goals are drawn one at a time, in the order they were
accepted (the feedback of a waiting goal says how many jobs are ahead; past
``queue_limit`` waiting goals a new one is rejected with a warning; a goal
cancelled while it waits is never drawn). Each is built and checked the
same way and sent as a ``run_program`` goal to the streamer; its feedback
(progress, line, pen position) is relayed, and cancelling the ``draw`` goal
cancels the ``run_program`` goal. The result carries the streamer's outcome
and final pen position. A bad shape aborts the goal with the reason in
``message`` (and on ``shape_error``); so does a missing streamer (no
``run_program`` server within ``server_timeout`` seconds). A finished
drawing is logged at INFO with its time; a cancel is INFO too.

Defaults rule: message fields cannot be "not given", so a goal with
``size == 0`` gets ``default_size``, and a goal at ``x == 0`` and ``y == 0``
is placed at (``work_x``, ``work_y``), the work-area centre: a figure centred
on the work area's corner could never be drawn, so ``{shape: star, size:
40.0}`` draws a 40 mm star in the middle. A ``line`` always starts at its
(x, y). ``feed == 0`` means ``default_feed``.

Parameters: ``default_feed`` (mm/min, 1500), ``default_size`` (mm, 40),
``work_x`` / ``work_y`` (mm, 100 / 100), ``server_timeout`` (s, 2.0), the
work area ``x_min``, ``x_max``, ``y_min``, ``y_max`` (mm, 0 / 200 / 0 / 200),
``queue_limit`` (16); all but ``queue_limit`` may change while it runs.
"""

from __future__ import annotations

import sys
import time
import traceback
from dataclasses import dataclass, field
from typing import Dict, Optional

from action_msgs.msg import GoalStatus
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.task import Future
from std_msgs.msg import String

from plotter_interfaces.action import DrawShape, RunProgram
from plotter_interfaces.msg import ShapeGoal

from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.nodes.action_client import ActionClient
from plotter_bridge.nodes.jobs import JobQueue, Waker, Worker
from plotter_bridge.nodes.main import DEFAULT_NAMESPACE, run_node
from plotter_bridge.nodes.params import COORDINATE, WORK_AREA, NodeParameters, ParamSpec, check_work_area

from plotter_shapes.geometry import (
    DEFAULT_FEED_MM_MIN,
    DEFAULT_SIZE_MM,
    MAX_FEED_MM_MIN,
    MAX_SIZE_MM,
    MIN_SIZE_MM,
    ShapeError,
    goal_program,
)
from plotter_shapes.work_area import outside

NODE_NAME = "shape_server"
#: How long the streamer's action server may be missing during a drawing
#: before the ``draw`` goal is aborted (s).
_SERVER_LOST_S = 5.0

SPECS = (
    ParamSpec("default_feed", DEFAULT_FEED_MM_MIN, "feed of a shape whose feed is 0", "mm/min",
              low=0.0, above=True, high=MAX_FEED_MM_MIN),
    ParamSpec("default_size", DEFAULT_SIZE_MM, "size of a shape whose size is 0: radius of a circle or arc, "
              "overall width of the other figures", "mm", low=MIN_SIZE_MM, high=MAX_SIZE_MM),
    ParamSpec("work_x", 100.0, "X of a shape at x = y = 0 (the work area's centre)", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("work_y", 100.0, "Y of a shape at x = y = 0 (the work area's centre)", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("server_timeout", 2.0, "how long a draw goal waits for the streamer's run_program action server",
              "s", low=0.0, above=True, high=3600.0),
    *WORK_AREA,
    ParamSpec("queue_limit", 16, "draw goals that may wait for their turn; more are rejected", "goals",
              low=1, high=1000, read_only=True),
)


@dataclass
class _Drawing:
    """A draw goal's run_program goal; `ended` completes with its wrapped
    result, or None when the streamer went away."""
    handle: Optional[object] = None
    ended: Future = field(default_factory=Future)
    missing_since: Optional[float] = None


class ShapeServer(Node):
    """Shape requests in, G-code programs out (topic and action)."""

    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__(NODE_NAME, namespace=namespace, **kwargs)
        self.params = NodeParameters(self, SPECS, cross=check_work_area)
        self._group = ReentrantCallbackGroup()
        self._waker = Waker(self)
        self._worker = Worker("draw-wait")
        self._queue = JobQueue(int(self.params["queue_limit"]))
        self._drawings: Dict[bytes, _Drawing] = {}     # by goal id
        self._program_pub = self.create_publisher(String, "program", 10)
        self._error_pub = self.create_publisher(String, "shape_error", 10)
        self._shape_sub = self.create_subscription(
            ShapeGoal, "shape", self._on_shape, 10, callback_group=self._group
        )
        self._run_client = ActionClient(
            self, RunProgram, "run_program", callback_group=self._group
        )
        # Goals are answered one at a time, in the order they come, and take
        # their place in the queue as they are accepted.
        self._draw_server = ActionServer(
            self,
            DrawShape,
            "draw",
            execute_callback=self._execute_draw,
            goal_callback=self._on_goal,
            cancel_callback=self._on_cancel,
            handle_accepted_callback=self._on_accepted,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )
        self.create_timer(1.0, self._watch_streamer, callback_group=self._group)
        self.get_logger().info(
            f"ready: '{self.resolve_topic_name('shape')}' -> "
            f"'{self.resolve_topic_name('program')}', action '{self.resolve_topic_name('draw')}'"
        )

    # Shapes -----------------------------------------------------------------

    def make_program(self, goal: ShapeGoal) -> tuple[str, str]:
        """(name, G-code text) for a goal; raises ShapeError, also for a
        shape that does not fit the work area."""
        p = self.params
        name, lines = goal_program(
            goal.shape, goal.x, goal.y, goal.size, goal.clockwise, goal.reverse,
            goal.feed, goal.x2, goal.y2, goal.start_angle, goal.end_angle,
            default_feed=float(p["default_feed"]),
            default_size=float(p["default_size"]),
            default_centre=(float(p["work_x"]), float(p["work_y"])),
        )
        program = "\n".join(lines) + "\n"
        area = WorkArea(float(p["x_min"]), float(p["x_max"]), float(p["y_min"]), float(p["y_max"]))
        why = outside(program, area)
        if why:
            raise ShapeError(why)
        return name, program

    def _try_make_program(self, goal: ShapeGoal) -> tuple[Optional[tuple[str, str]], str]:
        """((name, program), "") or (None, reason); a refusal is logged at
        WARN and published on shape_error, prefixed with the shape."""
        try:
            return self.make_program(goal), ""
        except ShapeError as exc:
            reason = str(exc)
        except Exception as exc:  # a bad message must never stop the node
            self.get_logger().error(traceback.format_exc())
            reason = f"internal error while building {goal.shape!r}: {exc}"
        self._refuse(goal.shape, reason)
        return None, reason

    def _refuse(self, shape: str, reason: str) -> None:
        label = shape.strip()[:40] if shape.strip().isprintable() and shape.strip() else "shape"
        self.get_logger().warn(f"{label}: refused: {reason}")
        self._error_pub.publish(String(data=f"{label}: {reason}"))

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
            self._refuse(name, f"no gcode_streamer listens on {self._program_pub.topic_name}")
            return
        self._program_pub.publish(String(data=program))
        self.get_logger().info(
            f"published program '{name}' ({len(program.splitlines())} lines)")

    # Action -----------------------------------------------------------------

    def _on_goal(self, _goal) -> GoalResponse:
        if self._queue.full():
            self.get_logger().warn(
                f"draw goal rejected: {self._queue.limit} goals already waiting")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_accepted(self, goal_handle) -> None:
        """The goal's place in the queue, taken in the order goals are answered: its execute callback
        starts as an executor task, and a multi-threaded executor starts tasks in any order."""
        self._queue.enter(goal_handle)
        goal_handle.execute()

    def _on_cancel(self, goal_handle) -> CancelResponse:
        self._queue.withdraw(goal_handle)            # if it waits for its turn
        drawing = self._drawings.get(bytes(goal_handle.goal_id.uuid))
        if drawing is not None and drawing.handle is not None:
            drawing.handle.cancel_goal_async()
        return CancelResponse.ACCEPT

    def _tell_waiting(self) -> None:
        for key in self._queue.waiting():
            if key.is_active:
                key.publish_feedback(DrawShape.Feedback(jobs_ahead=self._queue.ahead(key)))

    def _relay_feedback(self, goal_handle, feedback_msg) -> None:
        inner = feedback_msg.feedback
        if not goal_handle.is_active:
            return
        goal_handle.publish_feedback(DrawShape.Feedback(
            progress=float(inner.progress),
            seconds_left=float(inner.seconds_left),
            current_line=int(inner.current_line),
            x_mm=float(inner.x_mm),
            y_mm=float(inner.y_mm),
            jobs_ahead=int(inner.jobs_ahead),
        ))

    def _watch_streamer(self) -> None:
        """A drawing whose streamer is gone for _SERVER_LOST_S ends."""
        ready = self._run_client.server_is_ready()
        now = time.monotonic()
        for drawing in list(self._drawings.values()):
            if ready or drawing.handle is None:
                drawing.missing_since = None
            elif drawing.missing_since is None:
                drawing.missing_since = now
            elif now - drawing.missing_since > _SERVER_LOST_S and not drawing.ended.done():
                drawing.ended.set_result(None)
                self._waker.wake()

    async def _execute_draw(self, goal_handle) -> DrawShape.Result:
        t0 = time.monotonic()
        shape = goal_handle.request.shape
        if goal_handle.is_cancel_requested:             # withdrawn before it started: not entered again
            self._queue.give_up(goal_handle)
            return self._finish(goal_handle, shape.shape, t0,
                                DrawShape.Result(message="canceled before it was drawn"), "canceled")
        turn = self._queue.enter(goal_handle)           # its place since it was accepted
        made, reason = self._try_make_program(shape)
        if made is None:
            self._queue.give_up(goal_handle)
            self._tell_waiting()
            return self._finish(goal_handle, shape.shape, t0, DrawShape.Result(message=reason), "abort")
        name, program = made
        self._tell_waiting()
        if not await self._waker.wait(turn):
            result = DrawShape.Result(message="canceled before it was drawn")
            return self._finish(goal_handle, name, t0, result, "canceled")
        drawing = _Drawing()
        self._drawings[bytes(goal_handle.goal_id.uuid)] = drawing
        try:
            result, outcome = await self._draw(goal_handle, name, program, drawing)
        finally:
            del self._drawings[bytes(goal_handle.goal_id.uuid)]
            self._queue.leave(goal_handle)
            self._tell_waiting()
        return self._finish(goal_handle, name, t0, result, outcome)

    def _finish(self, goal_handle, name: str, t0: float, result: DrawShape.Result,
                outcome: str) -> DrawShape.Result:
        if outcome == "succeed":
            goal_handle.succeed()
            self.get_logger().info(f"{name}: drawn in {time.monotonic() - t0:.1f} s")
        elif outcome == "canceled":
            goal_handle.canceled()
            self.get_logger().info(f"{name}: canceled ({result.message})")
        else:
            goal_handle.abort()
            self.get_logger().warn(f"{name}: draw aborted: {result.message}")
        return result

    async def _draw(self, goal_handle, name: str, program: str,
                    drawing: _Drawing) -> tuple[DrawShape.Result, str]:
        """Run the program through the streamer: (result, outcome)."""
        if goal_handle.is_cancel_requested:
            return DrawShape.Result(message="canceled before it was drawn"), "canceled"
        timeout = float(self.params["server_timeout"])
        if not await self._waker.wait(self._worker.run(self._run_client.wait_for_server, timeout)):
            return DrawShape.Result(message=f"G-code streamer not available: no action server "
                                            f"'{self.resolve_topic_name('run_program')}' after "
                                            f"{timeout:g} s"), "abort"
        handle = await self._waker.wait(self._run_client.send_goal_async(
            RunProgram.Goal(program=program, name=name),
            feedback_callback=lambda fb: self._relay_feedback(goal_handle, fb),
        ))
        if handle is None or not handle.accepted:
            return DrawShape.Result(message=f"the streamer refused program '{name}'"), "abort"
        drawing.handle = handle
        if goal_handle.is_cancel_requested:
            handle.cancel_goal_async()
        self.get_logger().info(f"drawing '{name}'")
        handle.get_result_async().add_done_callback(
            lambda f: drawing.ended.done() or drawing.ended.set_result(f.result()))
        wrapped = await self._waker.wait(drawing.ended)
        if wrapped is None:
            handle.cancel_goal_async()
            return DrawShape.Result(message="lost the streamer while drawing"), "abort"
        run = wrapped.result
        success = bool(run.success) and wrapped.status == GoalStatus.STATUS_SUCCEEDED
        result = DrawShape.Result(success=success, x_mm=float(run.x_mm), y_mm=float(run.y_mm),
                                  message=run.message or f"run_program ended with status {wrapped.status}")
        if success:
            return result, "succeed"
        return result, "canceled" if goal_handle.is_cancel_requested else "abort"

    def destroy_node(self) -> None:
        self._worker.shutdown()
        super().destroy_node()


def main(args: Optional[list[str]] = None) -> int:
    """Entry point: ``ros2 run plotter_shapes shape_server`` or
    ``python -m plotter_shapes.shape_server_node``."""
    return run_node(ShapeServer, NODE_NAME, args)


if __name__ == "__main__":
    sys.exit(main())
