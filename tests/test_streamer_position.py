"""The pen position a gcode_streamer job reports: the bridge's result, even
when a feedback message sent before the result is handled after it (the
two come by different ways; on the multi-threaded executor the order in
which they are handled is not the order in which they were sent).

The bridge is a stand-in here, so that the late feedback is certain rather
than a matter of timing."""
from types import SimpleNamespace

import pytest

from node_processes import new_domain

pytestmark = pytest.mark.ros

JOB_A = "a" * 32
JOB_B = "b" * 32


def done(value):
    from rclpy.task import Future
    future = Future()
    future.set_result(value)
    return future


def feedback(x_mm, y_mm, executed=1):
    return SimpleNamespace(feedback=SimpleNamespace(x_mm=x_mm, y_mm=y_mm, executed=executed, current_line=1))


class Bridge:
    """The serial bridge's action as the streamer calls it: each goal gets
    its feedback, then its result at (x_mm, y_mm); the feedback callbacks
    are kept, to be called again afterwards."""

    def __init__(self, ends):
        self.ends = list(ends)
        self.callbacks = []

    def wait_for_server(self, timeout_sec=None):
        return True

    def server_is_ready(self):
        return True

    def send_goal_async(self, goal, feedback_callback=None, goal_uuid=None):
        x_mm, y_mm = self.ends.pop(0)
        self.callbacks.append(feedback_callback)
        feedback_callback(feedback(x_mm / 2, y_mm / 2))
        result = SimpleNamespace(success=True, executed=len(goal.commands), completed=len(goal.commands),
                                 message="done", x_mm=x_mm, y_mm=y_mm, follow_state=0, followed_steps=0)
        return done(SimpleNamespace(accepted=True, get_result_async=lambda: done(SimpleNamespace(result=result)),
                                    cancel_goal_async=lambda: done(None)))


@pytest.fixture
def streamer(tmp_path):
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter
    from plotter_bridge.nodes.gcode_streamer import GCodeStreamer
    context = Context()
    rclpy.init(context=context, domain_id=new_domain())
    node = GCodeStreamer(context=context, parameter_overrides=[
        Parameter("journal_dir", Parameter.Type.STRING, str(tmp_path / "journal"))])
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def record(job_id):
    from plotter_bridge.link.journal import JobRecord
    return JobRecord(job_id, "square", ["L 4000 2400 2000 0"], [1], (0, 0))


def test_a_feedback_handled_after_the_result_leaves_the_end_position(streamer):
    streamer._bridge = bridge = Bridge([(50.0, 30.0)])
    out = streamer._stream(record(JOB_A), None)
    assert out.success, out.message
    assert streamer._position.xy == (50.0, 30.0)
    bridge.callbacks[0](feedback(38.2125, 62.175))        # sent before the result, handled after it
    assert streamer._position.xy == (50.0, 30.0)


def test_an_earlier_jobs_late_feedback_leaves_the_next_job_alone(streamer):
    streamer._bridge = bridge = Bridge([(50.0, 30.0), (10.0, 20.0)])
    assert streamer._stream(record(JOB_A), None).success
    assert streamer._stream(record(JOB_B), None).success
    bridge.callbacks[0](feedback(25.0, 15.0))
    assert streamer._position.xy == (10.0, 20.0)


def test_feedback_moves_the_position_while_the_job_runs(streamer):
    streamer._bridge = Bridge([(50.0, 30.0)])
    seen = []
    real = Bridge.send_goal_async

    def watching(self, goal, feedback_callback=None, goal_uuid=None):
        def callback(msg):
            feedback_callback(msg)
            seen.append(streamer._position.xy)
        return real(self, goal, callback, goal_uuid)

    streamer._bridge.send_goal_async = watching.__get__(streamer._bridge)
    assert streamer._stream(record(JOB_A), None).success
    assert seen == [(25.0, 15.0)]


def test_the_outcome_carries_the_position_its_job_ended_at(streamer):
    # Taken on the worker as the job ends, before the worker can start the
    # next job, which replaces the streamer's position.
    streamer._bridge = Bridge([(50.0, 30.0)])
    out = streamer._timed_run("units", lambda: streamer._stream(record(JOB_A), None))
    assert out.success and out.xy == (50.0, 30.0)


def test_a_job_for_a_disconnected_board_is_refused_with_the_bridges_reason(streamer):
    from plotter_interfaces.msg import BoardState
    from plotter_bridge.nodes.gcode_streamer import GCodeStreamer
    streamer._bridge = bridge = Bridge([])
    streamer._board_state = lambda timeout=5.0: GCodeStreamer._board_state(streamer, 0.1)   # no wait for a connection
    why = "cannot open /dev/ttyUSB0: another program has it open (a serial_bridge, or a plotter command with --port)"
    streamer._on_state(BoardState(state=BoardState.DISCONNECTED, last_error=why))
    out = streamer.run("G0 X10\n", "units", None)
    assert not out.success and out.message == f"board not connected: {why}"
    streamer._on_state(BoardState(state=BoardState.DISCONNECTED))
    assert streamer.run("G0 X10\n", "units", None).message == "board not connected"
    assert bridge.callbacks == []                  # nothing was sent
