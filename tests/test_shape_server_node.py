"""The shape_server node, run as its own process like ``ros2 run`` would.

Each test starts ``python -m plotter_shapes.shape_server_node`` in a ROS domain
of its own (node_processes.new_domain, discovery on loopback) and talks to it with
rclpy from the test process: it publishes ShapeGoal messages as
``ros2 topic pub --once /plotter/shape plotter_interfaces/msg/ShapeGoal "{...}"``
does (reliable, volatile, after a subscriber has matched), reads
/plotter/program and /plotter/shape_error, and plays the streamer's
``run_program`` action server for the ``draw`` action.
"""

import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "ros_ws" / "src" / "plotter_shapes"))

import pytest  # noqa: E402

import node_processes  # noqa: E402
from plotter_shapes.geometry import goal_program  # noqa: E402

pytestmark = pytest.mark.ros

SHAPES_SRC = Path(__file__).resolve().parent.parent / "ros_ws" / "src" / "plotter_shapes"
TIMEOUT_S = 30.0


def wait_until(predicate, timeout=TIMEOUT_S, what="condition"):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")


def wait_future(future, timeout=TIMEOUT_S, what="future"):
    wait_until(future.done, timeout, what)
    return future.result()


@pytest.fixture
def domain_id():
    """A ROS domain of its own for this test."""
    return node_processes.new_domain()


class NodeProcess(node_processes.NodeProcess):
    """The shape server running as a separate process."""

    def __init__(self, domain: int, ros_args=()):
        super().__init__("plotter_shapes.shape_server_node", domain, ros_args)


@pytest.fixture
def start_server(domain_id):
    started = []

    def start(*ros_args):
        proc = NodeProcess(domain_id, ros_args)
        started.append(proc)
        return proc

    yield start
    for proc in started:
        proc.close()


class Probe:
    """Test-side ROS node spinning in a background thread."""

    def __init__(self, domain: int, namespace="/plotter"):
        import rclpy
        from rclpy.callback_groups import ReentrantCallbackGroup
        from rclpy.context import Context
        from rclpy.executors import MultiThreadedExecutor
        from std_msgs.msg import String

        from plotter_interfaces.msg import ShapeGoal

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node("shape_server_probe", context=self.context)
        self.group = ReentrantCallbackGroup()
        self.ns = namespace
        self.programs = []
        self.errors = []
        # Answers to wait_for_server_node's pings: one may come late, into a test, and is dropped.
        self.ping_answers = set()
        self.node.create_subscription(
            String, f"{namespace}/program", lambda m: self._keep(self.programs, m.data), 10)
        self.node.create_subscription(
            String, f"{namespace}/shape_error", lambda m: self._keep(self.errors, m.data), 10)
        self.shape_pub = self.node.create_publisher(ShapeGoal, f"{namespace}/shape", 10)
        self.executor = MultiThreadedExecutor(num_threads=4, context=self.context)
        self.executor.add_node(self.node)
        self.closing = threading.Event()
        self.goals_lock = threading.Lock()
        self.goals_running = 0          # FakeStreamer goals whose execute has not returned
        from plotter_bridge.nodes.spinning import SpinThread
        self.spin = SpinThread(self.executor)

    def _keep(self, answers, text):
        if text not in self.ping_answers:
            answers.append(text)

    def wait_for_server_node(self, server: NodeProcess):
        """Until messages flow both ways on all three topics.

        Graph discovery alone does not prove that the server's publishers have
        matched our subscriptions, and a volatile message sent before that is
        lost. So ping: a good goal until a program comes back, a bad goal until
        an error comes back; then drop the answers.
        """
        def matched():
            assert server.alive(), "shape_server exited:\n" + server.output()
            return self.shape_pub.get_subscription_count() >= 1
        wait_until(matched, what="the shape_server's subscription")
        for fields, answers in (({"shape": "line", "x": 1.0, "y": 1.0, "x2": 2.0, "y2": 2.0},
                                 self.programs),
                                ({"shape": ""}, self.errors)):
            deadline = time.monotonic() + TIMEOUT_S
            while not answers:
                assert server.alive(), "shape_server exited:\n" + server.output()
                assert time.monotonic() < deadline, f"no answer to {fields}:\n" + server.output()
                self.publish(**fields)
                resend_at = time.monotonic() + 0.5
                while not answers and time.monotonic() < resend_at:
                    time.sleep(0.02)
            # Every ping of a kind has the same answer: one to a ping sent before is dropped as it comes.
            self.ping_answers.update(answers)
        self.programs.clear()
        self.errors.clear()

    def publish(self, **fields):
        """One ShapeGoal, like ``ros2 topic pub --once``."""
        from plotter_interfaces.msg import ShapeGoal

        self.shape_pub.publish(ShapeGoal(**fields))

    def close(self):
        import rclpy

        self.closing.set()
        # A FakeStreamer goal still running ends itself on `closing`, before its handles go.
        wait_until(lambda: self.goals_running == 0, what="the fake streamer's goals to end")
        self.spin.stop()                   # out of the executor before the node goes
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture
def probe(domain_id):
    p = Probe(domain_id)
    yield p
    p.close()


def expected_program(shape, x=0.0, y=0.0, size=0.0, **kwargs):
    _, lines = goal_program(shape, x, y, size, **kwargs)
    return "\n".join(lines) + "\n"


def test_star_goal_publishes_its_program(start_server, probe):
    server = start_server()
    probe.wait_for_server_node(server)
    probe.publish(shape="star", size=40.0)
    wait_until(lambda: probe.programs, what="a program on /plotter/program")
    (program,) = probe.programs
    assert program == expected_program("star", size=40.0)
    lines = program.splitlines()
    assert lines[:2] == ["(star)", "G21 G90"]
    assert sum(line.startswith("G1 ") for line in lines) == 5
    assert lines[-2:] == ["M5", "M2"]
    assert probe.errors == []
    assert server.interrupt() == 0


def test_defaults_apply_to_an_empty_goal(start_server, probe):
    server = start_server("-p", "default_size:=30.0", "-p", "default_feed:=900.0")
    probe.wait_for_server_node(server)
    probe.publish(shape="circle")
    wait_until(lambda: probe.programs, what="a program")
    assert probe.programs == [expected_program(
        "circle", default_size=30.0, default_feed=900.0)]
    assert "G0 X130.0000 Y100.0000" in probe.programs[0]


def test_bad_goals_are_reported_and_the_node_survives(start_server, probe):
    server = start_server()
    probe.wait_for_server_node(server)
    probe.publish(shape="hexagon", size=40.0)
    wait_until(lambda: len(probe.errors) >= 1, what="a shape_error for 'hexagon'")
    probe.publish(shape="star", size=float("nan"))
    wait_until(lambda: len(probe.errors) >= 2, what="a shape_error for size NaN")
    # Each refusal names the shape it refuses, then the field.
    assert probe.errors[0].startswith("hexagon: shape:"), probe.errors[0]
    assert probe.errors[1].startswith("star: size:") and "nan" in probe.errors[1], probe.errors[1]
    assert probe.programs == []
    assert server.alive()
    probe.publish(shape="car", x=100.0, y=100.0, size=60.0, reverse=True)
    wait_until(lambda: probe.programs, what="a program after the bad goals")
    assert probe.programs == [expected_program("car", 100.0, 100.0, 60.0, reverse=True)]
    assert server.interrupt() == 0


def test_namespace_remap_takes_precedence(domain_id, start_server):
    server = start_server("-r", "__ns:=/bench")
    other = Probe(domain_id, namespace="/bench")
    try:
        other.wait_for_server_node(server)
        other.publish(shape="diamond", x=50.0, y=50.0, size=20.0)
        wait_until(lambda: other.programs, what="a program on /bench/program")
        assert other.programs[0].startswith("(diamond)\nG21 G90\n")
    finally:
        other.close()


class FakeStreamer:
    """The streamer's run_program action server, inside the probe."""

    def __init__(self, probe: Probe, hold: bool = False):
        from rclpy.action import ActionServer, CancelResponse, GoalResponse

        from plotter_interfaces.action import RunProgram

        self.hold = hold
        self.probe = probe
        self.closing = probe.closing
        self.goals = []
        self.cancelled = threading.Event()
        # Set by the test once the last feedback came through the shape server:
        # the fake keeps repeating it until then, so a feedback published
        # before the topics matched cannot make the test flaky.
        self.released = threading.Event()
        self.server = ActionServer(
            probe.node, RunProgram, f"{probe.ns}/run_program",
            execute_callback=self.execute,
            goal_callback=lambda _g: GoalResponse.ACCEPT,
            cancel_callback=lambda _h: CancelResponse.ACCEPT,
            callback_group=probe.group,
        )

    def execute(self, goal_handle):
        with self.probe.goals_lock:
            self.probe.goals_running += 1
        try:
            return self._execute(goal_handle)
        finally:
            with self.probe.goals_lock:
                self.probe.goals_running -= 1

    def _execute(self, goal_handle):
        from plotter_interfaces.action import RunProgram

        request = goal_handle.request
        self.goals.append((request.name, request.program))
        total = len(request.program.splitlines())
        line = 0
        deadline = time.monotonic() + TIMEOUT_S
        while time.monotonic() < deadline and not self.closing.is_set():
            line = min(line + 1, total)
            goal_handle.publish_feedback(RunProgram.Feedback(
                progress=line / total, current_line=line, total_lines=total,
                x_mm=float(line), y_mm=2.0 * line))
            time.sleep(0.05)
            if goal_handle.is_cancel_requested:
                self.cancelled.set()
                goal_handle.canceled()
                return RunProgram.Result(success=False, message="cancelled",
                                         lines_done=line, x_mm=float(line), y_mm=2.0 * line)
            if line == total and not self.hold and self.released.is_set():
                goal_handle.succeed()
                return RunProgram.Result(success=True, message="program done",
                                         lines_done=total, x_mm=12.5, y_mm=34.5)
        goal_handle.abort()
        return RunProgram.Result(success=False, message="fake streamer stopped")


def draw_client(probe):
    from plotter_bridge.nodes.action_client import ActionClient

    from plotter_interfaces.action import DrawShape

    client = ActionClient(probe.node, DrawShape, f"{probe.ns}/draw", callback_group=probe.group)
    assert client.wait_for_server(timeout_sec=TIMEOUT_S), "no /plotter/draw action server"
    return client


def test_draw_action_forwards_to_run_program(start_server, probe):
    from action_msgs.msg import GoalStatus

    from plotter_interfaces.action import DrawShape
    from plotter_interfaces.msg import ShapeGoal

    streamer = FakeStreamer(probe)
    server = start_server("-p", f"server_timeout:={TIMEOUT_S}")
    client = draw_client(probe)
    feedback = []

    def on_feedback(msg):
        feedback.append(msg)
        if msg.feedback.progress == pytest.approx(1.0):
            streamer.released.set()

    goal = DrawShape.Goal(shape=ShapeGoal(shape="cone", x=100.0, y=100.0, size=50.0,
                                          clockwise=True, feed=1200.0))
    handle = wait_future(client.send_goal_async(goal, feedback_callback=on_feedback),
                         what="draw goal acceptance")
    assert handle.accepted
    wrapped = wait_future(handle.get_result_async(), what="draw result")
    assert wrapped.status == GoalStatus.STATUS_SUCCEEDED, server.output()
    assert wrapped.result.success
    assert wrapped.result.message == "program done"
    assert (wrapped.result.x_mm, wrapped.result.y_mm) == (12.5, 34.5)
    assert streamer.goals == [("cone", expected_program(
        "cone", 100.0, 100.0, 50.0, clockwise=True, feed=1200.0))]
    assert feedback, "no feedback relayed"
    last = feedback[-1].feedback
    total = len(streamer.goals[0][1].splitlines())
    assert last.current_line == total
    assert last.progress == pytest.approx(1.0)
    assert (last.x_mm, last.y_mm) == (float(total), 2.0 * total)
    assert server.interrupt() == 0


def test_cancelling_draw_cancels_run_program(start_server, probe):
    from action_msgs.msg import GoalStatus

    from plotter_interfaces.action import DrawShape
    from plotter_interfaces.msg import ShapeGoal

    streamer = FakeStreamer(probe, hold=True)
    server = start_server("-p", f"server_timeout:={TIMEOUT_S}")
    client = draw_client(probe)
    feedback = []
    handle = wait_future(
        client.send_goal_async(DrawShape.Goal(shape=ShapeGoal(shape="car", size=60.0)),
                               feedback_callback=feedback.append),
        what="draw goal acceptance")
    assert handle.accepted
    wait_until(lambda: feedback, what="relayed feedback")
    wait_future(handle.cancel_goal_async(), what="cancel response")
    wrapped = wait_future(handle.get_result_async(), what="draw result")
    assert streamer.cancelled.is_set()
    assert wrapped.status == GoalStatus.STATUS_CANCELED
    assert not wrapped.result.success
    assert wrapped.result.message == "cancelled"
    assert server.alive()
    assert server.interrupt() == 0


def test_draw_aborts_on_bad_shape_and_without_streamer(start_server, probe):
    from action_msgs.msg import GoalStatus

    from plotter_interfaces.action import DrawShape
    from plotter_interfaces.msg import ShapeGoal

    server = start_server("-p", "server_timeout:=0.5")
    probe.wait_for_server_node(server)
    client = draw_client(probe)

    handle = wait_future(client.send_goal_async(
        DrawShape.Goal(shape=ShapeGoal(shape="star", size=-3.0))), what="acceptance")
    wrapped = wait_future(handle.get_result_async(), what="result")
    assert wrapped.status == GoalStatus.STATUS_ABORTED
    assert wrapped.result.message.startswith("size:")
    wait_until(lambda: probe.errors, what="the shape_error of the bad draw goal")

    handle = wait_future(client.send_goal_async(
        DrawShape.Goal(shape=ShapeGoal(shape="star", size=40.0))), what="acceptance")
    wrapped = wait_future(handle.get_result_async(), what="result")
    assert wrapped.status == GoalStatus.STATUS_ABORTED
    assert "run_program" in wrapped.result.message
    assert server.alive()
    assert server.interrupt() == 0


def test_ctrl_c_while_drawing_stops_cleanly(start_server, probe):
    from plotter_interfaces.action import DrawShape
    from plotter_interfaces.msg import ShapeGoal

    FakeStreamer(probe, hold=True)
    server = start_server("-p", f"server_timeout:={TIMEOUT_S}")
    client = draw_client(probe)
    feedback = []
    handle = wait_future(
        client.send_goal_async(DrawShape.Goal(shape=ShapeGoal(shape="circle", size=30.0)),
                               feedback_callback=feedback.append),
        what="draw goal acceptance")
    assert handle.accepted
    wait_until(lambda: feedback, what="relayed feedback")
    assert server.interrupt() == 0, server.output()
    assert "Traceback" not in server.output(), server.output()
