"""A drawing survives a busy or stalled host.

The node graph runs as processes on the mock board beside two CPU-bound
processes (a laptop with a browser open, a small computer at full load), and
the streamer, the bridge and the `plotter` client are each frozen (SIGSTOP)
in the middle of a job, then let go (SIGCONT).  Each time the drawing
completes exactly: the board's sequence log shows every command once and in
order, the step trace ends where the program does, and the job is reported
done.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import pytest

from node_processes import new_domain, read_seq_log
from ros_graph import PlotterGraph, Probe, read_trace, wait_until
from test_reliability_graph import consecutive, end_of, program_commands, zigzag

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parent.parent
PLOTTER = str(REPO / ".venv" / "bin" / "plotter")
HOGS = 2


@pytest.fixture(scope="module")
def hogs():
    """Two CPU-bound processes beside the graph, for the whole module."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(HOGS)]
    try:
        yield procs
    finally:
        for p in procs:
            p.kill()
            p.wait()


@pytest.fixture(scope="module")
def graph(tmp_path_factory, hogs):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.msg import BoardState

    domain = new_domain()
    g = PlotterGraph(domain, tmp_path_factory.mktemp("stalls"))
    g.probe = Probe(domain)
    g.states = []
    g.lock = threading.Lock()
    g.env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")

    def on_state(m):
        with g.lock:
            g.states.append((time.monotonic(), m))

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    g.probe.node.create_subscription(BoardState, "state", on_state, latched)
    try:
        wait_until(lambda: any(s.state == BoardState.IDLE for _, s in g.states), 90, "IDLE")
        yield g
    except BaseException:
        print(g.outputs())
        raise
    finally:
        g.probe.close()
        codes = g.close()
    assert all(c == 0 for c in codes), f"nodes did not exit cleanly on Ctrl-C: {codes}"


@pytest.fixture(autouse=True)
def node_logs_on_failure(request, graph):
    failed = request.session.testsfailed
    yield
    if request.session.testsfailed > failed:
        print(graph.outputs())


def _latest(g):
    with g.lock:
        return g.states[-1][1]


def _running_since(g, t0) -> bool:
    from plotter_interfaces.msg import BoardState
    with g.lock:
        return any(t >= t0 and s.state == BoardState.RUNNING for t, s in g.states)


def _at_rest(g) -> bool:
    from plotter_interfaces.msg import BoardState
    s = _latest(g)
    return s.state == BoardState.IDLE and s.queue_free == s.queue_size


class Job:
    """A program for the board, and what it must leave in the board's logs."""

    def __init__(self, g, lines: int, y0: float) -> None:
        wait_until(lambda: _at_rest(g), 60, "the board at rest")
        st = _latest(g)
        self.start = (st.x_steps, st.y_steps)
        self.text = zigzag(lines, y0=y0)
        self.commands = program_commands(self.text, self.start)
        self.seq_before = len(read_seq_log(g.seq_log))

    def started(self, g) -> int:
        """Commands of this job the board has started (its sequence log)."""
        return len(read_seq_log(g.seq_log)) - self.seq_before

    def check_drawn_exactly(self, g) -> None:
        wait_until(lambda: len(read_seq_log(g.seq_log)) - self.seq_before >= len(self.commands), 60,
                   "every command on the board")
        wait_until(lambda: read_trace(g.trace)[-1][1:] == end_of(self.commands, self.start), 30,
                   "the pen at the program's end")
        seqs = read_seq_log(g.seq_log)[self.seq_before:]
        assert len(seqs) == len(self.commands), f"{len(seqs)} commands ran, the program has {len(self.commands)}"
        assert consecutive(seqs), f"every command once, in order: {seqs}"


def _run_goal(g, text: str):
    from plotter_interfaces.action import RunProgram
    client = g.probe.action_client(RunProgram, "run_program")
    assert client.wait_for_server(timeout_sec=30)
    send = client.send_goal_async(RunProgram.Goal(program=text, name="stall"))
    wait_until(send.done, 30, "goal acceptance")
    handle = send.result()
    assert handle.accepted
    return handle.get_result_async()


# Commands of the job the board has started before a process is frozen: the job is under way,
# with most of its 40-odd commands still to come.
UNDER_WAY = 3


@contextmanager
def _frozen(proc: subprocess.Popen, seconds: float) -> Iterator[None]:
    """The process stopped (SIGSTOP) for `seconds`, then let go; the `with` body runs at
    the start of the freeze, to record what was done by then."""
    os.kill(proc.pid, signal.SIGSTOP)
    try:
        yield
        time.sleep(seconds)
    finally:
        os.kill(proc.pid, signal.SIGCONT)


@pytest.mark.parametrize("node,seconds", [("streamer", 10.0), ("bridge", 5.0)])
def test_a_node_frozen_mid_job_and_the_drawing_completes_exactly(graph, node, seconds):
    job = Job(graph, 40, y0=60.0 if node == "streamer" else 90.0)
    t0 = time.monotonic()
    result = _run_goal(graph, job.text)
    wait_until(lambda: _running_since(graph, t0), 30, "RUNNING")
    wait_until(lambda: job.started(graph) >= UNDER_WAY, 60, f"{UNDER_WAY} of the job's commands on the board")
    with _frozen(getattr(graph, node).proc, seconds):
        started, finished = job.started(graph), result.done()
    assert not finished and started < len(job.commands), \
        f"the job was over when the freeze began: {started} of {len(job.commands)} commands started"
    wait_until(result.done, 120, "the job's result")
    res = result.result().result
    assert res.success, res.message
    job.check_drawn_exactly(graph)


def test_the_plotter_client_frozen_mid_job_and_the_drawing_completes_exactly(graph, tmp_path):
    job = Job(graph, 40, y0=120.0)
    program = tmp_path / "zigzag.gcode"
    program.write_text(job.text)
    t0 = time.monotonic()
    client = subprocess.Popen([PLOTTER, "stream", str(program), "--quiet"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=graph.env)
    try:
        wait_until(lambda: _running_since(graph, t0), 60, "RUNNING")
        wait_until(lambda: job.started(graph) >= UNDER_WAY, 60, f"{UNDER_WAY} of the job's commands on the board")
        with _frozen(client, 10.0):
            started, ended = job.started(graph), client.poll() is not None
        assert not ended and started < len(job.commands), \
            f"the job was over when the freeze began: {started} of {len(job.commands)} commands started"
        out, err = client.communicate(timeout=120)
    finally:
        if client.poll() is None:
            client.kill()
            client.wait()
    assert client.returncode == 0, f"exit {client.returncode}\n{out}\n{err}"
    job.check_drawn_exactly(graph)
