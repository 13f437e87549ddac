"""The whole node graph, launch-less, each node its own process, on the mock board.

A shape goal is published exactly as `ros2 topic pub --once /plotter/shape
plotter_interfaces/msg/ShapeGoal "{shape: star, size: 40.0}"` would; the
mock board's step trace and /plotter/position show what was drawn.
"""
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

from node_processes import new_domain
from ros_graph import HELD_REPORTS, PlotterGraph, Probe, distance_to_segment, held_still, read_trace, wait_until

pytestmark = pytest.mark.ros

STEPS_PER_MM = 80.0
REPO = Path(__file__).resolve().parent.parent


@contextmanager
def watched_graph(workdir):
    """The graph, with a probe that records /plotter/position and
    /plotter/state and can publish shape goals; the nodes must stop cleanly.
    Its link runs at 115200 baud (firmware built with BAUD=115200), so that
    /plotter/position comes at serial_bridge's status_hz while the board
    draws; the default 9600 carries a twelfth of its bytes, and so of its
    status reports."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from geometry_msgs.msg import PointStamped
    from plotter_interfaces.msg import BoardState, ShapeGoal

    domain = new_domain()
    fast = ("-p", "baud:=115200")
    g = PlotterGraph(domain, workdir, bridge_args=fast, board_args=fast)
    probe = Probe(domain)
    g.probe = probe
    g.positions, g.states = [], []
    lock = threading.Lock()
    g.lock = lock

    def on_pos(m):
        stamp = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        with lock:
            g.positions.append((time.monotonic(), m.point.x * 1000, m.point.y * 1000, stamp))   # m -> mm

    def on_state(m):
        with lock:
            g.states.append((time.monotonic(), m.state, m.queue_free, m.x_steps, m.y_steps))

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(PointStamped, "position", on_pos, 50)
    probe.node.create_subscription(BoardState, "state", on_state, latched)
    g.shape_pub = probe.node.create_publisher(ShapeGoal, "shape", 10)
    try:
        wait_until(lambda: any(s[1] == BoardState.IDLE for s in g.states), 60, "the bridge's first IDLE state")
        yield g
    except BaseException:
        print(g.outputs())
        raise
    finally:
        probe.close()
        codes = g.close()
    assert all(c == 0 for c in codes), f"nodes did not exit cleanly on Ctrl-C: {codes}\n"


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    with watched_graph(tmp_path_factory.mktemp("graph")) as g:
        yield g


def wait_idle_after(g, t0, timeout=120):
    """Wait for RUNNING after t0, then IDLE with an empty queue."""
    from plotter_interfaces.msg import BoardState

    def ran_and_stopped():
        with g.lock:
            after = [s for s in g.states if s[0] >= t0]
        seen_run = [k for k, s in enumerate(after) if s[1] == BoardState.RUNNING]
        return bool(seen_run) and any(s[1] == BoardState.IDLE and s[2] == 6 for s in after[seen_run[0]:])
    wait_until(ran_and_stopped, timeout, "the board to run and come to rest")


def wait_rest_after(g, t0, timeout=30):
    """Wait for IDLE with an empty queue reported after t0.  The mock board flushes its
    trace before it can report itself at rest, so every step is in the trace by then."""
    from plotter_interfaces.msg import BoardState

    def at_rest():
        with g.lock:
            return any(s[0] >= t0 and s[1] == BoardState.IDLE and s[2] == 6 for s in g.states)
    wait_until(at_rest, timeout, "the board at rest")


def wait_held_still(g, timeout=30):
    """Wait until the board, holding, has come to rest (ros_graph.held_still)."""
    def still():
        with g.lock:
            reports = [(s[1], s[3], s[4]) for s in g.states[-HELD_REPORTS:]]
        return held_still(reports, g.trace)
    wait_until(still, timeout, "the pen at rest in HOLD")


def reference_path(figure, start):
    """The figure's segments plus the straight pen-up travel to and between strokes."""
    from plotter_shapes.geometry import Line
    segs, here = [], start
    for stroke in figure.strokes:
        if stroke.start != here:
            segs.append(Line(here[0], here[1], *stroke.start))
        segs.extend(stroke.segments)
        here = stroke.end
    return segs


def scaled(seg):
    """A geometry segment in steps."""
    from dataclasses import replace
    fields = {k: getattr(seg, k) * STEPS_PER_MM for k in ("x0", "y0", "x1", "y1", "cx", "cy") if hasattr(seg, k)}
    return replace(seg, **fields)


def check_trace_follows(trace, segments, tolerance_steps=1.5):
    segs = [scaled(s) for s in segments]
    worst = 0.0
    for _, x, y in trace:
        d = min(distance_to_segment((x, y), s) for s in segs)
        worst = max(worst, d)
    assert worst <= tolerance_steps, f"trace strays {worst:.2f} steps from the figure"


def path_order(points, segments, tolerance_steps=1.5):
    """For each point (in steps) the index of the first segment, at or after the previous
    point's, that it lies on: the points are on the path and in the path's order."""
    segs = [scaled(s) for s in segments]
    k, order = 0, []
    for p in points:
        j = next((j for j in range(k, len(segs)) if distance_to_segment(p, segs[j]) <= tolerance_steps), None)
        assert j is not None, f"{p} is not on the path at or after segment {k}: {segments[k]}"
        order.append(j)
        k = j
    return order


def test_star_from_a_topic_message_is_drawn(graph):
    from plotter_interfaces.msg import ShapeGoal
    from plotter_shapes.geometry import build_shape

    wait_until(lambda: graph.shape_pub.get_subscription_count() > 0, 30, "shape_server subscription")
    # shape_server publishes the program once: the streamer must already listen.
    wait_until(lambda: graph.probe.node.count_subscribers("program") > 0, 30, "gcode_streamer subscription")
    with graph.lock:
        start_steps = graph.states[-1][3:]
    start = tuple(v / STEPS_PER_MM for v in start_steps)
    t0 = time.monotonic()
    graph.shape_pub.publish(ShapeGoal(shape="star", size=40.0))
    wait_idle_after(graph, t0)
    figure = build_shape("star", None, None, 40.0)
    path = reference_path(figure, start)
    trace = read_trace(graph.trace)
    assert trace, "the board took no steps"
    check_trace_follows(trace, path)
    end = tuple(round(v * STEPS_PER_MM) for v in figure.end)
    assert trace[-1][1:] == end
    wait_until(lambda: graph.positions and abs(graph.positions[-1][1] * STEPS_PER_MM - end[0]) < 1e-6
               and abs(graph.positions[-1][2] * STEPS_PER_MM - end[1]) < 1e-6, 30, "final /plotter/position")
    # /plotter/position while moving: the board's position as it draws, in the order drawn, not
    # only where it stops.  How often it comes (serial_bridge's status_hz, 25 a second at 115200)
    # is a figure of the machine, measured by benchmarks/host_latency.py ("/plotter/position: gap
    # between arrivals"); a star takes some 10 s to draw, about 250 positions at that rate.
    with graph.lock:
        moving = [p for p in graph.positions if p[0] >= t0]
    stamps = [p[3] for p in moving]
    assert stamps == sorted(stamps), "position stamps go back in time"
    points = [(x * STEPS_PER_MM, y * STEPS_PER_MM) for _, x, y, _ in moving]
    order = path_order(points, path)
    first_stroke = len(path) - len(figure.strokes[0].segments)
    corners = {(round(s.x0 * STEPS_PER_MM), round(s.y0 * STEPS_PER_MM)) for s in path} | {end}
    drawing = {(round(x), round(y)) for (x, y), k in zip(points, order) if k >= first_stroke} - corners
    assert len(drawing) >= 2 * len(figure.strokes[0].segments), \
        f"{len(drawing)} distinct positions between the star's corners: {sorted(drawing)}"
    assert order[-1] == len(path) - 1, "the last position is on the star's last side"


def run_program(graph, text, cancel_when=None):
    from plotter_interfaces.action import RunProgram

    client = graph.probe.action_client(RunProgram, "run_program")
    assert client.wait_for_server(timeout_sec=30)
    feedback = []
    goal = RunProgram.Goal(program=text, name="test")
    send = client.send_goal_async(goal, feedback_callback=lambda fb: feedback.append(fb.feedback))
    wait_until(send.done, 30, "goal acceptance")
    handle = send.result()
    assert handle.accepted
    res = handle.get_result_async()
    if cancel_when is not None:
        wait_until(cancel_when, 60, "the moment to cancel")
        handle.cancel_goal_async()
    wait_until(res.done, 300, "the program's result")
    return res.result(), feedback


def test_gcode_program_through_the_action(graph):
    from action_msgs.msg import GoalStatus
    square = "\n".join(["G21 G90", "G0 X20 Y20", "M3", "G1 X60 Y20 F3000", "G1 X60 Y60",
                        "G2 X20 Y60 I-20 J0", "G1 X20 Y20", "M5", "G0 X30 Y30", "M2"])
    result, feedback = run_program(graph, square)
    assert result.status == GoalStatus.STATUS_SUCCEEDED, result.result.message
    assert result.result.success
    assert (result.result.x_mm, result.result.y_mm) == (30.0, 30.0)
    assert feedback and feedback[-1].total_lines >= 9
    assert read_trace(graph.trace)[-1][1:] == (2400, 2400)


def test_bad_program_is_refused_before_anything_moves(graph):
    from action_msgs.msg import GoalStatus
    before = read_trace(graph.trace)
    result, _ = run_program(graph, "G21 G90\nG1 X10 Y10 F1000\nG1 X10 Y900\nM2\n")
    assert result.status == GoalStatus.STATUS_ABORTED
    assert "line 3" in result.result.message and "work area" in result.result.message
    time.sleep(0.3)
    assert read_trace(graph.trace) == before


def test_cancel_stops_the_board_and_nothing_moves_after(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.msg import BoardState
    slow = "G21 G90\nM3\n" + "".join(f"G1 X{150 if k % 2 == 0 else 40} Y{40 + k} F600\n" for k in range(40)) + "M2\n"
    with graph.lock:
        start = graph.states[-1][3:]
    t0 = time.monotonic()

    def moving():
        # Cancelled once the pen has left its start: of the job's 40 lines of some 11 s each, most are to come.
        with graph.lock:
            return any(s[0] >= t0 and s[1] == BoardState.RUNNING and s[3:] != start for s in graph.states)
    result, _ = run_program(graph, slow, cancel_when=moving)
    assert result.status == GoalStatus.STATUS_CANCELED
    wait_rest_after(graph, time.monotonic())
    n = len(read_trace(graph.trace))
    time.sleep(1.0)
    assert len(read_trace(graph.trace)) == n, "the board kept moving after the cancel"


def test_a_program_past_the_old_four_megabytes_from_the_topic_is_drawn(graph):
    """/plotter/program takes what the streamer takes (MAX_PROGRAM_BYTES, 64 MB): a 5 MB random walk
    of 1.5 mm segments (benchmarks/big_drawing.py) is checked whole, then drawn; stopped here with
    the emergency stop once the pen has drawn part of it (it would take hours)."""
    import io
    import sys
    from std_msgs.msg import String
    from plotter_interfaces.msg import BoardState
    sys.path.insert(0, str(REPO / "benchmarks"))
    import big_drawing
    out = io.StringIO()
    big_drawing.write(275_000, out)
    text = out.getvalue()
    assert len(text) > 5 * 1024 * 1024
    publisher = graph.probe.node.create_publisher(String, "program", 10)
    wait_until(lambda: publisher.get_subscription_count() > 0, 30, "gcode_streamer subscription")
    first = read_trace(graph.trace)
    t0 = time.monotonic()
    publisher.publish(String(data=text))

    start = (round(100 * STEPS_PER_MM), round(100 * STEPS_PER_MM))      # the walk's first point, X100 Y100

    def drawing():
        steps = [s[1:] for s in read_trace(graph.trace)[len(first):]]
        return start in steps and len(steps) - steps.index(start) > 200
    wait_until(drawing, 240, "the 5 MB program to be checked and its drawing to start")
    with graph.lock:
        assert any(s[0] >= t0 and s[1] == BoardState.RUNNING for s in graph.states)
    assert call(graph, "estop").success
    wait_until(lambda: graph.states[-1][1] == BoardState.ALARM, 10, "ALARM")
    assert call(graph, "reset").success
    wait_until(lambda: graph.states[-1][1] == BoardState.IDLE, 10, "IDLE after reset")
    graph.probe.node.destroy_publisher(publisher)


def call(graph, name):
    from std_srvs.srv import Trigger
    client = graph.probe.node.create_client(Trigger, name)
    assert client.wait_for_service(timeout_sec=20), name
    future = client.call_async(Trigger.Request())
    wait_until(future.done, 20, f"the {name} service")
    graph.probe.node.destroy_client(client)
    return future.result()


def test_hold_resume_estop_reset_and_set_origin_services(graph):
    from plotter_interfaces.msg import BoardState
    from plotter_interfaces.action import RunProgram

    def latest():
        with graph.lock:
            return graph.states[-1]

    slow = "G21 G90\nM3\n" + "".join(f"G1 X{150 if k % 2 == 0 else 40} Y{60 + k} F900\n" for k in range(20)) + "M2\n"
    client = graph.probe.action_client(RunProgram, "run_program")
    assert client.wait_for_server(timeout_sec=30)
    send = client.send_goal_async(RunProgram.Goal(program=slow, name="services"))
    wait_until(send.done, 30, "goal acceptance")
    result = send.result().get_result_async()
    wait_until(lambda: latest()[1] == BoardState.RUNNING, 30, "RUNNING")

    assert call(graph, "hold").success
    wait_until(lambda: latest()[1] == BoardState.HOLD, 10, "HOLD")
    wait_held_still(graph)
    held = len(read_trace(graph.trace))
    time.sleep(0.5)
    assert len(read_trace(graph.trace)) == held, "moved while held"
    assert call(graph, "resume").success
    wait_until(lambda: latest()[1] == BoardState.RUNNING, 10, "RUNNING after resume")

    assert call(graph, "estop").success
    wait_until(result.done, 30, "the program to end on the emergency stop")
    assert not result.result().result.success
    wait_until(lambda: latest()[1] == BoardState.ALARM, 10, "ALARM")
    stopped = read_trace(graph.trace)
    time.sleep(1.0)
    assert read_trace(graph.trace) == stopped, "moved after the emergency stop"
    refused, _ = run_program(graph, "G21 G90\nG1 X50 Y50 F1000\nM2\n")
    assert not refused.result.success and "alarm" in refused.result.message

    assert call(graph, "reset").success
    wait_until(lambda: latest()[1] == BoardState.IDLE, 10, "IDLE after reset")
    assert call(graph, "set_origin").success
    wait_until(lambda: latest()[3:] == (0, 0), 10, "position 0,0 after set_origin")
    graph.origin_moved = stopped[-1][1:]


def test_watch_prints_live_positions(graph):
    import os
    import subprocess
    env = dict(os.environ, ROS_DOMAIN_ID=str(graph.domain))
    watch = subprocess.Popen([str(REPO / ".venv" / "bin" / "plotter"), "watch", "--count", "5", "--timeout", "60"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    result, _ = run_program(graph, "G21 G90\nG1 X30 Y30 F3000\nG1 X10 Y10\nM2\n")
    out, err = watch.communicate(timeout=90)
    assert watch.returncode == 0, err
    rows = [line for line in out.splitlines() if " X " in line and " Y " in line]
    assert len(rows) >= 5
