"""The plotter's ROS 2 face, poked at the way a ROS user pokes at a driver.

Every node runs as its own process, as `ros2 run` starts it; the test
process plays the `ros2` command line through rclpy: `ros2 param
get/set/describe` through the parameter services, `ros2 topic pub/echo`,
`ros2 action send_goal`.  What is checked: integer literals for numbers,
one clear line for a bad value, descriptors, runtime parameter changes that
apply or are refused with a reason, one settings file for all nodes, goals
sent ten at a time, errors logged and published where the user looks, a
missing port, SI units, and the launch file.
"""
from __future__ import annotations

import math
import re
import threading
import time
from pathlib import Path

import pytest

from node_processes import STARTUP_S, NodeProcess, PlotterGraph, new_domain, params_file, read_trace, wait_until
from ros_graph import Probe

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parent.parent
STEPS_PER_MM = 80.0
MODULES = {
    "mock_board": "plotter_bridge.nodes.mock_board",
    "serial_bridge": "plotter_bridge.nodes.serial_bridge",
    "gcode_streamer": "plotter_bridge.nodes.gcode_streamer",
    "shape_server": "plotter_shapes.shape_server_node",
}


def _wait(future, timeout: float = 30.0, what: str = "an answer"):
    wait_until(future.done, timeout, what)
    return future.result()


def _param_client(probe: Probe, node: str):
    from rclpy.parameter_client import AsyncParameterClient
    client = AsyncParameterClient(probe.node, f"/plotter/{node}")
    assert client.wait_for_services(timeout_sec=30.0), f"no parameter services of {node}"
    return client


def _get(client, names):
    from rclpy.parameter import parameter_value_to_python
    return [parameter_value_to_python(v) for v in _wait(client.get_parameters(names)).values]


def _set(client, name, value):
    from rclpy.parameter import Parameter
    (result,) = _wait(client.set_parameters([Parameter(name, value=value)])).results
    return result


# --------------------------------------------------------------------- parameters

@pytest.fixture(scope="module")
def lone_nodes(tmp_path_factory):
    """The four nodes, each started with integer literals where numbers are declared,
    as `ros2 run ... --ros-args -p steps_per_mm:=100 -p x_max:=250` starts them."""
    domain = new_domain()
    tmp = tmp_path_factory.mktemp("lone")
    ints = ("-p", "steps_per_mm:=100", "-p", "x_max:=250", "-p", "acceleration:=800", "-p", "baud:=9600",
            "-p", "default_size:=30", "-p", "status_hz:=20", "-p", "unplug_for:=3")
    extra = {"serial_bridge": ("-p", "port:=/nonexistent/plotter"),
             "gcode_streamer": ("-p", f"journal_dir:={tmp}"),
             "mock_board": ("-p", f"link:={tmp / 'board'}")}
    procs = {name: NodeProcess(module, domain, ("-r", "__ns:=/plotter", *ints, *extra.get(name, ())))
             for name, module in MODULES.items()}
    probe = Probe(domain)
    try:
        yield procs, probe
    finally:
        probe.close()
        for p in procs.values():
            p.close()


def test_integer_literals_are_taken_where_numbers_are_declared(lone_nodes):
    procs, probe = lone_nodes
    expected = {"mock_board": {"steps_per_mm": 100, "baud": 9600, "unplug_for": 3},
                "serial_bridge": {"steps_per_mm": 100, "baud": 9600, "status_hz": 20},
                "gcode_streamer": {"steps_per_mm": 100, "x_max": 250, "acceleration": 800},
                "shape_server": {"x_max": 250, "default_size": 30}}
    for name, values in expected.items():
        client = _param_client(probe, name)
        assert procs[name].alive(), procs[name].output()
        got = _get(client, list(values))
        assert got == list(values.values()), (name, got)
        assert "Traceback" not in procs[name].output()


def test_every_parameter_has_a_descriptor_saying_what_it_may_be(lone_nodes):
    from rcl_interfaces.msg import ParameterType
    procs, probe = lone_nodes
    read_only = {"machine", "steps_per_mm", "port", "baud", "link", "trace", "journal_dir", "queue_limit"}
    changeable = {"x_max", "acceleration", "status_hz", "default_size", "unplug_for", "bridge_timeout"}
    ranged = {"status_hz", "acceleration", "baud", "default_size", "bridge_timeout", "x_max"}
    seen = set()
    for name in MODULES:
        client = _param_client(probe, name)
        names = [n for n in _wait(client.list_parameters()).result.names
                 if n not in ("use_sim_time", "start_type_description_service")]
        assert len(names) >= 5, (name, names)
        for d in _wait(client.describe_parameters(names)).descriptors:
            seen.add(d.name)
            assert d.description.strip(), (name, d.name)
            assert d.additional_constraints.strip(), (name, d.name)
            if d.name in read_only:
                assert d.read_only, (name, d.name)
            if d.name in changeable:
                assert not d.read_only, (name, d.name)
            if d.name in ranged and d.type in (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER):
                assert d.floating_point_range or d.integer_range, (name, d.name)
    assert read_only | changeable <= seen


def test_set_parameters_is_applied_or_refused_with_a_reason(lone_nodes):
    procs, probe = lone_nodes
    streamer = _param_client(probe, "gcode_streamer")
    refusals = [("x_max", -5.0, "x_max"), ("x_max", "wide", "x_max"), ("acceleration", math.nan, "acceleration"),
                ("acceleration", 0.0, "acceleration"), ("x_min", 300.0, "x_min"), ("bridge_timeout", 0.5, "bridge_timeout"),
                ("steps_per_mm", 0.0, "read-only"), ("steps_per_mm", 90.0, "read-only"),
                ("junction_deviation", -0.1, "junction_deviation"), ("lookahead", 3, "lookahead")]
    for name, value, word in refusals:
        before = _get(streamer, [name])
        result = _set(streamer, name, value)
        assert not result.successful, (name, value)
        assert word in result.reason, (name, value, result.reason)
        assert _get(streamer, [name]) == before, (name, value)
    for name, value in (("x_max", 180), ("x_max", 175.5), ("acceleration", 1500), ("lookahead", False)):
        result = _set(streamer, name, value)
        assert result.successful, (name, value, result.reason)
        assert _get(streamer, [name]) == [value]
    shapes = _param_client(probe, "shape_server")
    assert not _set(shapes, "default_size", -5.0).successful
    assert not _set(shapes, "y_min", 500).successful        # above y_max
    assert _set(shapes, "y_max", 150).successful
    bridge = _param_client(probe, "serial_bridge")
    assert not _set(bridge, "port", "/dev/ttyUSB1").successful
    assert not _set(bridge, "status_hz", 0).successful
    assert _set(bridge, "status_hz", 10).successful
    assert "parameters applied" in procs["serial_bridge"].output()
    for p in procs.values():
        assert p.alive(), p.output()


BAD_VALUES = [
    ("serial_bridge", "steps_per_mm", "-80.0"), ("serial_bridge", "steps_per_mm", "0"),
    ("serial_bridge", "steps_per_mm", "nan"), ("serial_bridge", "status_hz", "fast"),
    ("serial_bridge", "baud", "0"), ("serial_bridge", "port", "''"),
    ("gcode_streamer", "x_max", "-5"), ("gcode_streamer", "acceleration", "nan"),
    ("gcode_streamer", "acceleration", "0"), ("gcode_streamer", "bridge_timeout", "0.0"),
    ("gcode_streamer", "machine", "delta"), ("gcode_streamer", "pulley_left", "[1.0]"),
    ("mock_board", "baud", "-9600"), ("mock_board", "faults", "drop=2"),
    ("mock_board", "steps_per_mm", "true"),
    ("shape_server", "default_size", "0"), ("shape_server", "default_feed", "slow"),
    ("shape_server", "y_max", "-1"),
]


def test_a_bad_value_at_start_ends_the_node_with_one_clear_line(tmp_path):
    """Every bad value at once, each node in a domain of its own."""
    started = []
    for node, name, value in BAD_VALUES:
        extra = ("-p", f"journal_dir:={tmp_path}") if node == "gcode_streamer" else ()
        proc = NodeProcess(MODULES[node], new_domain(), (*extra, "-p", f"{name}:={value}"))
        started.append((node, name, value, proc))
    try:
        for node, name, value, proc in started:
            wait_until(lambda: not proc.alive(), 60, f"{node} with {name}:={value} to exit")
            out = proc.output()
            assert proc.proc.returncode == 1, (node, name, value, out)
            assert "Traceback" not in out, out
            lines = [line for line in out.splitlines() if "bad parameter" in line]
            assert len(lines) == 1, out
            # The parameter, its value, and what it may be.
            assert f"{name} = " in lines[0] and ("must be" in lines[0] or "outside" in lines[0]), lines[0]
    finally:
        for *_, proc in started:
            proc.close()


# --------------------------------------------------------------------- one settings file

def test_the_settings_file_holds_the_machine_once_for_every_node():
    import yaml
    from plotter_bridge.nodes import gcode_streamer, mock_board, serial_bridge
    from plotter_shapes import shape_server_node
    specs = {"mock_board": mock_board.SPECS, "serial_bridge": serial_bridge.SPECS,
             "gcode_streamer": gcode_streamer.SPECS, "shape_server": shape_server_node.SPECS}
    installed = Path(params_file())
    source = REPO / "ros_ws" / "src" / "plotter_bridge" / "config" / "plotter.yaml"
    assert installed.read_text() == source.read_text()
    doc = yaml.safe_load(source.read_text())
    # One section for every node: a node's own section would win over `-p` on its command line.
    assert set(doc) == {"/**"}
    values = doc["/**"]["ros__parameters"]
    for key, value in values.items():
        owners = [spec for node in specs.values() for spec in node if spec.name == key]
        assert owners, f"{key} is declared by no node"
        for spec in owners:
            assert spec.check(value) is None, spec.check(value)
            assert spec.coerce(value) == spec.default, f"{key}: the file and the code's default differ"
    for key in ("machine", "steps_per_mm", "baud", "port", "x_min", "x_max", "y_min", "y_max"):
        assert key in values


def test_a_changed_settings_file_reaches_every_node(tmp_path):
    """A user's copy of the file, with another machine: every node takes it."""
    text = Path(params_file()).read_text()
    mine = tmp_path / "my_plotter.yaml"
    mine.write_text(text.replace("steps_per_mm: 80.0", "steps_per_mm: 100").replace("x_max: 200.0", "x_max: 120"))
    domain = new_domain()
    args = ("-r", "__ns:=/plotter", "--params-file", str(mine))
    procs = {name: NodeProcess(module, domain, args + (
        ("-p", "port:=/nonexistent/plotter") if name == "serial_bridge" else
        ("-p", f"journal_dir:={tmp_path}") if name == "gcode_streamer" else ()))
        for name, module in MODULES.items()}
    probe = Probe(domain)
    try:
        for name in ("mock_board", "serial_bridge", "gcode_streamer"):
            assert _get(_param_client(probe, name), ["steps_per_mm"]) == [100], name
        for name in ("gcode_streamer", "shape_server"):
            assert _get(_param_client(probe, name), ["x_max"]) == [120], name
    finally:
        probe.close()
        for p in procs.values():
            p.close()


# --------------------------------------------------------------------- the whole graph

@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PointStamped
    from plotter_interfaces.msg import BoardState
    from std_msgs.msg import String

    domain = new_domain()
    g = PlotterGraph(domain, tmp_path_factory.mktemp("driver"))
    probe = Probe(domain)
    g.probe = probe
    g.lock = threading.Lock()
    g.states, g.positions, g.shape_errors, g.program_errors, g.programs = [], [], [], [], []

    def keep(store, f=lambda m: m):
        def cb(m):
            with g.lock:
                store.append(f(m))
        return cb
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(BoardState, "state", keep(g.states), latched)
    probe.node.create_subscription(PointStamped, "position", keep(g.positions), 50)
    probe.node.create_subscription(String, "shape_error", keep(g.shape_errors, lambda m: m.data), 10)
    probe.node.create_subscription(String, "program_error", keep(g.program_errors, lambda m: m.data), 10)
    probe.node.create_subscription(String, "program", keep(g.programs, lambda m: m.data), 10)
    g.diags = []
    probe.node.create_subscription(DiagnosticArray, "/diagnostics", keep(g.diags), 10)
    try:
        wait_until(lambda: any(s.state == BoardState.IDLE for s in g.states), 60, "IDLE")
        yield g
    except BaseException:
        print(g.outputs())
        raise
    finally:
        probe.close()
        codes = g.close()
    assert all(c == 0 for c in codes), codes


def _send_all(client, goals, feedback):
    """Send every goal at once, as ten `ros2 action send_goal` would; the goal handles."""
    futures = [client.send_goal_async(goal, feedback_callback=lambda fb, k=k: feedback[k].append(fb.feedback))
               for k, goal in enumerate(goals)]
    return [_wait(f, 30, "goal responses") for f in futures]


def _first_visits(trace, places_steps, radius_steps):
    """The order in which the trace first comes within radius of each place."""
    order = []
    for _, x, y in trace:
        for k, (px, py) in enumerate(places_steps):
            if k not in order and math.hypot(x - px, y - py) <= radius_steps:
                order.append(k)
    return order


def test_ten_run_program_goals_at_once_queue_and_are_drawn_in_order(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import RunProgram
    client = graph.probe.action_client(RunProgram, "run_program")
    assert client.wait_for_server(timeout_sec=30)
    xs = [20.0 + 16.0 * k for k in range(10)]
    goals = [RunProgram.Goal(name=f"stroke {k}", program=f"G21 G90\nG0 X{x} Y20\nM3\nG1 X{x} Y32 F4000\nM5\nM2\n")
             for k, x in enumerate(xs)]
    feedback = [[] for _ in goals]
    start = len(read_trace(graph.trace))
    handles = _send_all(client, goals, feedback)
    assert all(h.accepted for h in handles)
    t0 = time.monotonic()
    results = [_wait(h.get_result_async(), 120, "every result") for h in handles]
    assert time.monotonic() - t0 < 120
    assert [r.status for r in results] == [GoalStatus.STATUS_SUCCEEDED] * 10, [r.result.message for r in results]
    trace = read_trace(graph.trace)[start:]
    tops = [(x * STEPS_PER_MM, 32 * STEPS_PER_MM) for x in xs]
    assert _first_visits(trace, tops, 1) == list(range(10))
    assert max(max((f.jobs_ahead for f in fb), default=0) for fb in feedback) >= 5, "no goal was told it waits"
    out = graph.streamer.output()
    assert all(re.search(rf"stroke {k}: done in \d+\.\d s", out) for k in range(10)), out


def test_a_goal_cancelled_while_it_waits_never_moves_the_pen(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import RunProgram
    client = graph.probe.action_client(RunProgram, "run_program")
    first = RunProgram.Goal(name="long", program="G21 G90\nG0 X20 Y60\nM3\n" + "G1 X180 Y60 F3000\nG1 X20 Y61\n" * 2
                            + "M5\nM2\n")
    waiting = RunProgram.Goal(name="never", program="G21 G90\nG0 X100 Y150\nM3\nG1 X110 Y150 F3000\nM5\nM2\n")
    feedback = [[], []]
    start = len(read_trace(graph.trace))
    h_first, h_waiting = _send_all(client, [first, waiting], feedback)
    wait_until(lambda: feedback[1] and feedback[1][-1].jobs_ahead == 1, 30, "the second goal to wait")
    _wait(h_waiting.cancel_goal_async(), 10, "the cancel response")
    res = _wait(h_waiting.get_result_async(), 10, "the cancelled goal's result")
    assert res.status == GoalStatus.STATUS_CANCELED, res.result.message
    assert _wait(h_first.get_result_async(), 120).status == GoalStatus.STATUS_SUCCEEDED
    trace = read_trace(graph.trace)[start:]
    assert all(y < 149 * STEPS_PER_MM for _, _, y in trace), "the cancelled goal moved the pen"
    out = graph.streamer.output()
    assert "never: canceled" in out or "canceled before it ran" in res.result.message


def test_ten_draw_goals_at_once_are_drawn_in_order(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import DrawShape
    from plotter_interfaces.msg import ShapeGoal
    client = graph.probe.action_client(DrawShape, "draw")
    assert client.wait_for_server(timeout_sec=30)
    centres = [(20.0 + 17.0 * k, 170.0) for k in range(10)]
    goals = [DrawShape.Goal(shape=ShapeGoal(shape="circle", x=x, y=y, size=4.0, feed=4000.0)) for x, y in centres]
    feedback = [[] for _ in goals]
    start = len(read_trace(graph.trace))
    handles = _send_all(client, goals, feedback)
    assert all(h.accepted for h in handles)
    results = [_wait(h.get_result_async(), 180, "every draw result") for h in handles]
    assert [r.status for r in results] == [GoalStatus.STATUS_SUCCEEDED] * 10, [r.result.message for r in results]
    trace = read_trace(graph.trace)[start:]
    rims = [((x + 4.0) * STEPS_PER_MM, y * STEPS_PER_MM) for x, y in centres]   # where each circle starts
    assert _first_visits(trace, rims, 1) == list(range(10))
    assert re.search(r"circle: drawn in \d+\.\d s", graph.shapes.output())


def test_ten_stream_commands_goals_at_once_one_runs_the_rest_are_refused(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import StreamCommands
    client = graph.probe.action_client(StreamCommands, "stream_commands")
    assert client.wait_for_server(timeout_sec=30)
    # Out 5 mm and back, 3 s apart: the board is the first goal's until long after the last answer.
    goals = [StreamCommands.Goal(commands=["L 400 0 4000 0", "D 3000", "L -400 0 4000 0"]) for _ in range(10)]
    refusal = "stream_commands goal rejected: another job is running"
    refused_before = graph.bridge.output().count(refusal)
    start = len(read_trace(graph.trace))
    t0 = time.monotonic()
    handles = _send_all(client, goals, [[] for _ in goals])
    answered = time.monotonic() - t0
    assert answered < 30
    # The bridge takes the board for a goal as it accepts it, and lets go only when the job ends.
    accepted = [h for h in handles if h.accepted]
    assert len(accepted) == 1, f"{len(accepted)} goals accepted; the answers took {answered:.1f} s"
    assert _wait(accepted[0].get_result_async(), 60).status == GoalStatus.STATUS_SUCCEEDED
    assert graph.bridge.output().count(refusal) - refused_before == 9
    # One job's steps on the board, not two: 400 along +X and the same back.
    moved = [(x, y) for _, x, y in read_trace(graph.trace)[start:]]
    x0, y0 = moved[0][0] - 1, moved[0][1]
    assert moved == [(x0 + k, y0) for k in range(1, 401)] + [(x0 + k, y0) for k in range(399, -1, -1)]


# --------------------------------------------------------------------- errors where the user looks

def test_a_shape_that_does_not_fit_is_refused_by_the_shape_server(graph):
    from plotter_interfaces.msg import ShapeGoal
    pub = graph.probe.node.create_publisher(ShapeGoal, "shape", 10)
    wait_until(lambda: pub.get_subscription_count() > 0, 30, "shape_server")
    with graph.lock:
        programs = len(graph.programs)
    for goal, shape in ((ShapeGoal(shape="circle", size=150.0), "circle"),
                        (ShapeGoal(shape="star", x=199.0, y=199.0), "star")):
        n = len(graph.shape_errors)
        pub.publish(goal)
        wait_until(lambda: len(graph.shape_errors) > n, 30, f"the {shape}'s refusal")
        text = graph.shape_errors[-1]
        assert text.startswith(f"{shape}: does not fit the work area"), text
    time.sleep(0.5)
    assert len(graph.programs) == programs, "a refused shape was published as a program"
    warn = [line for line in graph.shapes.output().splitlines() if "does not fit" in line]
    assert len(warn) == 2 and all(line.startswith("[WARN]") for line in warn), warn


def test_a_topic_program_refused_by_the_streamer_is_warned_and_named(graph):
    from std_msgs.msg import String
    pub = graph.probe.node.create_publisher(String, "program", 10)
    wait_until(lambda: pub.get_subscription_count() > 1, 30, "gcode_streamer")
    n = len(graph.program_errors)
    pub.publish(String(data="(sketch)\nG21 G90\nG1 X500 Y10 F1000\nM2\n"))
    wait_until(lambda: len(graph.program_errors) > n, 30, "the program's refusal")
    text = graph.program_errors[-1]
    assert text.startswith("sketch: line 3:") and "work area" in text, text
    lines = [line for line in graph.streamer.output().splitlines() if "sketch" in line]
    assert lines and all(line.startswith("[WARN]") for line in lines), lines


def test_a_cancel_is_not_an_error_and_no_node_logged_one(graph):
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import RunProgram
    client = graph.probe.action_client(RunProgram, "run_program")
    slow = "G21 G90\nG0 X20 Y100\nM3\n" + "G1 X180 Y100 F1500\nG1 X20 Y101\n" * 3 + "M5\nM2\n"
    feedback = [[]]
    (handle,) = _send_all(client, [RunProgram.Goal(name="to cancel", program=slow)], feedback)
    wait_until(lambda: any(f.current_line > 3 for f in feedback[0]), 30, "the program to run")
    _wait(handle.cancel_goal_async(), 10)
    assert _wait(handle.get_result_async(), 30).status == GoalStatus.STATUS_CANCELED
    time.sleep(0.5)
    out = graph.streamer.output()
    assert any(line.startswith("[INFO]") and "to cancel: canceled" in line for line in out.splitlines()), out
    for proc in graph.processes:
        errors = [line for line in proc.output().splitlines() if line.startswith(("[ERROR]", "[FATAL]"))]
        assert not errors, (proc.module, errors)


def test_positions_are_in_metres_and_mm_fields_in_millimetres(graph):
    import subprocess
    import os
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import RunProgram
    env = dict(os.environ, ROS_DOMAIN_ID=str(graph.domain))
    watch = subprocess.Popen([str(REPO / ".venv" / "bin" / "plotter"), "watch", "--timeout", "120"],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
    lines: list = []
    reader = threading.Thread(target=lambda: lines.extend(iter(watch.stdout.readline, "")), daemon=True)
    reader.start()
    # The bridge publishes the position with each status report, at rest too: a first line
    # says that the watch hears the topic before the job starts.
    wait_until(lambda: lines, 60, "plotter watch's first line")
    client = graph.probe.action_client(RunProgram, "run_program")
    (handle,) = _send_all(client, [RunProgram.Goal(name="units", program="G21 G90\nG0 X50 Y30\nM2\n")], [[]])
    res = _wait(handle.get_result_async(), 60)
    assert res.status == GoalStatus.STATUS_SUCCEEDED
    assert (res.result.x_mm, res.result.y_mm) == (50.0, 30.0)

    def settled():
        with graph.lock:
            p = graph.positions[-1] if graph.positions else None
            s = graph.states[-1]
        return p is not None and abs(p.point.x - 0.050) < 1e-9 and abs(p.point.y - 0.030) < 1e-9 \
            and s.x_mm == 50.0 and s.y_mm == 30.0
    wait_until(settled, 10, "position 0.050, 0.030 m and state 50, 30 mm")
    wait_until(lambda: any("X    50.000  Y    30.000 mm" in line for line in lines), 30,
               "plotter watch printing X 50 Y 30 mm")
    watch.terminate()
    watch.wait(timeout=30)
    reader.join(timeout=30)


# --------------------------------------------------------------------- a missing port

def _state_and_diagnostics(domain):
    """A probe on `domain` keeping /plotter/state and /diagnostics: (probe, states, diagnostic arrays)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from diagnostic_msgs.msg import DiagnosticArray
    from plotter_interfaces.msg import BoardState
    probe = Probe(domain)
    states, diags = [], []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    probe.node.create_subscription(BoardState, "state", states.append, latched)
    probe.node.create_subscription(DiagnosticArray, "/diagnostics", diags.append, 10)
    return probe, states, diags


def _diagnosed_error(diags, text: str) -> bool:
    from diagnostic_msgs.msg import DiagnosticStatus
    return any(s.level == DiagnosticStatus.ERROR and text in s.message for d in diags for s in d.status)


def test_a_missing_port_is_reported_at_once_and_again_more_slowly(tmp_path):
    from plotter_interfaces.msg import BoardState
    domain = new_domain()
    probe, states, diags = _state_and_diagnostics(domain)
    bridge = NodeProcess(MODULES["serial_bridge"], domain, ("-r", "__ns:=/plotter", "--params-file", params_file(),
                                                            "-p", "port:=/nonexistent/ttyUSB9"))
    try:
        def errors():
            return [line for line in bridge.output().splitlines()
                    if line.startswith("[ERROR]") and "/nonexistent/ttyUSB9" in line]
        # "At once": the first attempt is made as the node comes up (its start-up beside CPU-bound
        # processes may take longer than the back-off), so its error is the first one logged.
        wait_until(lambda: errors(), STARTUP_S, "the first error")
        assert "No such file or directory" in errors()[0] and "(attempt 1;" in errors()[0], errors()
        wait_until(lambda: len(errors()) >= 7, 40, "seven attempts")
        stamps = [float(re.match(r"\[ERROR\] \[(\d+\.\d+)\]", line).group(1)) for line in errors()]
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        assert all(later >= earlier * 0.9 for earlier, later in zip(gaps, gaps[1:])), gaps
        assert gaps[-1] > 2 * gaps[0], gaps
        wait_until(lambda: states and states[-1].state == BoardState.DISCONNECTED
                   and "/nonexistent/ttyUSB9" in states[-1].last_error, 10, "DISCONNECTED in /plotter/state")
        wait_until(lambda: _diagnosed_error(diags, "/nonexistent/ttyUSB9"), 10, "the port's error in /diagnostics")
        assert bridge.alive()
    finally:
        probe.close()
        assert bridge.interrupt() == 0
        bridge.close()


def test_a_port_whose_board_does_not_answer_is_reported_in_state_and_diagnostics(tmp_path):
    """The port opens (a pty nobody answers on: a board switched off, or
    firmware at another baud rate), and no status report ever comes."""
    import os
    from plotter_interfaces.msg import BoardState
    domain = new_domain()
    probe, states, diags = _state_and_diagnostics(domain)
    master, slave = os.openpty()
    bridge = NodeProcess(MODULES["serial_bridge"], domain, ("-r", "__ns:=/plotter", "--params-file", params_file(),
                                                            "-p", f"port:={os.ttyname(slave)}"))
    try:
        wait_until(lambda: "[ERROR]" in bridge.output(), 20, "the bridge's error")
        line = next(x for x in bridge.output().splitlines() if x.startswith("[ERROR]"))
        assert "no answer from the board in 5 s: nothing came back on the port at 9600 baud" in line, line
        wait_until(lambda: states and states[-1].state == BoardState.DISCONNECTED
                   and states[-1].last_error.startswith("no answer from the board"), 10,
                   "DISCONNECTED with the reason in /plotter/state")
        wait_until(lambda: _diagnosed_error(diags, "no answer from the board"), 10, "the reason in /diagnostics")
    finally:
        probe.close()
        assert bridge.interrupt() == 0
        bridge.close()
        os.close(master)
        os.close(slave)


# --------------------------------------------------------------------- the launch file

def test_the_launch_file_starts_what_it_describes(tmp_path):
    """plotter.launch.py with mock:=true, started exactly as it describes
    (executables, namespace, parameter files, values), draws a shape."""
    from ament_index_python.packages import get_package_prefix, get_package_share_directory
    from plotter_interfaces.msg import BoardState, ShapeGoal
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    import launch_recorder
    link = tmp_path / "board"
    launch_file = Path(get_package_share_directory("plotter_bridge")) / "launch" / "plotter.launch.py"
    nodes = launch_recorder.evaluate(launch_file, {"mock": "true", "port": str(link)},
                                     get_package_share_directory)
    assert [(n.package, n.executable) for n in nodes] == [
        ("plotter_bridge", "mock_board"), ("plotter_bridge", "serial_bridge"),
        ("plotter_bridge", "gcode_streamer"), ("plotter_shapes", "shape_server")]
    assert all(n.namespace == "plotter" and n.param_files == [params_file()] for n in nodes)
    assert nodes[0].params == {"link": str(link)} and nodes[1].params == {"port": str(link)}
    domain = new_domain()
    procs = []
    probe = Probe(domain)
    try:
        for n in nodes:
            exe = Path(get_package_prefix(n.package)) / "lib" / n.package / n.executable
            assert exe.is_file(), exe
            procs.append(NodeProcess.executable(str(exe), domain, [*n.ros_args(), "-p", f"journal_dir:={tmp_path}"]
                                                if n.executable == "gcode_streamer" else n.ros_args()))
            if n.executable == "mock_board":
                wait_until(link.exists, 20, "the mock board's link")
        states = []
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        probe.node.create_subscription(BoardState, "state", states.append, latched)
        wait_until(lambda: any(s.state == BoardState.IDLE for s in states), 60, "IDLE")
        pub = probe.node.create_publisher(ShapeGoal, "shape", 10)
        wait_until(lambda: pub.get_subscription_count() > 0, 30, "shape_server")
        pub.publish(ShapeGoal(shape="diamond", size=20.0))
        wait_until(lambda: states[-1].x_steps != 0 and states[-1].state == BoardState.IDLE
                   and states[-1].queue_free == 6, 60, "the diamond to be drawn")
        for n in nodes:
            client = _param_client(probe, n.executable)
            for key, value in n.params.items():
                assert _get(client, [key]) == [value]
        assert _get(_param_client(probe, "serial_bridge"), ["steps_per_mm", "baud"]) == [80.0, 9600]
    finally:
        probe.close()
        for p in reversed(procs):
            assert p.interrupt() == 0, p.output()
            p.close()


def test_a_job_whose_bridge_dies_ends_with_the_reason_and_the_streamer_rests(tmp_path):
    """The bridge killed mid-job: the goal ends (no waiting forever), and the
    streamer goes back to using no processor time."""
    import os as _os
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import RunProgram
    domain = new_domain()
    g = PlotterGraph(domain, tmp_path, streamer_args=("-p", "bridge_timeout:=5.0"))
    probe = Probe(domain)
    try:
        client = probe.action_client(RunProgram, "run_program")
        assert client.wait_for_server(timeout_sec=60)
        slow = "G21 G90\nG0 X20 Y60\nM3\n" + "G1 X180 Y60 F900\nG1 X20 Y61\n" * 4 + "M5\nM2\n"
        feedback = [[]]
        (handle,) = _send_all(client, [RunProgram.Goal(name="orphan", program=slow)], feedback)
        wait_until(lambda: any(f.current_line > 3 for f in feedback[0]), 60, "the job to run")
        g.bridge.proc.kill()
        res = _wait(handle.get_result_async(), 60, "the job's end")
        assert res.status == GoalStatus.STATUS_ABORTED
        assert "serial bridge could not be reached for 5 s" in res.result.message, res.result.message
        assert "plotter resume" in res.result.message

        def cpu() -> float:
            fields = Path(f"/proc/{g.streamer.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / _os.sysconf("SC_CLK_TCK")
        before = cpu()
        time.sleep(3.0)
        assert cpu() - before < 0.3, "the streamer keeps working for a job that ended"
    finally:
        probe.close()
        g.close()


# --------------------------------------------------------------------- one machine

def test_a_job_planned_for_another_machine_than_the_bridges_is_refused_before_anything_moves(tmp_path):
    """`-p steps_per_mm:=100` typed for the streamer alone: its jobs are
    planned at 100 steps/mm while the bridge reports steps at 80.  The job
    ends with both values named, and the board takes no step."""
    from action_msgs.msg import GoalStatus
    from plotter_interfaces.action import RunProgram
    domain = new_domain()
    g = PlotterGraph(domain, tmp_path, streamer_args=("-p", "steps_per_mm:=100"))
    probe = Probe(domain)
    try:
        client = probe.action_client(RunProgram, "run_program")
        assert client.wait_for_server(timeout_sec=60)
        (handle,) = _send_all(client, [RunProgram.Goal(name="scaled", program="G21 G90\nG0 X10 Y5\nM2\n")], [[]])
        res = _wait(handle.get_result_async(), 60, "the job's end")
        assert res.status == GoalStatus.STATUS_ABORTED
        assert "steps_per_mm 100.0 in the job, 80.0 here" in res.result.message, res.result.message
        assert (res.result.x_mm, res.result.y_mm) == (0.0, 0.0)
        time.sleep(0.5)
        assert not (g.trace.exists() and read_trace(g.trace)), "the board stepped"
        assert "planned for another machine" in g.bridge.output()
    except BaseException:
        print(g.outputs())
        raise
    finally:
        probe.close()
        g.close()
