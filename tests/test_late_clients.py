"""plotter_bridge.nodes.late_clients: a server answers a client it discovered
late, once the client's reader is matched, and never runs a goal whose
acceptance it could not deliver.

On the real graph the race is rare (the server's reply writer has not matched
the client's reply reader yet when the answer goes out); here rmw's timeout is
played by a send that times out a given number of times first, warning as
rclpy 7.1.6 does, and then really sends.
"""
import threading
import warnings

import pytest

from node_processes import wait_until
from ros_graph import ActionPair

pytestmark = pytest.mark.ros

TIMEOUT_WARNING = "failed to send response (timeout): client will not receive response, at rmw_response.cpp"


def _lossy(method, losses: int):
    """method, but its first `losses` calls time out without sending."""
    left = [losses]

    def send(handle, *args):
        if left[0] > 0:
            left[0] -= 1
            warnings.warn(TIMEOUT_WARNING, RuntimeWarning)
            return None
        return method(handle, *args)
    return send


# --------------------------------------------------------------------- deliver()

def test_an_answer_is_sent_again_until_it_goes_out():
    from plotter_bridge.nodes.late_clients import deliver
    calls = []

    def send():
        calls.append(1)
        if len(calls) < 4:
            warnings.warn(TIMEOUT_WARNING, RuntimeWarning)
    assert deliver(send) == 4
    assert len(calls) == 4


def test_an_answer_never_matched_gives_up_after_its_patience():
    from plotter_bridge.nodes.late_clients import deliver
    now = [0.0]
    calls = []

    def send():
        calls.append(1)
        now[0] += 0.1               # what rmw waits each time
        warnings.warn(TIMEOUT_WARNING, RuntimeWarning)
    assert deliver(send, patience=1.0, clock=lambda: now[0]) == 0
    assert 10 <= len(calls) <= 11


def test_other_warnings_of_a_send_are_passed_on_and_do_not_count_as_lost():
    from plotter_bridge.nodes.late_clients import deliver
    with pytest.warns(UserWarning, match="something else"):
        assert deliver(lambda: warnings.warn("something else", UserWarning)) == 1


def test_an_error_of_a_send_is_raised_not_retried():
    from plotter_bridge.nodes.late_clients import deliver
    calls = []

    def send():
        calls.append(1)
        raise RuntimeError("broken")
    with pytest.raises(RuntimeError, match="broken"):
        deliver(send)
    assert len(calls) == 1


def test_installing_twice_wraps_once():
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from plotter_bridge.nodes.late_clients import retry_late_answers
    retry_late_answers()
    first = _rclpy.ActionServer.send_goal_response
    retry_late_answers()
    assert _rclpy.ActionServer.send_goal_response is first
    for method in (_rclpy.ActionServer.send_goal_response, _rclpy.ActionServer.send_cancel_response,
                   _rclpy.ActionServer.send_result_response, _rclpy.Service.service_send_response):
        assert hasattr(method, "__wrapped__")
        assert not hasattr(method.__wrapped__, "__wrapped__")


# --------------------------------------------------------------------- on a real server

@pytest.fixture
def graph():
    """An action server counting the goals it runs and a client, in one
    context spun on a thread of its own."""
    from plotter_bridge.nodes.action_client import ActionClient
    from plotter_interfaces.action import RunProgram
    ran = []

    def execute(goal_handle):
        ran.append(goal_handle.request.name)
        goal_handle.succeed()
        return RunProgram.Result(success=True, message=goal_handle.request.name)

    with ActionPair(RunProgram, "run_program_late", execute) as pair:
        client = ActionClient(pair.client_node, RunProgram, "run_program_late")
        assert client.wait_for_server(10.0), "the test's own action server never appeared"
        yield client, ran


def _raw(method):
    return getattr(method, "__wrapped__", method)


def test_a_goal_answer_that_timed_out_three_times_reaches_the_client_and_the_goal_runs_once(graph, monkeypatch):
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from plotter_bridge.nodes.late_clients import patient
    from plotter_interfaces.action import RunProgram
    client, ran = graph
    raw = _raw(_rclpy.ActionServer.send_goal_response)
    monkeypatch.setattr(_rclpy.ActionServer, "send_goal_response",
                        patient(_lossy(raw, 3), "goal answer", True))
    sent = client.send_goal_async(RunProgram.Goal(name="late"))
    wait_until(sent.done, 10.0, "the goal's answer")
    assert sent.result().accepted
    result = sent.result().get_result_async()
    wait_until(result.done, 10.0, "the result")
    assert result.result().result.message == "late"
    assert ran == ["late"]


def test_a_goal_whose_answer_never_goes_out_is_not_run(graph, monkeypatch):
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from plotter_bridge.nodes.late_clients import patient
    from plotter_interfaces.action import RunProgram
    client, ran = graph
    raw = _raw(_rclpy.ActionServer.send_goal_response)
    answer = patient(_lossy(raw, 10**9), "goal answer", True, patience=0.3)
    gave_up = threading.Event()

    def send_goal_response(handle, *args):
        try:
            return answer(handle, *args)
        finally:
            gave_up.set()
    monkeypatch.setattr(_rclpy.ActionServer, "send_goal_response", send_goal_response)
    sent = client.send_goal_async(RunProgram.Goal(name="unanswered"))
    # The server is done with the goal (its answer lost) before the check that nothing comes of it.
    wait_until(gave_up.is_set, 30.0, "the server to give up on the goal's answer")
    with pytest.raises(TimeoutError):
        wait_until(sent.done, 2.0, "an answer")
    assert ran == [], "a goal ran whose client was never told it was accepted"


@pytest.mark.filterwarnings("ignore:failed to send response")
def test_rclpy_alone_runs_a_goal_whose_answer_was_lost(graph, monkeypatch):
    """The control: with rclpy's own send the client waits for ever while its
    goal runs, which is what the two tests above guard against."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from plotter_interfaces.action import RunProgram
    client, ran = graph
    monkeypatch.setattr(_rclpy.ActionServer, "send_goal_response",
                        _lossy(_raw(_rclpy.ActionServer.send_goal_response), 1))
    sent = client.send_goal_async(RunProgram.Goal(name="lost"))
    wait_until(lambda: ran == ["lost"], 10.0, "the goal to run")
    assert not sent.done(), "the lost answer arrived after all"


def test_a_service_answer_that_timed_out_reaches_the_client(monkeypatch):
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from std_srvs.srv import Trigger
    from plotter_bridge.nodes.late_clients import patient
    from plotter_bridge.nodes.spinning import SpinThread
    raw = _raw(_rclpy.Service.service_send_response)
    monkeypatch.setattr(_rclpy.Service, "service_send_response",
                        patient(_lossy(raw, 2), "service answer", False))
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("late_service", context=context)
    node.create_service(Trigger, "late_trigger", lambda _req, res: Trigger.Response(success=True, message="ok"))
    client = node.create_client(Trigger, "late_trigger")
    executor = MultiThreadedExecutor(num_threads=2, context=context)
    executor.add_node(node)
    spin = SpinThread(executor)
    try:
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(Trigger.Request())
        wait_until(future.done, 10.0, "the service's answer")
        assert future.result().message == "ok"
    finally:
        spin.stop()
        node.destroy_node()
        rclpy.shutdown(context=context)
