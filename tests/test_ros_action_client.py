"""plotter_bridge.nodes.action_client: goals sent from a thread other than the
executor's are followed even when the answer comes back at once.

The window in which rclpy 7.1.6 loses an answer (between sending a request and
filing its sequence number) is microseconds wide; here the client's send is
slowed down so that every answer lands in it.  rclpy's own ActionClient loses
those answers (the control case), the plotter's must not.
"""
import time

import pytest

from node_processes import wait_until
from ros_graph import ActionPair

pytestmark = pytest.mark.ros

SEND_DELAY_S = 0.3     # far longer than an in-process answer takes


class _SlowSend:
    """The client's rcl handle, pausing after each request it sends."""

    def __init__(self, handle) -> None:
        self._handle = handle

    def __getattr__(self, name):
        attr = getattr(self._handle, name)
        if name.startswith("send_"):
            def send(*args):
                seq = attr(*args)
                time.sleep(SEND_DELAY_S)
                return seq
            return send
        return attr


@pytest.fixture
def graph():
    """A context with an action server that finishes every goal at once, spun
    by a multi-threaded executor on a thread of its own; yields a function that
    makes a client of the given class on it."""
    from plotter_interfaces.action import RunProgram

    def execute(goal_handle):
        goal_handle.succeed()
        result = RunProgram.Result()
        result.success = True
        result.message = goal_handle.request.name
        return result

    with ActionPair(RunProgram, "run_program_race", execute) as pair:
        def make(cls):
            client = cls(pair.client_node, RunProgram, "run_program_race")
            assert client.wait_for_server(10.0), "the test's own action server never appeared"
            client._client_handle = _SlowSend(client._client_handle)
            return client
        yield make


def _goal(name: str):
    from plotter_interfaces.action import RunProgram
    goal = RunProgram.Goal()
    goal.name = name
    return goal


def test_goals_results_and_cancels_sent_from_another_thread_all_complete(graph):
    from plotter_bridge.nodes.action_client import ActionClient
    client = graph(ActionClient)
    for n in range(4):
        sent = client.send_goal_async(_goal(f"goal {n}"))
        wait_until(sent.done, 10.0, f"goal {n}: the server's answer")
        handle = sent.result()
        assert handle.accepted
        result = handle.get_result_async()
        wait_until(result.done, 10.0, f"goal {n}: the result")
        assert result.result().result.message == f"goal {n}"
        cancel = handle.cancel_goal_async()      # too late to cancel, but it is answered
        wait_until(cancel.done, 10.0, f"goal {n}: the cancel answer")


def test_rclpys_own_client_loses_those_answers(graph):
    """The control: without the lock the slowed-down send loses its answer, so the
    test above would catch a client that does not guard against it."""
    from rclpy.action import ActionClient
    client = graph(ActionClient)
    lost = 0
    for n in range(3):
        sent = client.send_goal_async(_goal(f"goal {n}"))
        try:
            wait_until(sent.done, 2.0)
        except TimeoutError:
            lost += 1
            break
    assert lost, "rclpy's ActionClient kept every answer: is this rclpy still 7.1.6?"
