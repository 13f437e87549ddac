"""Test helpers: the node graph as processes (node_processes.py),
a probe node in the test process, and geometry for comparing traces."""
from __future__ import annotations

import contextlib
import math
import os

from node_processes import NodeProcess, PlotterGraph, read_trace, wait_until  # noqa: F401


def distance_to_segment(p, seg) -> float:
    """Distance from point p to a plotter_shapes Line or Arc (same units)."""
    px, py = p
    if hasattr(seg, "cx"):
        cx, cy = seg.cx, seg.cy
        r = math.hypot(seg.x0 - cx, seg.y0 - cy)
        a0 = math.atan2(seg.y0 - cy, seg.x0 - cx)
        a1 = math.atan2(seg.y1 - cy, seg.x1 - cx)
        a = math.atan2(py - cy, px - cx)
        span = ((a0 - a1) if seg.cw else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
        off = ((a0 - a) if seg.cw else (a - a0)) % (2 * math.pi)
        if off <= span:
            return abs(math.hypot(px - cx, py - cy) - r)
        return min(math.hypot(px - seg.x0, py - seg.y0), math.hypot(px - seg.x1, py - seg.y1))
    x0, y0, x1, y1 = seg.x0, seg.y0, seg.x1, seg.y1
    dx, dy = x1 - x0, y1 - y0
    L2 = dx * dx + dy * dy
    t = 0.0 if L2 == 0 else max(0.0, min(1.0, ((px - x0) * dx + (py - y0) * dy) / L2))
    return math.hypot(px - (x0 + t * dx), py - (y0 + t * dy))


# Reports at one position that show a holding board at rest: a status poll comes every
# 1/status_hz s, longer than a step takes at the slowest rate a hold brakes down to.
HELD_REPORTS = 3


def held_still(reports, trace_path) -> bool:
    """Whether a board in feed hold has come to rest: its last reports, (state, x_steps,
    y_steps) each, at least HELD_REPORTS of them, are all HOLD at one position, and its step
    trace ends there.  A hold brakes along the path first (`!!`), for as long as the speed
    it was at takes; the trace shows every step once the board has stopped stepping."""
    from plotter_interfaces.msg import BoardState
    last = list(reports)[-HELD_REPORTS:]
    if len(last) < HELD_REPORTS or any(r != (BoardState.HOLD, *last[-1][1:]) for r in last):
        return False
    trace = read_trace(trace_path)
    return bool(trace) and tuple(trace[-1][1:]) == tuple(last[-1][1:])


class Probe:
    """A node in the test process spinning in a thread."""

    def __init__(self, domain: int, namespace: str = "/plotter") -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import MultiThreadedExecutor
        os.environ["ROS_DOMAIN_ID"] = str(domain)
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node("test_probe", namespace=namespace, context=self.context)
        self.executor = MultiThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        from plotter_bridge.nodes.spinning import SpinThread
        self._spin = SpinThread(self.executor)
        self._action_clients = {}

    def action_client(self, action_type, name: str):
        """One action client per action, kept until close(): an action client
        destroyed while the executor waits on it kills the spin thread
        ("action client pointer is invalid")."""
        from plotter_bridge.nodes.action_client import ActionClient
        key = (action_type, name)
        if key not in self._action_clients:
            self._action_clients[key] = ActionClient(self.node, action_type, name)
        return self._action_clients[key]

    def close(self) -> None:
        import rclpy
        # The node goes only once the spin thread has left the executor: a
        # task still running would fail on its destroyed handles.
        self._spin.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


class ActionPair:
    """An action server and a client node in one context of the test process,
    spun by a multi-threaded executor on a thread of its own.  Use as a
    context manager; client_node makes the clients."""

    def __init__(self, action_type, name: str, execute) -> None:
        import rclpy
        from rclpy.action import ActionServer
        from rclpy.context import Context
        from rclpy.executors import MultiThreadedExecutor
        from plotter_bridge.nodes.spinning import SpinThread
        self._context = Context()
        rclpy.init(context=self._context)
        self.server_node = rclpy.create_node("answers", context=self._context)
        self.client_node = rclpy.create_node("asks", context=self._context)
        self.server = ActionServer(self.server_node, action_type, name, execute)
        executor = MultiThreadedExecutor(num_threads=4, context=self._context)
        executor.add_node(self.server_node)
        executor.add_node(self.client_node)
        self._spin = SpinThread(executor)

    def close(self) -> None:
        import rclpy
        self._spin.stop()
        self.server.destroy()
        self.server_node.destroy_node()
        self.client_node.destroy_node()
        rclpy.shutdown(context=self._context)

    def __enter__(self) -> "ActionPair":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@contextlib.contextmanager
def watched_graph(workdir, **graph_args):
    """A PlotterGraph in a domain of its own, up and IDLE, with a probe keeping every
    /plotter/state (graph.states, under graph.lock; last_state(graph)) and the environment
    for `plotter` commands on it (graph.env); afterwards every process must have ended cleanly."""
    import threading
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from node_processes import new_domain
    from plotter_interfaces.msg import BoardState
    domain = new_domain()
    g = PlotterGraph(domain, workdir, **graph_args)
    g.probe = Probe(domain)
    g.states, g.lock = [], threading.Lock()
    g.env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")

    def keep(m):
        with g.lock:
            g.states.append(m)
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    g.probe.node.create_subscription(BoardState, "state", keep, latched)
    try:
        wait_until(lambda: any(s.state == BoardState.IDLE for s in g.states), 60, "IDLE")
        yield g
    finally:
        print(g.outputs())          # shown with a failure
        g.probe.close()
        codes = g.close()
    assert all(c == 0 for c in codes), codes


@contextlib.contextmanager
def board_reports(domain: int, namespace: str = "/plotter"):
    """A probe keeping every <namespace>/state as (state, x_steps, y_steps), in a list it
    yields (appended to from the probe's thread); for tests that watch a graph some other way."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.msg import BoardState
    probe = Probe(domain, namespace)
    reports = []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(BoardState, "state", lambda m: reports.append((m.state, m.x_steps, m.y_steps)),
                                   latched)
    try:
        yield reports
    finally:
        probe.close()


def last_state(graph):
    """The last /plotter/state a watched_graph's probe kept."""
    with graph.lock:
        return graph.states[-1]
