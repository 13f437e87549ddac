"""Several plotters, and plotters across hosts.

- Two plotters at once: /plotter1 and /plotter2, each its own mock board,
  serial_bridge, gcode_streamer and shape_server (all processes, one ROS
  domain), draw different figures at the same time (one `draw` action goal
  each, as `ros2 action send_goal` would send it).
- Two hosts: the board side (mock board and serial_bridge) in one network
  namespace, the shape_server, gcode_streamer and a client in another, joined
  by a veth pair on a private /30; DDS discovery and every topic and action
  cross that link (shared memory is switched off, discovery range SUBNET).
  Needs root and iproute2; skipped without them, failed when they cannot
  make the namespaces.
"""
import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from node_processes import new_domain
from ros_graph import PlotterGraph, Probe, read_trace, wait_until
from test_graph_end_to_end import check_trace_follows, reference_path

pytestmark = pytest.mark.ros

TESTS = Path(__file__).resolve().parent
FIGURES = {"/plotter1": dict(shape="star", x=70.0, y=70.0, size=40.0),
           "/plotter2": dict(shape="circle", x=120.0, y=120.0, size=20.0)}


def test_two_plotters_draw_different_figures_at_once(tmp_path):
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_bridge.nodes.action_client import ActionClient
    from plotter_interfaces.action import DrawShape
    from plotter_interfaces.msg import BoardState, ShapeGoal
    from plotter_shapes.geometry import build_shape

    domain = new_domain()
    graphs = {}
    for ns in FIGURES:
        (tmp_path / ns.strip("/")).mkdir()
        graphs[ns] = PlotterGraph(domain, tmp_path / ns.strip("/"), namespace=ns)
    probe = Probe(domain, namespace="/")
    lock = threading.Lock()
    states = {ns: [] for ns in FIGURES}
    diagnostics = set()
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    clients = {}
    for ns in FIGURES:
        def on_state(m, ns=ns):
            with lock:
                states[ns].append((time.monotonic(), m.state, m.queue_free))
        probe.node.create_subscription(BoardState, ns + "/state", on_state, latched)
        clients[ns] = ActionClient(probe.node, DrawShape, ns + "/draw")
    probe.node.create_subscription(DiagnosticArray, "/diagnostics",
                                   lambda m: diagnostics.update(s.name for s in m.status), 10)
    try:
        for ns in FIGURES:
            wait_until(lambda: any(s[1] == BoardState.IDLE for s in states[ns]), 60, f"{ns}/state")
            assert clients[ns].wait_for_server(timeout_sec=30), f"{ns}/draw"
        t0 = time.monotonic()
        goals = {ns: clients[ns].send_goal_async(DrawShape.Goal(shape=ShapeGoal(**fig)))
                 for ns, fig in FIGURES.items()}

        def running_interval(ns):
            with lock:
                after = [s for s in states[ns] if s[0] >= t0]
            run = [s[0] for s in after if s[1] == BoardState.RUNNING]
            if not run:
                return None
            rest = [s[0] for s in after if s[0] > run[0] and s[1] == BoardState.IDLE and s[2] == 6]
            return (run[0], rest[0]) if rest else None
        wait_until(lambda: all(g.done() for g in goals.values()), 30, "the goals to be accepted")
        results = {ns: g.result().get_result_async() for ns, g in goals.items()}
        wait_until(lambda: all(r.done() for r in results.values()), 120, "both drawings")
        assert all(r.result().result.success for r in results.values()), \
            [r.result().result.message for r in results.values()]
        wait_until(lambda: all(running_interval(ns) for ns in FIGURES), 10, "both plotters at rest")
        (a0, a1), (b0, b1) = (running_interval(ns) for ns in FIGURES)
        assert max(a0, b0) < min(a1, b1), "the two plotters did not draw at the same time"
        for ns, fig in FIGURES.items():
            figure = build_shape(fig["shape"], fig["x"], fig["y"], fig["size"])
            trace = read_trace(graphs[ns].trace)
            check_trace_follows(trace, reference_path(figure, (0.0, 0.0)))
            assert trace[-1][1:] == tuple(round(v * 80) for v in figure.end)
        wait_until(lambda: {"plotter1/serial_bridge: link", "plotter2/serial_bridge: link"} <= diagnostics, 5,
                   "one diagnostics entry per plotter")
    except BaseException:
        for g in graphs.values():
            print(g.outputs())
        raise
    finally:
        probe.close()
        codes, stuck = [], []
        for g in graphs.values():        # both plotters stopped, even if one's node does not stop
            try:
                codes += g.close()
            except RuntimeError as exc:
                stuck.append(str(exc))
    assert not stuck, "\n".join(stuck)
    assert all(c == 0 for c in codes), codes


# --- two hosts ------------------------------------------------------------------------------

SUBNET = ("10.213.97.1", "10.213.97.2")   # a private /30 that exists only inside the test's namespaces


def _run(*args):
    return subprocess.run(list(args), capture_output=True, text=True)


class Hosts:
    """Two network namespaces joined by a veth pair, each with one address of a /30."""

    def __init__(self) -> None:
        tag = f"{os.getpid() % 100000}"
        self.names = (f"plotter-a-{tag}", f"plotter-b-{tag}")
        self.links = (f"pla{tag}", f"plb{tag}")
        self.created = []

    def up(self) -> None:
        for ns in self.names:
            r = _run("ip", "netns", "add", ns)
            if r.returncode:
                raise RuntimeError(f"ip netns add: {r.stderr.strip()}")
            self.created.append(ns)
        (na, nb), (la, lb) = self.names, self.links
        steps = [("ip", "link", "add", la, "netns", na, "type", "veth", "peer", "name", lb, "netns", nb)]
        for ns, link, addr in ((na, la, SUBNET[0]), (nb, lb, SUBNET[1])):
            steps += [("ip", "-n", ns, "link", "set", "lo", "up"),
                      ("ip", "-n", ns, "addr", "add", addr + "/30", "dev", link),
                      ("ip", "-n", ns, "link", "set", link, "up"),
                      ("ip", "-n", ns, "route", "add", "224.0.0.0/4", "dev", link)]   # DDS discovery multicast
        for step in steps:
            r = _run(*step)
            if r.returncode:
                raise RuntimeError(f"{' '.join(step)}: {r.stderr.strip()}")

    def traffic(self, k: int) -> int:
        """Bytes received on host k's end of the link."""
        r = _run("ip", "-n", self.names[k], "-s", "-j", "link", "show", self.links[k])
        return int(json.loads(r.stdout)[0]["stats64"]["rx"]["bytes"])

    def partition(self, seconds: float) -> None:
        """The link down on both ends for `seconds`, then up again."""
        for ns, link in zip(self.names, self.links):
            _run("ip", "-n", ns, "link", "set", link, "down")
        try:
            time.sleep(seconds)
        finally:
            for ns, link in zip(self.names, self.links):
                _run("ip", "-n", ns, "link", "set", link, "up")
            for ns, link in zip(self.names, self.links):
                _run("ip", "-n", ns, "route", "replace", "224.0.0.0/4", "dev", link)

    def down(self) -> None:
        for ns in self.created:
            _run("ip", "netns", "del", ns)
        self.created = []


def _netns_unavailable() -> str:
    if os.geteuid() != 0:
        return "needs root to create network namespaces"
    if shutil.which("ip") is None:
        return "needs iproute2 (the ip command)"
    return ""


class HostProcess:
    def __init__(self, ns: str, args, env, log: Path) -> None:
        self.log = open(log, "w+")
        self.proc = subprocess.Popen(["ip", "netns", "exec", ns, *args], env=env,
                                     stdout=self.log, stderr=subprocess.STDOUT)

    def stop(self) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
        return self.proc.returncode

    def output(self) -> str:
        self.log.flush()
        self.log.seek(0)
        return self.log.read()


@contextlib.contextmanager
def two_hosts(tmp_path):
    """The board side (mock board, serial_bridge) on one host, shape_server and
    gcode_streamer on the other; yields the hosts and a function that starts
    a further process on a host.  Every process is stopped at the end, and
    must stop cleanly."""
    reason = _netns_unavailable()
    if reason:
        pytest.skip(reason)
    hosts = Hosts()
    procs = []
    try:
        try:
            hosts.up()
        except RuntimeError as exc:
            # Root with iproute2 can make them: a failure here is a fault, not a machine without the means.
            pytest.fail(f"cannot make network namespaces here: {exc}", pytrace=False)
        env = dict(os.environ, ROS_DOMAIN_ID=str(new_domain()),
                   ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET", FASTDDS_BUILTIN_TRANSPORTS="UDPv4",
                   PYTHONUNBUFFERED="1")
        env.pop("ROS_STATIC_PEERS", None)
        board_host, client_host = hosts.names
        hosts.link_path, hosts.trace = tmp_path / "board.pty", tmp_path / "trace.csv"

        def start(ns, name, *args):
            p = HostProcess(ns, [sys.executable, *args], env, tmp_path / f"{name}.log")
            p.name = name
            procs.append(p)
            return p

        start(board_host, "mock_board", "-m", "plotter_bridge.nodes.mock_board", "--ros-args",
              "-p", f"link:={hosts.link_path}", "-p", f"trace:={hosts.trace}")
        wait_until(hosts.link_path.exists, 20, "the mock board's pty")
        start(board_host, "serial_bridge", "-m", "plotter_bridge.nodes.serial_bridge", "--ros-args",
              "-p", f"port:={hosts.link_path}")
        start(client_host, "gcode_streamer", "-m", "plotter_bridge.nodes.gcode_streamer")
        start(client_host, "shape_server", "-m", "plotter_shapes.shape_server_node")
        yield hosts, start
    except BaseException:
        for p in procs:
            print(f"--- {p.name}\n{p.output()}")
        raise
    finally:
        codes = [p.stop() for p in reversed(procs)]
        hosts.down()
    assert all(c == 0 for c in codes), codes


def _report(client) -> dict:
    out = client.output()
    report = json.loads([ln for ln in out.splitlines() if ln.startswith("{")][-1])
    assert report["discovered"], "the client host never saw the bridge's state"
    assert report["drawn"], out
    return report


def test_bridge_on_one_host_shapes_and_streamer_on_another(tmp_path):
    from plotter_shapes.geometry import build_shape
    with two_hosts(tmp_path) as (hosts, start):
        before = hosts.traffic(1)
        client = start(hosts.names[1], "client", str(TESTS / "remote_client.py"), "--shape", "circle",
                       "--x", "60", "--y", "60", "--size", "12")
        client.proc.wait(120)
        report = _report(client)
        figure = build_shape("circle", 60.0, 60.0, 12.0)
        check_trace_follows(read_trace(hosts.trace), reference_path(figure, (0.0, 0.0)))
        assert report["positions"] > 20 and abs(report["last"][0] - figure.end[0]) < 1e-6
        assert hosts.traffic(1) - before > 10000, "little traffic crossed the veth link"


def test_a_network_partition_of_10_s_mid_job_and_the_drawing_completes(tmp_path):
    """The link between the hosts goes down for 10 s while the board draws:
    the bridge draws on, and the client hears that the job is done once the
    link is back."""
    from plotter_shapes.geometry import build_shape
    with two_hosts(tmp_path) as (hosts, start):
        client = start(hosts.names[1], "client", str(TESTS / "remote_client.py"), "--shape", "circle",
                       "--x", "60", "--y", "60", "--size", "30", "--feed", "300", "--timeout", "150")
        wait_until(lambda: hosts.trace.exists() and len(read_trace(hosts.trace)) > 9000, 90, "the circle begun")
        hosts.partition(10.0)
        client.proc.wait(150)
        report = _report(client)
        figure = build_shape("circle", 60.0, 60.0, 30.0)
        check_trace_follows(read_trace(hosts.trace), reference_path(figure, (0.0, 0.0)))
        assert abs(report["last"][0] - figure.end[0]) < 1e-6
