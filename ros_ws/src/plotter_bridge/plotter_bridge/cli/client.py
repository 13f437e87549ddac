"""The `plotter` command as a client of a plotter that already runs.

Without `--port` or `--mock` the job goes to the node graph running in
`--namespace` (the nodes started as scripts, with `ros2 run` or `ros2
launch`, on this machine or another in the same ROS domain): `stream`,
`svg`, `text` and `resume` send a `run_program` goal to gcode_streamer,
`follow` a `follow_line` goal, `draw` a `draw` goal to shape_server;
`state` reads `/plotter/state` once, `hold`, `resume`, `estop`, `reset`,
`set-origin` and `home` call serial_bridge's services.  Ctrl-C cancels the goal: the pen stops where it is and nothing
more is drawn.
"""
from __future__ import annotations

import contextlib
import os
import signal
import threading
from dataclasses import dataclass
from typing import Callable, Iterator, Optional

WAIT_S = 5.0           # how long a server may take to answer before it counts as missing
# A goal once sent may be running before its answer reaches us: the server sends the answer again for
# nodes/late_clients.py's PATIENCE_S (10 s) until our reader is matched, which on a busy machine takes
# seconds.  Waiting less would report no server while the board draws the job.
GOAL_ANSWER_WAIT_S = 30.0
CANCEL_WAIT_S = 15.0   # how long a cancelled goal may take to end

# Which node serves what, and how to start it (for the message when it is missing).
STARTS_STREAMER = ("gcode_streamer", "ros2 run plotter_bridge gcode_streamer --ros-args --params-file "
                                     "<config/plotter.yaml>  (or: python -m plotter_bridge.nodes.gcode_streamer)")
STARTS = {
    "run_program": STARTS_STREAMER,
    "follow_line": STARTS_STREAMER,
    "draw": ("shape_server", "ros2 run plotter_shapes shape_server --ros-args --params-file "
                             "<config/plotter.yaml>  (or: python -m plotter_shapes.shape_server_node)"),
    "serial_bridge": ("serial_bridge", "ros2 run plotter_bridge serial_bridge --ros-args --params-file "
                                       "<config/plotter.yaml> -p port:=/dev/ttyUSB0  "
                                       "(or: python -m plotter_bridge.nodes.serial_bridge ...)"),
}


class Missing(RuntimeError):
    """A node the command needs does not answer."""


def missing(what: str, name: str, key: str) -> Missing:
    node, how = STARTS[key]
    return Missing(f"no {what} {name} answers within {WAIT_S:g} s: is {node} running in this ROS domain "
                   f"(ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')})? Start it with\n    {how}")


@dataclass
class GoalOutcome:
    status: str            # succeeded, aborted, canceled, rejected
    result: object = None  # the action's result message


class GraphClient:
    """A node of this process in the plotter's namespace, spinning in a thread."""

    def __init__(self, namespace: str) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import MultiThreadedExecutor
        from plotter_bridge.nodes.spinning import SpinThread
        self.namespace = "/" + namespace.strip("/")
        self._context = Context()
        rclpy.init(context=self._context, args=[])
        self.node = rclpy.create_node(f"plotter_cli_{os.getpid()}", namespace=self.namespace,
                                      context=self._context)
        self._executor = MultiThreadedExecutor(num_threads=2, context=self._context)
        self._executor.add_node(self.node)
        self._spin = SpinThread(self._executor)
        self._clients = []

    def name(self, relative: str) -> str:
        return f"{self.namespace.rstrip('/')}/{relative}"

    # --- actions ---------------------------------------------------------------------
    def run_goal(self, action_type, action: str, goal, feedback: Callable[[object], None]) -> GoalOutcome:
        """Send a goal and wait for its end; Ctrl-C cancels it (and raises
        KeyboardInterrupt once it ended).  Missing if no server answers."""
        from action_msgs.msg import GoalStatus
        from plotter_bridge.nodes.action_client import ActionClient
        client = ActionClient(self.node, action_type, action)
        self._clients.append(client)
        if not client.wait_for_server(timeout_sec=WAIT_S):
            raise missing("action server", self.name(action), action)
        sent = client.send_goal_async(goal, feedback_callback=lambda fb: feedback(fb.feedback))
        if not _wait(sent, GOAL_ANSWER_WAIT_S):
            raise Missing(f"the goal went to {self.name(action)} and no answer came within {GOAL_ANSWER_WAIT_S:g} s: "
                          "it may be running all the same (plotter state, plotter jobs)")
        handle = sent.result()
        if not handle.accepted:
            return GoalOutcome("rejected")
        result = handle.get_result_async()
        with _ctrl_c() as interrupted:
            try:
                while not _wait(result, 0.2):
                    # rclpy's own Ctrl-C handling may shut the context down first: nothing can
                    # arrive any more, so end as Ctrl-C does.
                    if interrupted.is_set() or not self._context.ok():
                        raise KeyboardInterrupt
            except KeyboardInterrupt:
                if self._context.ok():
                    handle.cancel_goal_async()
                    _wait(result, CANCEL_WAIT_S)
                raise
        wrapped = result.result()
        status = {GoalStatus.STATUS_SUCCEEDED: "succeeded", GoalStatus.STATUS_CANCELED: "canceled"}.get(
            wrapped.status, "aborted")
        return GoalOutcome(status, wrapped.result)

    # --- services and topics -------------------------------------------------------------
    def trigger(self, service: str, timeout: float = WAIT_S * 2) -> tuple:
        """Call a std_srvs/Trigger service of the bridge: (success, message)."""
        from std_srvs.srv import Trigger
        client = self.node.create_client(Trigger, service)
        if not client.wait_for_service(timeout_sec=WAIT_S):
            raise missing("service", self.name(service), "serial_bridge")
        future = client.call_async(Trigger.Request())
        if not _wait(future, timeout):
            raise missing("service", self.name(service), "serial_bridge")
        response = future.result()
        return response.success, response.message

    def state(self):
        """The board's state (latched: the last one the bridge published)."""
        from plotter_interfaces.msg import BoardState
        from plotter_bridge.nodes.qos import latched
        got: list = []
        event = threading.Event()
        self.node.create_subscription(BoardState, "state", lambda m: (got.append(m), event.set()), latched())
        if not event.wait(WAIT_S):
            raise missing("publisher of", self.name("state"), "serial_bridge")
        return got[0]

    def close(self) -> None:
        import rclpy
        from plotter_bridge.nodes.teardown import teardown_watchdog
        self._spin.stop()                      # out of the executor before anything is destroyed
        with teardown_watchdog():
            for client in self._clients:
                client.destroy()
            self.node.destroy_node()
            rclpy.try_shutdown(context=self._context)

    def __enter__(self) -> "GraphClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@contextlib.contextmanager
def _ctrl_c() -> Iterator[threading.Event]:
    """While a goal runs, Ctrl-C sets the event instead of raising KeyboardInterrupt wherever the main
    thread happens to be (inside rclpy's future, holding its lock, the cancel that follows would wait on
    that lock for ever); the wait loop sees the event within 0.2 s."""
    event = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield event
        return
    previous = signal.signal(signal.SIGINT, lambda *_: event.set())
    try:
        yield event
    finally:
        signal.signal(signal.SIGINT, previous)


def _wait(future, timeout: Optional[float]) -> bool:
    event = threading.Event()
    future.add_done_callback(lambda _: event.set())
    return event.wait(timeout) or future.done()
