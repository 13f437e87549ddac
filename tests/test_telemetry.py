"""The bridge's RViz topics (path, planned_path, pen, ink) and /diagnostics (plotter_bridge.link.telemetry, nodes.telemetry)."""
import math
import random
import threading
import time

import pytest

from plotter_bridge.link.board_link import LinkStats
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.motion.kinematics import Machine
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from plotter_bridge.link.telemetry import (ERROR, OK, STALE, WARN, BridgeSnapshot, LinkCounters, Sample,
                                          diagnose_board, diagnose_link, planned_pen_points,
                                          planned_points, step_rate, thin)


def test_planned_points_follow_lines_arcs_and_the_pen():
    pts = planned_points(["P 1", "L 800 0 2000 0", "A 0 0 -400 0 2000 0", "P 0", "L -800, 0 3000 0"], (100, 100))
    assert (pts[0].x, pts[0].y, pts[0].pen_down) == (100, 100, False)
    assert (pts[1].x, pts[1].y, pts[1].pen_down) == (900, 100, True)
    circle = [p for p in pts if p.pen_down][1:]
    assert len(circle) > 50
    assert all(abs(math.hypot(p.x - 500, p.y - 100) - 400) < 1e-6 for p in circle)
    assert circle[len(circle) // 4].y > 100           # counter-clockwise from the right: up first
    assert (pts[-1].x, pts[-1].y, pts[-1].pen_down) == (100, 100, False)
    cw = planned_points(["C 0 0 -400 0"], (0, 0))
    assert cw[len(cw) // 4].y < 0


def test_planned_path_of_the_hanging_machine_is_in_pen_coordinates():
    # Its board commands move the motors; the planned path must land on the
    # programmed circle in pen coordinates (pen mm * steps_per_mm), as /plotter/position.
    machine = Machine("hanging")
    config = StreamerConfig(machine="hanging", area=WorkArea(0, 800, 0, 1000))
    program = "G21 G90\nG0 X650 Y500\nM3\nG2 X650 Y500 I-250 J0 F6000\nM5\n"
    commands = [c.text for c in compile_program(program, config)]
    k = machine.steps_per_mm
    to_pen = lambda m: tuple(v * k for v in machine.pen_mm(m))   # noqa: E731
    pts = planned_pen_points(commands, (0, 0), False, None, to_pen)
    drawn = [(p.x / k, p.y / k) for p in pts if p.pen_down]
    assert len(drawn) > 50
    assert max(abs(math.hypot(x - 400, y - 500) - 250) for x, y in drawn) < 0.1
    assert math.dist(drawn[-1], (650, 500)) < 0.05
    # Where the job says it ends (motor steps) shifts the path, in motor steps.
    end = (3, -2)
    moved = planned_pen_points(commands, (0, 0), False, end, to_pen)
    assert (moved[-1].x, moved[-1].y) == pytest.approx(to_pen(end))
    # A cartesian machine's motors are its axes: nothing changes.
    plain = planned_pen_points(["L 800 0"], (100, 100), True, None, lambda m: m)
    assert [(p.x, p.y) for p in plain] == [(100, 100), (900, 100)]


@pytest.mark.parametrize("segments, length", [(30_000, 120), (300_000, 120), (60_000, 8)])
def test_a_big_jobs_planned_path_is_decimated_keeping_its_order_pen_changes_and_ends(segments, length):
    """A random walk of short chords with the pen lifted every 50: at most MAX_PLANNED_POSES poses,
    the walk's own points in its order, every pen change, the start and the end kept."""
    from plotter_bridge.link.telemetry import MAX_PLANNED_POSES, planned_points
    rng = random.Random(segments)
    commands, heading = [], 0.0
    for k in range(segments):
        if k % 50 == 0:
            commands.append(f"P {1 if k % 100 == 0 else 0}")
        heading += rng.gauss(0.0, 0.6)
        commands.append(f"L {round(length * math.cos(heading))} {round(length * math.sin(heading))} 4000 0")
    pts = planned_pen_points(commands, (0, 0), False, None, lambda m: m)
    full = planned_points(commands, (0, 0), False)
    assert len(pts) <= MAX_PLANNED_POSES < len(full)
    assert (pts[0], pts[-1]) == (full[0], full[-1])
    changes = [(p.x, p.y) for a, p in zip(full, full[1:]) if a.pen_down != p.pen_down]
    kept = {(p.x, p.y) for p in pts}
    assert all(c in kept for c in changes)
    walk = iter(full)
    assert all(any(q == p for q in walk) for p in pts)                 # the walk's own points, in its order


def test_step_rate_and_thinning():
    a, b = Sample(0.0, 0, 0, True), Sample(0.5, 300, -200, True)
    assert step_rate(a, b) == 1000.0 and step_rate(b, b) == 0.0
    samples = [Sample(float(k), k, 0, k % 3 != 0) for k in range(10)]
    assert len(thin(samples, 6)) == 8 and thin(samples, 6)[-5:] == samples[-5:]


def test_diagnostic_levels():
    up = BridgeSnapshot(port="/dev/ttyUSB0", connected=True, ever_connected=True, seconds_since_status=0.04,
                        board_state="Run", queue_free=2, step_rate=4000, firmware="PLOTTER 8051 1.0 ready",
                        counters=LinkCounters.of(LinkStats(bytes_sent=100, retransmissions=3)))
    link, board = diagnose_link(up), diagnose_board(up)
    assert (link.level, board.level) == (OK, OK) and board.message == "running"
    values = dict(link.values + board.values)
    assert values["retransmissions"] == "3" and values["queue fill %"] == "67"
    assert values["firmware"] == "PLOTTER 8051 1.0 ready" and values["step rate (steps/s)"] == "4000"
    assert diagnose_link(BridgeSnapshot(connected=True, seconds_since_status=0.1, errors_in_last_period=2)).level == WARN
    assert diagnose_link(BridgeSnapshot(connected=True, seconds_since_status=3.0)).level == WARN
    gone = BridgeSnapshot(port="/dev/ttyUSB0", ever_connected=True, lost_reason="disconnected: [Errno 5]")
    assert diagnose_link(gone).level == ERROR and "Errno 5" in diagnose_link(gone).message
    assert diagnose_board(gone).level == ERROR
    assert diagnose_board(BridgeSnapshot(connected=True, board_state="Alarm", alarm=1)).level == ERROR
    assert diagnose_board(BridgeSnapshot(connected=True, board_state="Run", underruns_in_last_period=1)).level == WARN
    assert diagnose_board(BridgeSnapshot(connected=True)).level == STALE


def _program(n=120):
    lines, x, y = ["G21 G90", "G0 X40 Y40", "M3"], 40.0, 40.0
    for k in range(n):
        x += 0.8 * math.cos(k * 0.15)
        y += 0.8 * math.sin(k * 0.15)
        lines.append(f"G1 X{x:.3f} Y{y:.3f} F1200")
    return "\n".join(lines + ["M5", "M2"]) + "\n", (x, y)


@pytest.mark.ros
def test_path_grows_and_diagnostics_follow_the_link(tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PointStamped
    from nav_msgs.msg import Path
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String
    from visualization_msgs.msg import Marker
    from node_processes import new_domain
    from ros_graph import PlotterGraph, Probe, wait_until

    domain = new_domain()
    # the program's 120 chords as written (not fitted as a few arcs): a link with traffic to count
    g = PlotterGraph(domain, tmp_path, streamer_args=("-p", "fit_arcs:=false"))
    probe = Probe(domain)
    lock = threading.Lock()
    paths, planned, pens, diags, positions, inks = [], [], [], [], [], []

    def keep(store, f):
        def cb(msg):
            with lock:
                store.append((time.monotonic(), f(msg)))
        return cb

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node = probe.node
    node.create_subscription(Path, "path", keep(paths, lambda m: [(p.pose.position.x, p.pose.position.y)
                                                                  for p in m.poses]), latched)
    node.create_subscription(Path, "planned_path", keep(planned, lambda m: [(p.pose.position.x, p.pose.position.y)
                                                                            for p in m.poses]), latched)
    node.create_subscription(Marker, "pen", keep(pens, lambda m: (m.pose.position.x, m.header.frame_id)), 10)
    node.create_subscription(Marker, "ink", keep(inks, lambda m: [(p.x * 1000, p.y * 1000) for p in m.points]),
                             latched)
    node.create_subscription(PointStamped, "position", keep(positions, lambda m: (m.point.x * 1000, m.point.y * 1000)), 10)   # m -> mm
    node.create_subscription(DiagnosticArray, "/diagnostics", keep(diags, lambda m: {
        s.name: (s.level, s.message, {kv.key: kv.value for kv in s.values}) for s in m.status}), 10)
    pub = node.create_publisher(String, "program", 10)
    link_name, board_name = "plotter/serial_bridge: link", "plotter/serial_bridge: board"
    try:
        wait_until(lambda: any(d[1].get(link_name, (None,))[0] == OK for d in diags), 30, "link OK in /diagnostics")
        wait_until(lambda: pub.get_subscription_count() > 0, 30, "gcode_streamer")
        text, end = _program()
        t0 = time.monotonic()
        pub.publish(String(data=text))

        def at_end():
            with lock:
                return bool(positions) and positions[-1][0] > t0 and \
                    math.dist(positions[-1][1], end) < 0.02 and len(paths) > 3
        wait_until(at_end, 90, "the program to finish")

        def path_at_end():
            with lock:
                p = paths[-1][1] if paths else None
            return bool(p) and math.dist((p[-1][0] * 1000, p[-1][1] * 1000), end) < 0.05
        wait_until(path_at_end, 20, "/plotter/path to reach the end")    # published on a timer
        with lock:
            sizes = [len(p) for t, p in paths if t > t0]
            last_path = paths[-1][1]
            running = [d for t, d in diags if t > t0 and board_name in d and d[board_name][1] == "running"]
        assert len(set(sizes)) >= 3 and sizes == sorted(sizes), sizes       # it grew while the board moved
        assert math.dist((last_path[-1][0] * 1000, last_path[-1][1] * 1000), end) < 0.05
        assert running, "no diagnostics while the board ran"
        # A busy machine may hold the mock board's reports past STALE_AFTER: that is a WARN,
        # as it should be; the port is never reported gone while the board runs.
        levels = [(d[link_name][0], d[link_name][1]) for d in running]
        assert any(lv == OK for lv, _ in levels), levels
        assert all(lv in (OK, WARN) for lv, _ in levels), levels
        assert max(float(d[board_name][2]["step rate (steps/s)"]) for d in running) > 500
        # The program's 120 lines went over the link: the counter says so once the job is done
        # (the last report while running may come early in it on a busy machine).
        def counted() -> bool:
            with lock:
                return any(t > t0 and link_name in d and int(d[link_name][2]["bytes sent"]) > 1000
                           for t, d in diags)
        wait_until(counted, 30, "the link's bytes sent to count the program")
        plan = planned[-1][1]
        assert len(plan) > 100 and math.dist((plan[-1][0] * 1000, plan[-1][1] * 1000), end) < 0.05
        assert pens and pens[-1][1][1] == "plotter"
        # The ink: segments between the reports while the pen drew, on the program's path (its
        # points every 0.8 mm, so within 0.4 mm of one of them and the step's rounding).
        drawn = [(40.0, 40.0)] + [tuple(map(float, (w[1:] for w in line.split()[1:3])))
                                  for line in text.splitlines() if line.startswith("G1 ")]
        wait_until(lambda: inks and len(inks[-1][1]) >= 6, 20, "the ink")
        with lock:
            ink = inks[-1][1]
        assert len(ink) % 2 == 0 and all(min(math.dist(p, q) for q in drawn) < 0.42 for p in ink), ink

        g.board.proc.kill()                          # the port goes away
        g.board.proc.wait()
        t1 = time.monotonic()
        wait_until(lambda: any(t > t1 and d.get(link_name, (None,))[0] == ERROR for t, d in diags), 15,
                   "ERROR in /diagnostics")
    except BaseException:
        print(g.outputs())
        raise
    finally:
        probe.close()
        codes = g.close()
    assert codes[:3] == [0, 0, 0], codes              # shapes, streamer, bridge stop cleanly
