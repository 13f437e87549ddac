"""Line following on the node graph: the mock board node with a sheet under
its pen (`-p sheet:=LINE.gcode`, the core built with FOLLOW=1); the serial
bridge streaming the board's `F` as any job, and `/plotter/state` saying
what the sensors read, why the follow stopped and the steps it took;
gcode_streamer's `follow_line` action, and `plotter follow` sending it to
the running graph.  One graph serves the module: a ring of r12 round
(100, 100) drawn 7 mm wide, the pen on its right-hand side at power-on, so
that the machine's origin is the sheet's (112, 100) and the ring's centre
is at machine X-12 Y0; the streamer's work area starts at X-50 Y-50 to
hold it."""
from __future__ import annotations

import math
import re
import subprocess
import threading
from pathlib import Path

import pytest

from follow_lines import distances, path_length
from node_processes import NodeProcess, new_domain, read_trace, wait_until
from ros_graph import last_state, watched_graph

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parent.parent
PLOTTER = str(REPO / ".venv" / "bin" / "plotter")
SPM = 80.0
CIRCLE = "G21 G90\nG0 X112 Y100\nM3\nG3 X112 Y100 I-12 J0 F600\nM5\n"   # r12 round (100, 100)
RING = 2 * math.pi * 12.0
ORIGIN = (112.0, 100.0)           # the sheet's point under the pen at power-on: the machine's origin


def circle_points(n: int = 720):
    return [(100.0 + 12.0 * math.cos(2 * math.pi * k / n), 100.0 + 12.0 * math.sin(2 * math.pi * k / n))
            for k in range(n + 1)]


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("follow")
    sheet = tmp / "circle.gcode"
    sheet.write_text(CIRCLE)
    with watched_graph(tmp, board_args=("-p", f"sheet:={sheet}", "-p", "sheet_start:=112,100"),
                       streamer_args=("-p", "x_min:=-50.0", "-p", "y_min:=-50.0")) as g:
        yield g


def pen_trace(graph, start: int = 0):
    """The mock board's pen (mm) from row `start` of its trace on (it counts from the sheet's start)."""
    return [(ORIGIN[0] + x / SPM, ORIGIN[1] + y / SPM) for _, x, y in read_trace(graph.trace)[start:]]


def plotter(graph, *args, timeout=180):
    return subprocess.run([PLOTTER, *args], capture_output=True, text=True, env=graph.env, timeout=timeout)


def test_the_bridge_streams_f_to_a_board_over_a_sheet_and_state_says_why_it_stopped(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import StreamCommands

    idle = last_state(graph)
    assert idle.has_sensors and idle.sensors == 7 and idle.follow_state_name == "none"
    client = graph.probe.action_client(StreamCommands, "stream_commands")
    assert client.wait_for_server(timeout_sec=30)
    future = client.send_goal_async(StreamCommands.Goal(commands=["F 6 400 0 280"]))
    wait_until(future.done, 30, "the goal's answer")
    result = future.result().get_result_async()
    wait_until(result.done, 120, "the follow's end")
    assert result.result().status == GoalStatus.STATUS_SUCCEEDED
    # The bridge's result says how the follow ended, as the board's last status did.
    assert (result.result().result.follow_state, result.result().result.followed_steps > 0) == (2, True)
    # The job ends on a status report at rest, which the probe may take a while to receive.
    wait_until(lambda: last_state(graph).follow_state_name == "home", 30, "a state saying home")
    with graph.lock:
        end = graph.states[-1]
        running = [s for s in graph.states if s.follow_state_name == "running"]
    assert running and any(0 < s.followed_steps < 6000 for s in running)
    assert (end.state_name, end.follow_state_name) == ("IDLE", "home")
    assert result.result().result.followed_steps == end.followed_steps
    trace = pen_trace(graph)
    assert len(trace) == end.followed_steps
    assert 0.98 <= path_length([(112.0, 100.0)] + trace) / RING <= 1.15   # once round
    assert distances(trace[::4], [circle_points()]).max() < 3.5
    assert math.dist(trace[-1], (112.0, 100.0)) <= 4.5


def test_follow_line_goes_to_the_start_follows_home_and_reports_in_mm(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import FollowLine

    before = len(read_trace(graph.trace))
    feedback, lock = [], threading.Lock()

    def keep(fb):
        with lock:
            feedback.append(fb.feedback)
    client = graph.probe.action_client(FollowLine, "follow_line")
    assert client.wait_for_server(timeout_sec=30)
    # Clockwise this time, setting out downwards (270 degrees) from the ring's right-hand side.
    goal = FollowLine.Goal(start_x_mm=0.0, start_y_mm=0.0, heading_deg=270.0, feed_mm_s=2.5)
    future = client.send_goal_async(goal, feedback_callback=keep)
    wait_until(future.done, 30, "the goal's answer")
    assert future.result().accepted
    done = future.result().get_result_async()
    wait_until(done.done, 150, "the follow's end")
    assert done.result().status == GoalStatus.STATUS_SUCCEEDED, done.result().result.message
    r = done.result().result
    assert (r.success, r.reason) == (True, "home")
    assert r.message.startswith(f"home after {r.steps} steps")
    trace = pen_trace(graph, before)
    travel = len(trace) - r.steps                      # the pen-up move to the start came first
    assert 0 <= travel < 5 * SPM
    followed = trace[travel:]
    assert math.dist(trace[travel - 1] if travel else trace[0], (112.0, 100.0)) < 0.05
    # The length is the path through the positions reported a few times a second: within a few per cent
    # of the step trace's own, which is the ring's once round.
    assert 0.95 <= r.length_mm / path_length([(112.0, 100.0)] + followed) <= 1.02
    assert 0.95 <= r.length_mm / RING <= 1.15
    assert math.dist((ORIGIN[0] + r.x_mm, ORIGIN[1] + r.y_mm), followed[-1]) < 0.02
    assert distances(followed[::4], [circle_points()]).max() < 3.5
    with lock:
        running = [fb for fb in feedback if fb.steps > 0]
    assert running, "no feedback while it followed"
    assert [fb.steps for fb in running] == sorted(fb.steps for fb in running)
    assert all(fb.sensors for fb in running)           # on the line all the way: some sensor on black
    assert any(0 < fb.length_mm < r.length_mm for fb in running)


def test_plotter_follow_on_the_running_graph_stops_at_the_distance_or_where_the_line_is_lost(graph):
    before = len(read_trace(graph.trace))
    r = plotter(graph, "follow", "--start", "0", "0", "--heading", "90", "--distance", "20")
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.startswith("follow: distance after 1600 steps"), r.stdout
    assert len(read_trace(graph.trace)) - before >= 1600
    # From where the pen stands: no way to the start, and on along the line.
    x, y = re.search(r"pen at X(\S+) Y(\S+) mm", r.stdout).groups()
    r = plotter(graph, "follow", "--start", x, y, "--heading", "90", "--distance", "5")
    assert r.returncode == 0 and r.stdout.startswith("follow: distance after 400 steps"), r.stdout + r.stderr
    # Off the ring nothing is black: lost after --lost mm, and said so with a failure.
    r = plotter(graph, "follow", "--start", "40", "40", "--lost", "4")
    assert r.returncode == 1, r.stdout + r.stderr
    # The first step may still see the black the pen stands beside: 4 mm of white is 320 steps, give or take one.
    assert re.search(r"follow: lost after 3(19|20|21) steps \(4\.\d mm\), pen at X4\d\.\d+ Y40\.000 mm", r.stderr), \
        r.stderr


def test_a_follow_that_leaves_the_work_area_is_stopped_at_its_edge(graph):
    # White all the way from X195 along +X: lost only after 8 mm, past the area's edge at X200.
    r = plotter(graph, "follow", "--start", "195", "40", "--lost", "8")
    assert r.returncode == 1, r.stdout + r.stderr
    m = re.search(r"follow: the pen left the work area \(X -50\.\.200 mm, Y -50\.\.200 mm\) "
                  r"at X(\d+\.\d+) Y40\.000 mm; stopped after (\d+) steps", r.stderr)
    assert m, r.stderr
    # Positions come ten a second, 0.3 mm apart at 3.1 mm/s; a busy machine may take a few periods more.
    assert 200.0 < float(m.group(1)) <= 201.5
    x_end = read_trace(graph.trace)[-1][1] / SPM                  # machine mm: the trace counts from the origin
    assert 200.0 < x_end < 202.0 and int(m.group(2)) < 8 * SPM


def test_a_bad_follow_goal_is_refused_with_every_reason_and_nothing_moves(graph):
    before = len(read_trace(graph.trace))
    r = plotter(graph, "follow", "--start", "900", "100", "--feed", "9", "--lost", "-1")
    assert r.returncode == 1, r.stdout + r.stderr
    for why in ("feed 9 mm/s is 720 steps/s", "lost distance must be a distance", "start X900 Y100"):
        assert why in r.stderr, r.stderr
    assert len(read_trace(graph.trace)) == before


def test_the_page_shows_the_sensors_and_follows_from_its_button(graph):
    from test_web_ui import browser, free_port, text, web_ui
    port = free_port()
    ui = web_ui(graph.domain, "-p", f"port:={port}")
    driver = None
    try:
        wait_until(lambda: f"plotter page on http://127.0.0.1:{port}/" in ui.output(), 30, "the web server")
        driver = browser()
        driver.get(f"http://127.0.0.1:{port}/")
        wait_until(lambda: text(driver, "state") == "IDLE", 60, "IDLE on the page")
        assert driver.find_element("id", "follow-box").is_displayed()
        before = len(read_trace(graph.trace))
        driver.find_element("id", "follow-here").click()          # from a start of its own
        for element_id, value in (("follow-x", "0"), ("follow-y", "0"), ("follow-heading", "90"),
                                  ("follow-distance", "10")):
            field = driver.find_element("id", element_id)
            field.clear()
            field.send_keys(value)
        driver.find_element("id", "follow").click()
        wait_until(lambda: text(driver, "job-status") == "succeeded", 120, "the follow to succeed")
        assert text(driver, "message").startswith("follow: distance after 800 steps"), text(driver, "message")
        assert text(driver, "job-steps") == "800"
        assert 5.0 <= float(text(driver, "job-length")) <= 10.5      # 800 steps: 10 mm of steps, less along a slant
        wait_until(lambda: text(driver, "follow-state") == "distance", 15, "the state saying distance")
        assert text(driver, "sensors") == "\u25cf\u25cf\u25cf"          # on the ring: all three on black
        assert len(read_trace(graph.trace)) - before >= 800
    finally:
        if driver is not None:
            driver.quit()
        assert ui.interrupt() == 0, ui.output()
        ui.close()


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
