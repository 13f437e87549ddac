"""Reliability of the node graph, each node its own process, on the mock board.

The port vanishes and comes back, the board resets, the e-stop is pressed, the
streamer is killed, and bad input arrives on every ROS interface: each ends in
the documented state, with no extra motion.  The mock board's sequence log
(parameter `seq_log`) shows every command it started, so "exactly once" is
checked against the board, not against what the nodes believe.
"""
import math
import os
import signal
import threading
import time

import pytest

from ros_graph import PlotterGraph, Probe, read_trace, wait_until
from node_processes import new_domain, read_seq_log

pytestmark = pytest.mark.ros

STEPS_PER_MM = 80.0
# Commands of a job the board has started before a fault is made: the job is under way, with most
# of its 30-50 commands still to come.
UNDER_WAY = 3


@pytest.fixture(autouse=True)
def node_logs_on_failure(request, graph):
    """The nodes' output, when a test of this module fails."""
    failed = request.session.testsfailed
    yield
    if request.session.testsfailed > failed:
        print(graph.outputs())


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.msg import BoardState

    domain = new_domain()
    g = PlotterGraph(domain, tmp_path_factory.mktemp("reliability"),
                     board_args=("-p", "unplug_for:=1.5"),
                     bridge_args=("-p", "reconnect_timeout:=20.0"))
    probe = Probe(domain)
    g.probe = probe
    g.states = []
    g.lock = threading.Lock()

    def on_state(m):
        with g.lock:
            g.states.append((time.monotonic(), m))

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(BoardState, "state", on_state, latched)
    try:
        wait_until(lambda: any(s.state == BoardState.IDLE for _, s in g.states), 60, "IDLE")
        yield g
    except BaseException:
        print(g.outputs())
        raise
    finally:
        probe.close()
        codes = g.close()
    assert all(c == 0 for c in codes), f"nodes did not exit cleanly on Ctrl-C: {codes}\n"


def latest(g):
    with g.lock:
        return g.states[-1][1]


def states_since(g, t0):
    with g.lock:
        return [s for t, s in g.states if t >= t0]


def call(g, name, timeout=20):
    from std_srvs.srv import Trigger
    client = g.probe.node.create_client(Trigger, name)
    assert client.wait_for_service(timeout_sec=timeout), name
    future = client.call_async(Trigger.Request())
    wait_until(future.done, timeout, f"the {name} service")
    g.probe.node.destroy_client(client)
    return future.result()


class Goal:
    """A run_program goal sent from the probe."""

    def __init__(self, g, program="", resume="", name="test"):
        from plotter_interfaces.action import RunProgram
        self.client = g.probe.action_client(RunProgram, "run_program")
        assert self.client.wait_for_server(timeout_sec=30)
        self.feedback = []
        send = self.client.send_goal_async(RunProgram.Goal(program=program, name=name, resume=resume),
                                           feedback_callback=lambda fb: self.feedback.append(fb.feedback))
        wait_until(send.done, 30, "goal acceptance")
        self.handle = send.result()
        assert self.handle.accepted
        self.future = self.handle.get_result_async()

    def result(self, timeout=120):
        wait_until(self.future.done, timeout, "the program's result")
        return self.future.result()


def zigzag(n, y0=60.0, feed=2400):
    """A pen-down zig-zag of n lines (about n * 0.2 s at this feed)."""
    lines = ["G21 G90", "G0 X40 Y%.1f" % y0, "M3", f"F{feed}"]
    for k in range(n):
        lines.append(f"G1 X{40 + 8 * ((k + 1) % 2)} Y{y0 + 0.5 * (k + 1):.1f}")
    lines += ["M5", "M2"]
    return "\n".join(lines) + "\n"


def program_commands(text, start_steps):
    from plotter_bridge.motion.compiler import StreamerConfig, compile_program
    return compile_program(text, StreamerConfig(), start_steps)


def end_of(commands, start):
    x, y = start
    for c in commands:
        if c.is_motion:
            x, y = x + c.args[0], y + c.args[1]
    return x, y


def new_seq(g, before):
    return read_seq_log(g.seq_log)[before:]


def consecutive(seqs):
    return all(isinstance(a, int) and isinstance(b, int) and b == (a + 1) % 65536
               for a, b in zip(seqs, seqs[1:]))


def wait_running(g, t0):
    from plotter_interfaces.msg import BoardState
    wait_until(lambda: any(s.state == BoardState.RUNNING for s in states_since(g, t0)), 30, "RUNNING")


def wait_under_way(g, seq_before):
    """Wait until the board has started UNDER_WAY commands after the first `seq_before` of its log."""
    wait_until(lambda: len(new_seq(g, seq_before)) >= UNDER_WAY, 60, f"{UNDER_WAY} of the job's commands on the board")


def wait_board_rest(g, t0, timeout=60):
    """Wait for a state reported after t0 in which the board moves no more (IDLE with an empty
    queue, or ALARM); returns the length of the step trace, whole by then: the mock board
    flushes it before it can report either."""
    from plotter_interfaces.msg import BoardState

    def at_rest(s):
        return (s.state == BoardState.IDLE and s.queue_free == s.queue_size) or s.state == BoardState.ALARM
    wait_until(lambda: any(at_rest(s) for s in states_since(g, t0)), timeout, "the board at rest")
    return len(read_trace(g.trace))


def endpoints(g, dds_topic):
    """The GIDs of the readers the probe knows of on a DDS topic (a service's request topic too)."""
    return {bytes(i.endpoint_gid) for i in g.probe.node.get_subscriptions_info_by_topic(dds_topic, no_mangle=True)}


# --- bad input on every interface ------------------------------------------------------

def test_bad_inputs_are_refused_and_no_node_dies(graph):
    from action_msgs.msg import GoalStatus
    from std_msgs.msg import String
    from plotter_interfaces.action import StreamCommands
    from plotter_interfaces.msg import ShapeGoal

    errors = {"shape_error": [], "program_error": []}
    subs = [graph.probe.node.create_subscription(String, topic, lambda m, seen=seen: seen.append(m.data), 50)
            for topic, seen in errors.items()]
    shape_pub = graph.probe.node.create_publisher(ShapeGoal, "shape", 50)
    program_pub = graph.probe.node.create_publisher(String, "program", 50)
    wait_until(lambda: shape_pub.get_subscription_count() > 0 and program_pub.get_subscription_count() > 0
               and all(sub.get_publisher_count() > 0 for sub in subs), 30, "the topics to connect")
    before = len(read_trace(graph.trace))
    bad_shapes = [ShapeGoal(shape="hexagon", size=40.0), ShapeGoal(shape="star", size=math.nan),
                  ShapeGoal(shape="star", size=math.inf), ShapeGoal(shape="circle", size=-5.0),
                  ShapeGoal(shape="circle", size=1e12), ShapeGoal(shape="star", x=math.nan, y=3.0),
                  ShapeGoal(shape="star", feed=-1.0), ShapeGoal(shape="line", x=10.0, y=10.0, x2=1e9, y2=10.0),
                  ShapeGoal(shape="\x00" * 1000)]
    for goal in bad_shapes:
        shape_pub.publish(goal)
    # Each with the reason its error must give, at line 1 (a ROS string ends at its NUL: the
    # third arrives empty).
    bad_programs = {"G1 X10 Q5\n": "unsupported word letter 'Q'", "G0 X1000\n": "outside the work area",
                    "\x00\xff garbage": "empty program", "G2 X10 I0 J0 F100\n": "zero-radius arc",
                    "G1 X" + "9" * 5000 + "\n": "line too long", "(" * 100000: "unclosed comment",
                    "G0 X1e400\n": "unsupported word letter 'E'"}
    for text in bad_programs:
        program_pub.publish(String(data=text))
    try:
        wait_until(lambda: len(errors["shape_error"]) >= len(bad_shapes), 30, "a reason for every bad shape")
        wait_until(lambda: len(errors["program_error"]) >= len(bad_programs), 60,
                   "a reason for every bad program")
    finally:
        print(errors)
    for reason in bad_programs.values():
        named = [e for e in errors["program_error"] if "line 1: " in e and reason in e]
        assert len(named) == 1, (reason, errors["program_error"])

    # run_program goals: each fails with a message naming the reason.
    for kw, word in ((dict(program="G1 X10 Y10 F100\nG1 X500\n"), "line 2"),
                     (dict(program="G0 X1\n", name="x" * 500), "name"),
                     (dict(resume="not-a-job"), "not a job id"),
                     (dict(resume="0" * 32), "not in the journal")):
        res = Goal(graph, **kw).result()
        assert res.status == GoalStatus.STATUS_ABORTED and word in res.result.message, res.result.message

    # stream_commands goals the bridge must not take: refused outright.
    client = graph.probe.action_client(StreamCommands, "stream_commands")
    assert client.wait_for_server(timeout_sec=20)
    for goal in (StreamCommands.Goal(commands=[]), StreamCommands.Goal(commands=["L 1 1", "N5 L 1 1 *3"]),
                 StreamCommands.Goal(commands=["\x18"]), StreamCommands.Goal(commands=["L 1 1"], lines=[1, 2])):
        send = client.send_goal_async(goal)
        wait_until(send.done, 20, "goal response")
        assert not send.result().accepted

    time.sleep(0.5)
    assert len(read_trace(graph.trace)) == before, "nothing moved"
    for p in graph.processes:
        assert p.alive(), f"{p.module} died:\n{p.output()}"
    res = Goal(graph, program="G21 G90\nG0 X20 Y20\nM2\n").result()
    assert res.result.success, res.result.message


# --- the port vanishes --------------------------------------------------------------------

def test_port_unplugged_and_back_mid_job_resumes_exactly(graph):
    from plotter_interfaces.msg import BoardState
    st = latest(graph)
    start = (st.x_steps, st.y_steps)
    text = zigzag(40)
    commands = program_commands(text, start)
    seq_before = len(read_seq_log(graph.seq_log))
    t0 = time.monotonic()
    goal = Goal(graph, text)
    wait_running(graph, t0)
    wait_under_way(graph, seq_before)
    assert call(graph, "mock_board/unplug").success
    assert not goal.future.done(), "the job was over before the port went"
    res = goal.result()
    assert res.result.success, res.result.message
    seen = states_since(graph, t0)
    assert any(s.state == BoardState.DISCONNECTED for s in seen), "the bridge said it was disconnected"
    assert any("resumed" in s.last_error for s in seen)
    end = end_of(commands, start)
    assert read_trace(graph.trace)[-1][1:] == end, "final position exact to the step"
    seqs = new_seq(graph, seq_before)
    assert len(seqs) == sum(1 for c in commands if c.verb != "L" or c.args != (0, 0))
    assert consecutive(seqs), f"every command once, in order: {seqs}"


# --- emergency stop ------------------------------------------------------------------------

def test_estop_mid_job_stops_and_nothing_queued_runs_after(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.msg import BoardState
    seq_before = len(read_seq_log(graph.seq_log))
    t0 = time.monotonic()
    goal = Goal(graph, zigzag(30, y0=100.0))
    wait_running(graph, t0)
    wait_under_way(graph, seq_before)
    t_stop = time.monotonic()
    assert call(graph, "estop").success
    res = goal.result()
    assert res.status == GoalStatus.STATUS_ABORTED and "emergency stop" in res.result.message
    assert f"plotter resume {res.result.job_id} finishes it" in res.result.message, "where and how to go on"
    wait_until(lambda: latest(graph).state == BoardState.ALARM, 10, "ALARM")
    n = wait_board_rest(graph, t_stop)
    seqs = read_seq_log(graph.seq_log)
    time.sleep(1.5)
    assert len(read_trace(graph.trace)) == n, "moved after the emergency stop"
    assert read_seq_log(graph.seq_log) == seqs, "a command queued before the stop ran after it"
    refused = Goal(graph, "G21 G90\nG1 X50 Y50 F1000\nM2\n").result()
    assert not refused.result.success and "alarm" in refused.result.message
    assert call(graph, "reset").success
    wait_until(lambda: latest(graph).state == BoardState.IDLE, 10, "IDLE after reset")
    assert latest(graph).position_known, "an emergency stop keeps the position"


# --- the streamer dies; the bridge draws the job to its end -----------------------------------

def test_streamer_killed_mid_job_the_bridge_finishes_it_and_resume_says_done(graph):
    from plotter_bridge.link.journal import Journal
    st = latest(graph)
    start = (st.x_steps, st.y_steps)
    text = zigzag(50, y0=120.0)
    commands = program_commands(text, start)
    seq_before = len(read_seq_log(graph.seq_log))
    t0 = time.monotonic()
    Goal(graph, text)
    wait_running(graph, t0)
    wait_under_way(graph, seq_before)
    os.kill(graph.streamer.proc.pid, signal.SIGKILL)
    graph.streamer.proc.wait()
    wait_until(lambda: len(new_seq(graph, seq_before)) == len(commands), 60, "the whole job on the board")
    wait_board_rest(graph, time.monotonic())
    assert read_trace(graph.trace)[-1][1:] == end_of(commands, start), "drawn to its end, exact to the step"
    seqs = new_seq(graph, seq_before)
    assert consecutive(seqs), f"every command once, in order: {seqs}"
    jobs = Journal(graph.journal).jobs()
    job_id, progress, _ = jobs[0]
    assert progress.state == "running" and progress.completed < len(commands), "the streamer died mid-job"

    # A new streamer resumes the job from its journal: the bridge says it is done, nothing moves.
    # The dead streamer stays in the ROS graph until its DDS lease ends, and may leave it any time:
    # wait for readers the probe did not know before, the new streamer's, on its program topic and
    # on the requests of its run_program action (a goal sent before they match is lost).
    topics = ("rt/plotter/program", "rq/plotter/run_program/_action/send_goalRequest",
              "rq/plotter/run_program/_action/get_resultRequest")
    old = {t: endpoints(graph, t) for t in topics}
    graph.restart_streamer()
    wait_until(lambda: all(endpoints(graph, t) - old[t] for t in topics), 30, "the new streamer")
    n = len(read_trace(graph.trace))
    res = Goal(graph, resume=job_id).result()
    assert res.result.success and "already done" in res.result.message, res.result.message
    time.sleep(0.5)
    assert len(read_trace(graph.trace)) == n
    assert new_seq(graph, seq_before) == seqs


# --- the board resets ---------------------------------------------------------------------------

def test_board_reset_mid_job_aborts_and_position_is_unknown_until_set_origin(graph):
    from action_msgs.msg import GoalStatus
    seq_before = len(read_seq_log(graph.seq_log))
    t0 = time.monotonic()
    goal = Goal(graph, zigzag(30, y0=150.0))
    wait_running(graph, t0)
    wait_under_way(graph, seq_before)
    assert call(graph, "mock_board/power_cycle").success
    res = goal.result()
    assert res.status == GoalStatus.STATUS_ABORTED
    assert "board reset" in res.result.message and "position is unknown" in res.result.message
    wait_until(lambda: not latest(graph).position_known, 10, "position_known false")
    n = wait_board_rest(graph, time.monotonic())
    time.sleep(1.0)
    assert len(read_trace(graph.trace)) == n
    log = read_seq_log(graph.seq_log)
    assert log[-1] == "reset", "nothing ran after the reset"
    refused = Goal(graph, "G21 G90\nG1 X5 Y5 F1000\nM2\n").result()
    assert not refused.result.success and "set_origin" in refused.result.message
    assert call(graph, "set_origin").success
    wait_until(lambda: latest(graph).position_known, 10, "position_known after set_origin")
    res = Goal(graph, "G21 G90\nG0 X5 Y5\nM2\n").result()
    assert res.result.success, res.result.message
