"""The plotter_interfaces messages and actions: fields, constants, defaults, and
a round trip through rclpy's CDR serialization."""

import math
import time

import pytest

pytestmark = pytest.mark.ros


def roundtrip(msg):
    from rclpy.serialization import deserialize_message, serialize_message

    data = serialize_message(msg)
    assert isinstance(data, bytes) and data
    return deserialize_message(data, type(msg))


def make_shape_goal():
    from plotter_interfaces.msg import ShapeGoal

    return ShapeGoal(shape="arc", x=12.5, y=-3.25, size=20.0, clockwise=True,
                     reverse=True, feed=1200.0, x2=40.0, y2=41.5,
                     start_angle=-45.0, end_angle=270.0)


def test_shape_goal_fields_and_roundtrip():
    from plotter_interfaces.msg import ShapeGoal

    default = ShapeGoal()
    assert default.shape == ""
    assert default.feed == 0.0 and not default.clockwise and not default.reverse

    goal = make_shape_goal()
    back = roundtrip(goal)
    assert back == goal
    assert back.shape == "arc" and back.x == 12.5 and back.y == -3.25
    assert back.size == 20.0 and back.clockwise and back.reverse
    assert back.feed == 1200.0 and back.x2 == 40.0 and back.y2 == 41.5
    assert back.start_angle == -45.0 and back.end_angle == 270.0


def test_board_state_constants_and_roundtrip():
    from builtin_interfaces.msg import Time
    from plotter_interfaces.msg import BoardState

    assert (BoardState.IDLE, BoardState.RUNNING, BoardState.HOLD,
            BoardState.ALARM, BoardState.DISCONNECTED, BoardState.PEN_CHANGE) == (0, 1, 2, 3, 4, 5)
    waiting = BoardState(state=BoardState.PEN_CHANGE, next_pen='layer 2 "red" #ff0000', next_pen_colour="#ff0000")
    assert (waiting.next_pen, waiting.next_pen_colour) == ('layer 2 "red" #ff0000', "#ff0000")

    state = BoardState()
    state.header.stamp = Time(sec=1700000000, nanosec=123456789)
    state.header.frame_id = "plotter"
    state.state = BoardState.ALARM
    state.state_name = "ALARM"
    state.x_steps = -2147483648
    state.y_steps = 2147483647
    state.x_mm = -0.0125
    state.y_mm = 297.0
    state.position_known = True
    state.pen_down = True
    state.queue_free = 65535
    state.queue_size = 16
    state.current_line = 4294967295
    state.lines_done = 42
    state.last_error = "limit switch X \u2013 hit"
    state.firmware_version = "plotter-fw 0.1"

    back = roundtrip(state)
    assert back == state
    assert back.header.stamp.nanosec == 123456789
    assert back.last_error == "limit switch X \u2013 hit"


def test_draw_shape_action_roundtrip():
    from plotter_interfaces.action import DrawShape

    goal = DrawShape.Goal(shape=make_shape_goal())
    assert roundtrip(goal) == goal

    result = DrawShape.Result(success=False, message="board in ALARM",
                              x_mm=10.0, y_mm=20.0)
    assert roundtrip(result) == result

    feedback = DrawShape.Feedback(progress=0.5, current_line=7, x_mm=1.0, y_mm=2.0)
    back = roundtrip(feedback)
    assert back.progress == pytest.approx(0.5) and back.current_line == 7
    assert (back.x_mm, back.y_mm) == (1.0, 2.0)


def test_run_program_action_roundtrip():
    from plotter_interfaces.action import RunProgram

    program = "G21\nG90\nM3\nG1 X10 Y0 F1200\nG2 X0 Y10 I-10 J0\nM5\n"
    goal = RunProgram.Goal(program=program, name="square")
    assert roundtrip(goal) == goal

    result = RunProgram.Result(success=True, message="done", lines_done=6,
                               x_mm=0.0, y_mm=10.0)
    assert roundtrip(result) == result

    feedback = RunProgram.Feedback(progress=1.0 / 3.0, current_line=2,
                                   total_lines=6, x_mm=math.pi, y_mm=-math.e)
    back = roundtrip(feedback)
    assert back.progress == pytest.approx(1.0 / 3.0, rel=1e-6)  # float32
    assert (back.current_line, back.total_lines) == (2, 6)
    assert (back.x_mm, back.y_mm) == (math.pi, -math.e)


def test_action_wire_types_are_complete():
    """The action's service and message types rclpy.action uses exist."""
    from plotter_interfaces.action import DrawShape, RunProgram

    for action in (DrawShape, RunProgram):
        assert hasattr(action.Impl, "SendGoalService")
        assert hasattr(action.Impl, "GetResultService")
        assert hasattr(action.Impl, "FeedbackMessage")
        request = action.Impl.SendGoalService.Request()
        assert isinstance(request.goal, action.Goal)


def test_messages_usable_over_topic(rclpy_context):
    """A BoardState published by one node arrives at another in-process."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from plotter_interfaces.msg import BoardState

    pub_node = rclpy.create_node("iface_test_pub", context=rclpy_context)
    sub_node = rclpy.create_node("iface_test_sub", context=rclpy_context)
    received = []
    sub_node.create_subscription(BoardState, "iface_test/state", received.append, 10)
    pub = pub_node.create_publisher(BoardState, "iface_test/state", 10)
    executor = SingleThreadedExecutor(context=rclpy_context)
    executor.add_node(pub_node)
    executor.add_node(sub_node)
    try:
        msg = BoardState(state=BoardState.RUNNING, state_name="RUNNING", x_mm=5.0)
        deadline = time.monotonic() + 10.0
        while not received and time.monotonic() < deadline:
            pub.publish(msg)
            executor.spin_once(timeout_sec=0.1)
        assert received, "no BoardState received within 10 s"
        assert received[0] == msg
    finally:
        executor.shutdown()
        pub_node.destroy_node()
        sub_node.destroy_node()
