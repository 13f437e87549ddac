"""Line following on the node graph: the mock board node with a sheet under
its pen (`-p sheet:=LINE.gcode`, the core built with FOLLOW=1), the serial
bridge streaming the board's `F` as any job, and `/plotter/state` saying
what the sensors read, why the follow stopped and the steps it took."""
from __future__ import annotations

import math
import threading

import pytest

from follow_lines import distances, path_length
from node_processes import NodeProcess, PlotterGraph, new_domain, read_trace, wait_until
from ros_graph import Probe

pytestmark = pytest.mark.ros

SPM = 80.0
CIRCLE = "G21 G90\nG0 X112 Y100\nM3\nG3 X112 Y100 I-12 J0 F600\nM5\n"   # r12 round (100, 100)


def circle_points(n: int = 720):
    return [(100.0 + 12.0 * math.cos(2 * math.pi * k / n), 100.0 + 12.0 * math.sin(2 * math.pi * k / n))
            for k in range(n + 1)]


def test_the_bridge_streams_f_to_a_board_over_a_sheet_and_state_says_why_it_stopped(tmp_path):
    from action_msgs.msg import GoalStatus
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.action import StreamCommands
    from plotter_interfaces.msg import BoardState

    sheet = tmp_path / "circle.gcode"
    sheet.write_text(CIRCLE)
    domain = new_domain()
    graph = PlotterGraph(domain, tmp_path, board_args=("-p", f"sheet:={sheet}", "-p", "sheet_start:=112,100"))
    probe = Probe(domain)
    states, lock = [], threading.Lock()

    def keep(m):
        with lock:
            states.append(m)
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(BoardState, "state", keep, latched)
    try:
        wait_until(lambda: any(s.state == BoardState.IDLE for s in states), 60, "IDLE")
        with lock:
            idle = states[-1]
        assert idle.has_sensors and idle.sensors == 7 and idle.follow_state_name == "none"
        client = probe.action_client(StreamCommands, "stream_commands")
        assert client.wait_for_server(timeout_sec=30)
        future = client.send_goal_async(StreamCommands.Goal(commands=["F 6 400 0 280"]))
        wait_until(future.done, 30, "the goal's answer")
        result = future.result().get_result_async()
        wait_until(result.done, 120, "the follow's end")
        assert result.result().status == GoalStatus.STATUS_SUCCEEDED

        def came_home():
            with lock:
                return states[-1].follow_state_name == "home"
        # The job ends on a status report at rest, which the probe may take a while to receive.
        wait_until(came_home, 30, "a state saying home")
        with lock:
            end = states[-1]
            running = [s for s in states if s.follow_state_name == "running"]
        assert running and any(0 < s.followed_steps < 6000 for s in running)
        assert (end.state_name, end.follow_state_name) == ("IDLE", "home")
        trace = [(112.0 + x / SPM, 100.0 + y / SPM) for _, x, y in read_trace(graph.trace)]
        assert len(trace) == end.followed_steps
        assert 0.98 <= path_length([(112.0, 100.0)] + trace) / (2 * math.pi * 12.0) <= 1.15   # once round
        assert distances(trace[::4], [circle_points()]).max() < 3.5
        assert math.dist(trace[-1], (112.0, 100.0)) <= 4.5
    finally:
        probe.close()
        graph.close()


def test_a_sheet_the_mock_board_cannot_use_ends_it_with_one_clear_line(tmp_path):
    missing = NodeProcess("plotter_bridge.nodes.mock_board", new_domain(),
                          ("-p", f"sheet:={tmp_path / 'none.gcode'}", "-p", f"link:={tmp_path / 'pty'}"))
    hanging = NodeProcess("plotter_bridge.nodes.mock_board", new_domain(),
                          ("-p", f"sheet:={tmp_path / 'none.gcode'}", "-p", "machine:=hanging",
                           "-p", f"link:={tmp_path / 'pty2'}"))
    try:
        wait_until(lambda: not missing.alive() and not hanging.alive(), 30, "both nodes to refuse")
        assert "none.gcode" in missing.output() and "No such file" in missing.output()
        assert "XY table only" in hanging.output()
    finally:
        missing.close()
        hanging.close()
