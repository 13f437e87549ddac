"""The hanging plotter (seed 003) end to end through the node graph on the mock board:
each node a process with `machine:=hanging`, a 50 cm circle from G-code, the
trace, /plotter/position and /plotter/planned_path in pen coordinates; a
line where the tolerance cannot be held is refused and nothing moves."""
import math
import threading
import time
from typing import Sequence, Tuple

import pytest

from node_processes import new_domain
from ros_graph import PlotterGraph, Probe, wait_until

pytestmark = pytest.mark.ros

STEPS_PER_MM = 80.0


def test_hanging_circle_through_the_graph_stays_within_a_tenth_of_a_millimetre(tmp_path):
    from action_msgs.msg import GoalStatus
    from geometry_msgs.msg import PointStamped
    from nav_msgs.msg import Path
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.action import RunProgram

    domain = new_domain()
    hanging = ("-p", "machine:=hanging")
    # Up to 20 mm below the pulleys: beyond the accurate area at the top.
    area = ("-p", "x_max:=800.0", "-p", "y_max:=1130.0")
    graph = PlotterGraph(domain, tmp_path, board_args=hanging, bridge_args=hanging,
                         streamer_args=hanging + area)
    probe = Probe(domain)
    positions = []
    lock = threading.Lock()

    def on_position(m):
        with lock:
            positions.append((m.point.x * 1000, m.point.y * 1000))   # m -> mm
    probe.node.create_subscription(PointStamped, "position", on_position, 50)
    planned = []

    def on_planned(m):
        with lock:
            planned.append([(p.pose.position.x * 1000, p.pose.position.y * 1000) for p in m.poses])
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(Path, "planned_path", on_planned, latched)
    try:
        client = probe.action_client(RunProgram, "run_program")
        assert client.wait_for_server(timeout_sec=60)
        program = "G21 G90\nG0 X650 Y500\nM3\nG2 X650 Y500 I-250 J0 F6000\nM5\nM2\n"
        send = client.send_goal_async(RunProgram.Goal(program=program, name="hanging circle"))
        wait_until(send.done, 30, "goal acceptance")
        res = send.result().get_result_async()
        wait_until(res.done, 240, "the circle")
        result = res.result()
        assert result.status == GoalStatus.STATUS_SUCCEEDED, result.result.message
        assert result.result.x_mm == pytest.approx(650.0, abs=0.05)
        assert result.result.y_mm == pytest.approx(500.0, abs=0.05)
        pen = [(x / STEPS_PER_MM, y / STEPS_PER_MM) for _, x, y in read_trace_floats(graph.trace)]
        start = next(k for k, p in enumerate(pen) if math.hypot(p[0] - 650, p[1] - 500) < 0.05)
        worst = max(abs(math.hypot(x - 400, y - 500) - 250) for x, y in pen[start:])
        assert worst <= 0.1, worst
        # All the way round, too: a circle ends where it starts, drawn or not.
        assert largest_gap_deg(pen[start:], (400, 500)) < 0.5
        with lock:
            assert positions and math.hypot(positions[-1][0] - 650, positions[-1][1] - 500) < 0.05
        wait_until(lambda: bool(planned), 10, "/plotter/planned_path")
        with lock:
            plan = planned[-1]
        assert math.dist(plan[0], (0, 0)) < 0.05 and math.dist(plan[-1], (650, 500)) < 0.05, (plan[0], plan[-1])
        on_circle = next(k for k, p in enumerate(plan) if math.dist(p, (650, 500)) < 0.05)
        assert len(plan) - on_circle > 50
        assert max(abs(math.hypot(x - 400, y - 500) - 250) for x, y in plan[on_circle:]) <= 0.1

        steps = len(read_trace_floats(graph.trace))
        program = "G21 G90\nG0 X100 Y1000\nM3\nG1 X700 Y1100 F3000\nM5\n"
        send = client.send_goal_async(RunProgram.Goal(program=program, name="too near the pulleys"))
        wait_until(send.done, 30, "goal acceptance")
        res = send.result().get_result_async()
        wait_until(res.done, 30, "the refusal")
        result = res.result()
        assert result.status == GoalStatus.STATUS_ABORTED
        assert "line 4" in result.result.message and "cannot be held within 0.1 mm" in result.result.message \
            and " Y10" in result.result.message, result.result.message
        time.sleep(1.0)       # a step taken now would be in the trace by then
        assert len(read_trace_floats(graph.trace)) == steps, "nothing moved"
        with lock:
            assert math.hypot(positions[-1][0] - 650, positions[-1][1] - 500) < 0.05
    except BaseException:
        print(graph.outputs())
        raise
    finally:
        probe.close()
        graph.close()


def largest_gap_deg(points: Sequence[Tuple[float, float]], centre: Tuple[float, float]) -> float:
    """The widest angle round `centre` that none of the points lies in."""
    angles = sorted(math.degrees(math.atan2(y - centre[1], x - centre[0])) for x, y in points)
    return max(b - a for a, b in zip(angles, angles[1:] + [angles[0] + 360.0]))


def read_trace_floats(path):
    with open(path) as f:
        rows = [line.strip().split(",") for line in f]
    assert rows[0] == ["t_s", "x_steps", "y_steps"]
    return [(float(t), float(x), float(y)) for t, x, y in rows[1:]]
