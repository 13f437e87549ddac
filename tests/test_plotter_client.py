"""The `plotter` command against a plotter that already runs.

The four nodes run as separate processes on the mock board, as CI starts
them; each `plotter` command runs as its own process in their ROS domain,
without --port or --mock, the way a user on a laptop beside the plotter's
computer would type it.
"""
from __future__ import annotations

import math
import os
import pty
import re
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from node_processes import PlotterGraph, new_domain, read_trace, wait_until
from ros_graph import HELD_REPORTS, Probe, held_still

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parent.parent
PLOTTER = str(REPO / ".venv" / "bin" / "plotter")
STEPS_PER_MM = 80.0


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.msg import BoardState
    domain = new_domain()
    g = PlotterGraph(domain, tmp_path_factory.mktemp("client"))
    g.probe = Probe(domain)
    g.states = []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    g.probe.node.create_subscription(BoardState, "state", g.states.append, latched)
    g.env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    try:
        wait_until(lambda: g.states and g.states[-1].state == BoardState.IDLE, 60, "IDLE")
        yield g
    except BaseException:
        print(g.outputs())
        raise
    finally:
        g.probe.close()
        codes = g.close()
    assert all(c == 0 for c in codes), codes


def plotter(graph, *args, timeout=180, **kw):
    return subprocess.run([PLOTTER, *args], capture_output=True, text=True, env=graph.env, timeout=timeout, **kw)


def idle(graph) -> bool:
    from plotter_interfaces.msg import BoardState
    s = graph.states[-1]
    return s.state == BoardState.IDLE and s.queue_free == s.queue_size


def pen_at(graph) -> tuple:
    s = graph.states[-1]
    return s.x_steps, s.y_steps


def moved_from(graph, start: tuple) -> bool:
    """The board runs a job and has left `start`."""
    s = graph.states[-1]
    return s.state_name == "RUNNING" and (s.x_steps, s.y_steps) != start


def resting_pen(graph) -> tuple:
    """Where the pen rests (steps), from a state the bridge sent after this call: the
    last one before it may still be the last job's."""
    seen = len(graph.states)
    wait_until(lambda: len(graph.states) >= seen + 2 and idle(graph), 30, "a state at rest")
    return pen_at(graph)


def drawing_problems(graph, program: str, before: int, start: tuple) -> list:
    """Why the board's steps from trace row `before` on are not `program` drawn whole
    from `start` (steps), to the step the firmware core takes; none when they are."""
    from test_web_ui import drawing_check, graph_config
    drawn = [(x, y) for _, x, y in read_trace(graph.trace)[before:]]
    return drawing_check().figure_problems(program, drawn, start, graph_config())


def test_stream_sends_the_program_to_the_running_streamer(graph, tmp_path):
    program = tmp_path / "square.gcode"
    program.write_text("(square)\nG21 G90\nG0 X20 Y20\nM3\nG1 X60 Y20 F3000\nG1 X60 Y60\nG1 X20 Y60\nG1 X20 Y20\n"
                       "M5\nM2\n")
    before = len(read_trace(graph.trace))
    r = plotter(graph, "stream", str(program))
    assert r.returncode == 0, r.stderr
    assert f"{program}: done, pen at X20.000 Y20.000 mm" in r.stdout
    trace = read_trace(graph.trace)[before:]
    corners = {(x, y) for _, x, y in trace}
    for cx, cy in ((20, 20), (60, 20), (60, 60), (20, 60)):
        assert (cx * 80, cy * 80) in corners
    # Not a terminal: plain progress lines, no carriage returns.
    assert "\r" not in r.stderr
    lines = [line for line in r.stderr.splitlines() if "% done" in line]
    assert lines and all(" left, line " in line for line in lines), r.stderr


def test_progress_is_the_share_of_the_length_with_the_time_left(graph, tmp_path):
    """One long line, then many short ones: half the time is not half the lines."""
    program = tmp_path / "long_then_short.gcode"
    short = "".join(f"G1 X{150 + (k % 2)} Y{20 + k}\n" for k in range(1, 40))
    program.write_text(f"G21 G90\nG0 X10 Y20\nM3\nG1 X150 Y20 F1200\n{short}M5\nM2\n")
    r = plotter(graph, "stream", str(program))
    assert r.returncode == 0, r.stderr
    rows = []
    for line in r.stderr.splitlines():
        if "% done" in line:
            pct = float(line.split(": ", 1)[1].split("%")[0])
            left = line.split("done, ")[1].split(" left")[0]
            secs = float(left.split()[0]) if left.endswith(" s") else \
                sum(int(v) * 60 ** k for k, v in enumerate(reversed(left.split(":"))))
            line_no = int(line.split(" line ")[1].split("/")[0])
            rows.append((pct, secs, line_no))
    assert len(rows) >= 3, r.stderr
    assert [p for p, _, _ in rows] == sorted(p for p, _, _ in rows)
    assert [s for _, s, _ in rows] == sorted((s for _, s, _ in rows), reverse=True)
    # While the long line (line 4, 140 mm of the path's 140 + 39 * ~1.4 + 10 mm) runs, the share grows past
    # what its one line of 45 would say.
    during_long = [p for p, _, n in rows if n == 4]
    assert during_long and max(during_long) > 20.0, rows
    assert rows[0][1] > 3.0, rows      # 140 mm at 20 mm/s: seconds, not a fraction


def test_progress_on_a_terminal_redraws_one_line(graph, tmp_path):
    program = tmp_path / "line.gcode"
    program.write_text("G21 G90\nG0 X20 Y100\nM3\nG1 X120 Y100 F3000\nM5\nM2\n")
    master, slave = pty.openpty()
    proc = subprocess.Popen([PLOTTER, "stream", str(program)], stdout=subprocess.PIPE, stderr=slave,
                            env=graph.env, text=True)
    os.close(slave)
    chunks = []

    def read():
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:
                return
            if not data:
                return
            chunks.append(data.decode(errors="replace"))
    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    out, _ = proc.communicate(timeout=120)
    reader.join(5)
    os.close(master)
    tty = "".join(chunks)
    assert proc.returncode == 0, tty
    assert tty.count("\r[") >= 2 and "% " in tty and " left " in tty, tty


def test_draw_sends_a_goal_to_the_running_shape_server(graph):
    from plotter_shapes.geometry import build_shape
    before = len(read_trace(graph.trace))
    r = plotter(graph, "draw", "star", "--size", "30")
    assert r.returncode == 0, r.stderr
    assert "star: done" in r.stdout
    figure = build_shape("star", None, None, 30.0)
    trace = read_trace(graph.trace)[before:]
    ends = {(round(x), round(y)) for _, x, y in trace}
    assert (round(figure.end[0] * 80), round(figure.end[1] * 80)) in ends
    assert "draw" in graph.shapes.output() and "star: drawn in" in graph.shapes.output()


def test_svg_and_text_go_to_the_running_streamer(graph, tmp_path):
    svg = tmp_path / "ring.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">'
                   '<circle cx="20" cy="20" r="15" fill="none" stroke="black"/></svg>')
    ring, hi = tmp_path / "ring.gcode", tmp_path / "hi.gcode"
    start, before = resting_pen(graph), len(read_trace(graph.trace))
    r = plotter(graph, "svg", str(svg), "--x", "60", "--y", "140", "--gcode", str(ring))
    assert r.returncode == 0, r.stderr
    # What the command sent, drawn whole by the running plotter: a ring of r15 round (60, 140).
    assert drawing_problems(graph, ring.read_text(), before, start) == []
    from test_hanging_graph import largest_gap_deg
    drawn = [(x / STEPS_PER_MM, y / STEPS_PER_MM) for _, x, y in read_trace(graph.trace)[before:]]
    on_ring = drawn[next(k for k, (x, y) in enumerate(drawn) if abs(math.hypot(x - 60, y - 140) - 15) < 0.02):]
    assert max(abs(math.hypot(x - 60, y - 140) - 15) for x, y in on_ring) < 1.5 / STEPS_PER_MM
    assert largest_gap_deg(on_ring, (60, 140)) < 1.0
    start, before = resting_pen(graph), len(read_trace(graph.trace))
    r = plotter(graph, "text", "HI", "--size", "8", "--x", "140", "--y", "140", "--gcode", str(hi))
    assert r.returncode == 0, r.stderr
    assert "HI: done" in r.stdout
    assert drawing_problems(graph, hi.read_text(), before, start) == []


def test_a_failing_job_exits_non_zero_with_the_reason(graph, tmp_path):
    program = tmp_path / "wide.gcode"
    program.write_text("G21 G90\nG1 X500 Y10 F1000\nM2\n")
    r = plotter(graph, "stream", str(program))
    assert r.returncode == 1 and "line 2" in r.stderr and "work area" in r.stderr, r.stderr
    r = plotter(graph, "draw", "circle", "--size", "150")
    assert r.returncode == 1 and "does not fit the work area" in r.stderr, r.stderr
    r = plotter(graph, "stream", str(program), "--trace", "t.csv")
    assert r.returncode == 2 and "--trace: only with --port or --mock" in r.stderr, r.stderr


def test_state_and_the_buttons(graph, tmp_path):
    r = plotter(graph, "state")
    assert r.returncode == 0, r.stderr
    fields = dict(line.split(": ", 1) for line in r.stdout.splitlines())
    assert fields["state_name"] == "'IDLE'" and float(fields["x_mm"]) >= 0 and fields["queue_size"] == "6"
    program = tmp_path / "slow.gcode"
    program.write_text("G21 G90\nG0 X20 Y120\nM3\n" + "G1 X180 Y120 F1200\nG1 X20 Y121\n" * 3 + "M5\nM2\n")
    job = subprocess.Popen([PLOTTER, "stream", str(program), "--quiet"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, env=graph.env)
    try:
        wait_until(lambda: graph.states[-1].state_name == "RUNNING", 30, "RUNNING")
        r = plotter(graph, "hold")
        assert r.returncode == 0 and "hold: feed hold" in r.stdout, r.stderr
        wait_until(lambda: graph.states[-1].state_name == "HOLD", 10, "HOLD")
        wait_until(lambda: held_still([(s.state, s.x_steps, s.y_steps) for s in graph.states[-HELD_REPORTS:]],
                                      graph.trace), 30, "the pen at rest in HOLD")
        held = len(read_trace(graph.trace))
        time.sleep(0.5)
        assert len(read_trace(graph.trace)) == held
        r = plotter(graph, "resume")
        assert r.returncode == 0 and "resume: resumed" in r.stdout, r.stderr
        wait_until(lambda: graph.states[-1].state_name == "RUNNING", 10, "RUNNING again")
        r = plotter(graph, "estop")
        assert r.returncode == 0, r.stderr
        out, err = job.communicate(timeout=60)
        assert job.returncode == 1 and "emergency stop" in err, err
        r = plotter(graph, "reset")
        assert r.returncode == 0, r.stderr
        wait_until(lambda: idle(graph), 10, "IDLE after reset")
        r = plotter(graph, "set-origin")
        assert r.returncode == 0, r.stderr
        wait_until(lambda: (graph.states[-1].x_steps, graph.states[-1].y_steps) == (0, 0), 10, "origin")
        graph.origin_moved = True
    finally:
        if job.poll() is None:
            job.kill()


def test_ctrl_c_cancels_the_job_and_the_board_stops_there(graph, tmp_path):
    program = tmp_path / "slow.gcode"
    program.write_text("G21 G90\nG0 X10 Y150\nM3\n" + "G1 X150 Y150 F900\nG1 X10 Y151\n" * 4 + "M5\nM2\n")
    start, before = resting_pen(graph), len(read_trace(graph.trace))
    # PYTHONFAULTHANDLER: if it outlives its Ctrl-C, SIGABRT prints where each of its threads is.
    job = subprocess.Popen([PLOTTER, "stream", str(program)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, env=dict(graph.env, PYTHONFAULTHANDLER="1"))
    # The pen on its way: the job takes over a minute, Ctrl-C comes in its first lines.
    wait_until(lambda: moved_from(graph, start), 60, "the pen moving")
    assert job.poll() is None, "the job ended before its Ctrl-C"
    job.send_signal(signal.SIGINT)
    try:
        out, err = job.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        job.send_signal(signal.SIGABRT)
        out, err = job.communicate(timeout=30)
        pytest.fail(f"plotter stream did not end within 60 s of Ctrl-C; its threads:\n{err[-6000:]}")
    assert job.returncode == 130 and "canceled" in err, err
    wait_until(lambda: idle(graph), 20, "IDLE after the cancel")
    stopped = read_trace(graph.trace)
    time.sleep(1.0)
    assert read_trace(graph.trace) == stopped, "the board moved after the cancel"
    # Stopped part way along the program: every step the program's, and short of its end (the
    # cancel, not the job's end, stopped it).
    problems = drawing_problems(graph, program.read_text(), before, start)
    found = problems and re.fullmatch(r"not drawn whole: the board stepped (\d+) of (\d+) steps, .*", problems[0])
    assert found and 0 < int(found[1]) < int(found[2]), problems


def test_a_missing_server_is_named_with_how_to_start_it(tmp_path):
    from plotter_bridge.cli.client import WAIT_S
    env = dict(os.environ, ROS_DOMAIN_ID=str(new_domain()),
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    program = tmp_path / "p.gcode"
    program.write_text("G21 G90\nG0 X1 Y1\nM2\n")
    cases = ((["stream", str(program)], "run_program", "gcode_streamer"),
             (["draw", "star"], "draw", "shape_server"),
             (["hold"], "hold", "serial_bridge"),
             (["state"], "state", "serial_bridge"))
    procs = [(subprocess.Popen([PLOTTER, *args], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env=env), what, node) for args, what, node in cases]
    for proc, what, node in procs:
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 1, err
        assert f"/plotter/{what}" in err and f"is {node} running" in err and "ros2 run" in err, err
        # It gave up after its own wait for the server (how long that takes a loaded machine to
        # see through is not the test's business; communicate's timeout catches one that hangs).
        assert f"answers within {WAIT_S:g} s" in err, err


def test_the_readme_workflow_commands_are_the_ones_tested():
    """Every `plotter` command the README's workflow section shows is one these tests run."""
    readme = (REPO / "README.md").read_text()
    section = readme.split("### A plotter that already runs", 1)[1].split("\n#", 1)[0]
    shown = {line.split()[1] for line in section.splitlines() if line.strip().startswith("plotter ")}
    # home: tests/test_homing.py::test_plotter_home_on_a_running_graph; follow: tests/test_follow_graph.py
    tested = {"stream", "draw", "svg", "text", "watch", "state", "hold", "resume", "estop", "reset", "set-origin",
              "home", "follow"}
    assert shown and shown <= tested, shown - tested


def test_a_job_names_its_own_dialect_for_the_running_streamer(graph, tmp_path):
    program = tmp_path / "laser.gcode"
    program.write_text("G21 G90\nG0 X40 Y170\nM3 S1000\nG2 X60 Y170 I10 J0 K0 F2000\nM5\nM2\n")
    r = plotter(graph, "stream", str(program))                   # the streamer reads linuxcnc: no K on XY arcs
    assert r.returncode == 1 and "line 4" in r.stderr and "--dialect grbl" in r.stderr, r.stderr
    r = plotter(graph, "stream", str(program), "--dialect", "grbl", "--quiet")
    assert r.returncode == 0, r.stderr
    r = plotter(graph, "stream", str(program), "--dialect", "grbl", "--pen-up-z", "2")
    assert r.returncode == 2 and "--pen-up-z: only with --port or --mock" in r.stderr, r.stderr
