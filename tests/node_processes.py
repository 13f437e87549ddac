"""The plotter's nodes as separate processes, without a launch system.

Each node runs as `python -m <module> --ros-args ...`, exactly as `ros2 run`
starts it; used by the end-to-end tests, the demo (scripts/demo.py) and the
benchmark (benchmarks/rosgraph.py), which put tests/ on their path.
"""
from __future__ import annotations

import itertools
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, List, Optional

from plotter_bridge.sim.trace import read_seq_log, read_trace  # noqa: F401  (for the tests)


def worker_domains() -> List[int]:
    """The ROS domain ids 1..232 (the last one DDS maps to ports) this process
    may use: under pytest-xdist a worker has every n-th of them, so that two
    workers' graphs never meet on one domain."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "") or 1)
    index = int(worker[2:]) if worker.startswith("gw") else 0
    return [d for d in range(1, 233) if d % count == index % count]


_next_domain = itertools.count(random.SystemRandom().randrange(232))
_domains: List[int] = []


def new_domain() -> int:
    """A ROS domain id for one graph, not the id of any graph before it in
    this test session (up to 116 of them under two xdist workers; then they
    come round again), nor the environment's own as the first call finds it
    (a robot on it is not the tests' to talk to; in a test session it is the
    session's, tests/conftest.py).  Two graphs on one domain hear each
    other's nodes: picked at random, a test's domain would now and then be
    that of a graph a module fixture keeps running beside it.  The ids come
    in turn from a random start, so that two sessions on one machine rarely
    share one either."""
    if not _domains:
        taken = os.environ.get("ROS_DOMAIN_ID", "")
        _domains.extend(d for d in worker_domains() if str(d) != taken)
    return _domains[next(_next_domain) % len(_domains)]


# How long a node process may take to come up: importing rclpy and joining the graph take a
# second on an idle machine, tens of seconds with four test workers and two CPU-bound
# processes on two cores.  A bound for a hang, not a speed.
STARTUP_S = 120.0


def wait_until(predicate: Callable[[], bool], timeout: float = 30.0, what: str = "condition") -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    raise TimeoutError(f"timed out waiting for {what}")


class NodeProcess:
    def __init__(self, module: str, domain: int, ros_args=(), command: Optional[List[str]] = None) -> None:
        env = dict(os.environ)
        env["ROS_DOMAIN_ID"] = str(domain)
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        env["PYTHONUNBUFFERED"] = "1"
        # SIGABRT then prints every thread's stack: what a node that does not stop was doing.
        env["PYTHONFAULTHANDLER"] = "1"
        self.module = module
        self.log = tempfile.TemporaryFile(mode="w+")
        args = list(command) if command else [sys.executable, "-m", module]
        if ros_args:
            args += ["--ros-args", *ros_args]
        self.proc = subprocess.Popen(args, env=env, stdout=self.log, stderr=subprocess.STDOUT)

    @classmethod
    def executable(cls, path: str, domain: int, ros_args=()) -> "NodeProcess":
        """An installed executable (lib/<package>/<name>), as `ros2 run` starts it."""
        return cls(Path(path).name, domain, ros_args, command=[path])

    def output(self) -> str:
        self.log.seek(0)
        return self.log.read()

    def alive(self) -> bool:
        return self.proc.poll() is None

    def interrupt(self, timeout: float = 15.0) -> int:
        """Ctrl-C, as in a terminal."""
        if self.alive():
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.send_signal(signal.SIGABRT)
                try:
                    self.proc.wait(5.0)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()
                raise RuntimeError(f"{self.module} did not stop on Ctrl-C:\n{self.output()}")
        code = self.proc.returncode
        frame = stuck_in_dds_teardown(code, self.output())
        if frame:
            # The node stopped and began destroying its DDS entities, and the
            # middleware deadlocked there (nodes/teardown.py): not this
            # project's code, and the watchdog ended it as it should.
            print(f"{self.module}: its teardown watchdog ended it in {frame} (eProsima/Fast-DDS#6502)", flush=True)
            return 0
        return code

    def close(self) -> None:
        if self.alive():
            self.proc.kill()
            self.proc.wait()
        self.log.close()


_THREAD = re.compile(r"^(?:Current thread|Thread) 0x[0-9a-f]+ \(most recent call first\):\n\s+File \"([^\"]+)\", "
                     r"line \d+ in (\w+)", re.M)


def stuck_in_dds_teardown(code: int, output: str) -> str:
    """The frame ('rclpy/publisher.py in destroy') where a node process that
    nodes/teardown.py's watchdog ended (exit status -SIGALRM) was stuck, when
    that is rclpy destroying an entity or shutting down; else ''."""
    if code != -signal.SIGALRM or "Timeout (" not in output:
        return ""
    dump = output[output.rindex("Timeout ("):]
    for path, function in _THREAD.findall(dump):
        if "/rclpy/" in path and (function.startswith("destroy") or function in ("shutdown", "try_shutdown")):
            return f"rclpy/{path.rsplit('/rclpy/', 1)[1]} in {function}"
    return ""


def params_file() -> str:
    """The installed config/plotter.yaml: the machine's settings for every node."""
    from ament_index_python.packages import get_package_share_directory
    return str(Path(get_package_share_directory("plotter_bridge")) / "config" / "plotter.yaml")


class PlotterGraph:
    """mock_board + serial_bridge + gcode_streamer + shape_server, each a process,
    all with config/plotter.yaml; `*_args` add to it or override it."""

    def __init__(self, domain: int, workdir: Path, namespace: str = "/plotter",
                 bridge_args=(), board_args=(), streamer_args=()) -> None:
        self.domain = domain
        self.link = workdir / "board.pty"
        self.trace = workdir / "trace.csv"
        self.seq_log = workdir / "seq_log.csv"
        self.journal = workdir / "journal"
        self._ns = ("-r", f"__ns:={namespace}", "--params-file", params_file())
        ns = self._ns
        self.board = NodeProcess("plotter_bridge.nodes.mock_board", domain,
                                 ns + ("-p", f"link:={self.link}", "-p", f"trace:={self.trace}",
                                       "-p", f"seq_log:={self.seq_log}") + tuple(board_args))
        wait_until(self.link.exists, STARTUP_S, "the mock board's pty link")
        self.bridge = NodeProcess("plotter_bridge.nodes.serial_bridge", domain,
                                  ns + ("-p", f"port:={self.link}") + tuple(bridge_args))
        self._streamer_args = ns + ("-p", f"journal_dir:={self.journal}") + tuple(streamer_args)
        self.streamer = NodeProcess("plotter_bridge.nodes.gcode_streamer", domain, self._streamer_args)
        self.shapes = NodeProcess("plotter_shapes.shape_server_node", domain, ns)
        self.processes = [self.shapes, self.streamer, self.bridge, self.board]
        self.dead: List[NodeProcess] = []

    def restart_streamer(self) -> None:
        """A new gcode_streamer process (after the old one died), same journal."""
        old = self.streamer
        self.streamer = NodeProcess("plotter_bridge.nodes.gcode_streamer", self.domain, self._streamer_args)
        self.processes[self.processes.index(old)] = self.streamer
        self.dead.append(old)

    def outputs(self) -> str:
        return "\n".join(f"--- {p.module}\n{p.output()}" for p in self.processes if not p.log.closed)

    def close(self) -> List[int]:
        for p in self.dead:
            p.close()
        # Every process is stopped even when one does not stop on Ctrl-C: a
        # survivor would go on using the machine for the tests after it.
        codes, failure = [], None
        for p in self.processes:
            try:
                codes.append(p.interrupt())
                if codes[-1] != 0:     # what it printed (a crash: PYTHONFAULTHANDLER's stacks)
                    print(f"--- {p.module} ended with {codes[-1]}:\n{p.output()}")
            except RuntimeError as exc:
                failure = failure or exc
            finally:
                p.close()
        if failure is not None:
            raise failure
        return codes
