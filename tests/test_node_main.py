"""Every node shares one main (plotter_bridge/nodes/main.py): started as a
plain script, a bad parameter ends it with exit code 1 and one line saying
so, and Ctrl-C ends it cleanly with 0."""
import time

import pytest

from node_processes import NodeProcess, new_domain, wait_until

pytestmark = pytest.mark.ros

# (module, a parameter it refuses: a value out of range and a value of the wrong type)
NODES = [
    ("plotter_bridge.nodes.serial_bridge", ("steps_per_mm:=-80.0", "status_hz:=fast", "homing_travel:=500.0")),
    ("plotter_bridge.nodes.gcode_streamer", ("bridge_timeout:=0.5", "x_max:=wide", "dialect:=fanuc", "marlin_pen_up:=30.2")),
    ("plotter_bridge.nodes.mock_board", ("baud:=0", "baud:=fast", "switches:=north", "switches:=5,5")),
    ("plotter_shapes.shape_server_node", ("default_size:=-5.0", "default_feed:=slow")),
]
HEALTHY = {
    "plotter_bridge.nodes.serial_bridge": ("-p", "port:=/nonexistent/plotter"),
    "plotter_bridge.nodes.gcode_streamer": (),
    "plotter_bridge.nodes.mock_board": (),
    "plotter_shapes.shape_server_node": (),
}
NODE_NAMES = {
    "plotter_bridge.nodes.serial_bridge": "serial_bridge",
    "plotter_bridge.nodes.gcode_streamer": "gcode_streamer",
    "plotter_bridge.nodes.mock_board": "mock_board",
    "plotter_shapes.shape_server_node": "shape_server",
}


def _wait_exit(proc: NodeProcess, timeout: float = 30.0) -> int:
    end = time.monotonic() + timeout
    while proc.alive() and time.monotonic() < end:
        time.sleep(0.05)
    assert not proc.alive(), f"{proc.module} still running:\n{proc.output()}"
    return proc.proc.returncode


@pytest.mark.parametrize("module,bad", [(m, b) for m, bads in NODES for b in bads])
def test_a_bad_parameter_exits_1_with_one_line(module, bad, tmp_path):
    extra = ("-p", f"journal_dir:={tmp_path}") if module.endswith("gcode_streamer") else ()
    proc = NodeProcess(module, new_domain(), (*extra, "-p", bad))
    try:
        code = _wait_exit(proc)
        out = proc.output()
        assert code == 1, out
        assert "Traceback" not in out, out
        lines = [line for line in out.splitlines() if "bad parameter" in line]
        assert len(lines) == 1, out
        assert bad.split(":=")[0] in lines[0], out          # which parameter, not only that one was bad
    finally:
        proc.close()


@pytest.mark.parametrize("module", [m for m, _ in NODES])
def test_ctrl_c_exits_0(module, tmp_path):
    extra = ("-p", f"journal_dir:={tmp_path}") if module.endswith("gcode_streamer") else ()
    from ros_graph import Probe
    domain = new_domain()
    proc = NodeProcess(module, domain, (*extra, *HEALTHY[module]))
    probe = Probe(domain)
    try:
        # Up and spinning: made (its parameters taken) and in the graph, its executor next.
        name = NODE_NAMES[module]

        def up() -> bool:
            assert proc.alive(), proc.output()
            return ("/plotter", name) in [(ns, n) for n, ns in probe.node.get_node_names_and_namespaces()]
        wait_until(up, 60, f"{name} in the ROS graph")
        assert proc.interrupt() == 0, proc.output()
        assert "Traceback" not in proc.output(), proc.output()
    finally:
        probe.close()
        proc.close()


@pytest.mark.parametrize("entity", ["publisher", "action server"])
def test_ctrl_c_while_the_node_is_being_made_exits_0(entity):
    """rclpy's SIGINT handler shuts the context down under a constructor: the
    next entity it makes fails (RCLError, or ValueError from an action
    server, "context is invalid").  That is the Ctrl-C it was, not a bad
    parameter (seen: a shape_server stopped as it started exiting 1 with a
    traceback)."""
    import rclpy
    from rclpy.action import ActionServer
    from plotter_interfaces.action import DrawShape
    from std_msgs.msg import String
    from plotter_bridge.nodes import main as node_main

    def interrupted_while_made():
        node = rclpy.create_node("interrupted")
        rclpy.try_shutdown()
        if entity == "publisher":
            node.create_publisher(String, "x", 1)
        else:
            ActionServer(node, DrawShape, "draw", lambda goal: None)
        raise AssertionError(f"made a {entity} on a shut-down context")

    domain = str(new_domain())
    assert node_main.run_node(interrupted_while_made, "interrupted",
                              ["--ros-args", "-r", f"__ns:=/interrupted{domain}"]) == node_main.EXIT_OK


def test_ctrl_c_stops_the_spin_without_raising_in_the_main_thread():
    """A KeyboardInterrupt is raised wherever the main thread is, and once it came between a
    lock's acquire and the `with` block of the executor's thread pool: the lock stayed taken and
    the page's node never exited (seen beside CPU-bound processes).  run_node takes Ctrl-C as a
    flag its spin loop reads, after rclpy's own handler has shut the context down, and gives the
    handler back when it returns."""
    import os
    import signal
    import threading
    import rclpy
    from plotter_bridge.nodes import main as node_main
    during = []
    spinning = threading.Event()

    def make():
        during.append(signal.getsignal(signal.SIGINT))
        node = rclpy.create_node("flagged")
        node.create_timer(0.01, spinning.set)
        return node

    def ctrl_c() -> None:
        assert spinning.wait(60), "the node never spun"
        os.kill(os.getpid(), signal.SIGINT)
    before = signal.getsignal(signal.SIGINT)
    sender = threading.Thread(target=ctrl_c, daemon=True)
    sender.start()
    t0 = time.monotonic()
    code = node_main.run_node(make, "flagged", ["--ros-args", "-r", f"__ns:=/flagged{new_domain()}"])
    sender.join(5)
    assert code == node_main.EXIT_OK and spinning.is_set()
    assert during and during[0] is not signal.default_int_handler, "Ctrl-C would raise KeyboardInterrupt"
    assert signal.getsignal(signal.SIGINT) is before
    assert time.monotonic() - t0 < 60
