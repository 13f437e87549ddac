"""The plotter's nodes as separate processes, without a launch system.

Each node runs as `python -m <module> --ros-args ...`, exactly as `ros2 run`
starts it; used by the demo (scripts/demo.py) and the end-to-end tests.
"""
from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, List


def wait_until(predicate: Callable[[], bool], timeout: float = 30.0, what: str = "condition") -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    raise TimeoutError(f"timed out waiting for {what}")


class NodeProcess:
    def __init__(self, module: str, domain: int, ros_args=()) -> None:
        env = dict(os.environ)
        env["ROS_DOMAIN_ID"] = str(domain)
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        env["PYTHONUNBUFFERED"] = "1"
        self.module = module
        self.log = tempfile.TemporaryFile(mode="w+")
        args = [sys.executable, "-m", module]
        if ros_args:
            args += ["--ros-args", *ros_args]
        self.proc = subprocess.Popen(args, env=env, stdout=self.log, stderr=subprocess.STDOUT)

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
                self.proc.kill()
                self.proc.wait()
                raise RuntimeError(f"{self.module} did not stop on Ctrl-C:\n{self.output()}")
        return self.proc.returncode

    def close(self) -> None:
        if self.alive():
            self.proc.kill()
            self.proc.wait()
        self.log.close()


class PlotterGraph:
    """mock_board + serial_bridge + gcode_streamer + shape_server, each a process."""

    def __init__(self, domain: int, workdir: Path, namespace: str = "/plotter",
                 bridge_args=(), board_args=(), streamer_args=()) -> None:
        self.domain = domain
        self.link = workdir / "board.pty"
        self.trace = workdir / "trace.csv"
        self.seq_log = workdir / "seq_log.csv"
        self.journal = workdir / "journal"
        self._ns = ("-r", f"__ns:={namespace}")
        ns = self._ns
        self.board = NodeProcess("plotter_bridge.mock_board_node", domain,
                                 ns + ("-p", f"link:={self.link}", "-p", f"trace:={self.trace}",
                                       "-p", f"seq_log:={self.seq_log}") + tuple(board_args))
        wait_until(self.link.exists, 20, "the mock board's pty link")
        self.bridge = NodeProcess("plotter_bridge.serial_bridge_node", domain,
                                  ns + ("-p", f"port:={self.link}") + tuple(bridge_args))
        self._streamer_args = ns + ("-p", f"journal_dir:={self.journal}") + tuple(streamer_args)
        self.streamer = NodeProcess("plotter_bridge.gcode_streamer_node", domain, self._streamer_args)
        self.shapes = NodeProcess("plotter_shapes.shape_server_node", domain, ns)
        self.processes = [self.shapes, self.streamer, self.bridge, self.board]
        self.dead: List[NodeProcess] = []

    def restart_streamer(self) -> None:
        """A new gcode_streamer process (after the old one died), same journal."""
        old = self.streamer
        self.streamer = NodeProcess("plotter_bridge.gcode_streamer_node", self.domain, self._streamer_args)
        self.processes[self.processes.index(old)] = self.streamer
        self.dead.append(old)

    def outputs(self) -> str:
        return "\n".join(f"--- {p.module}\n{p.output()}" for p in self.processes if not p.log.closed)

    def close(self) -> List[int]:
        for p in self.dead:
            p.close()
        codes = []
        for p in self.processes:
            try:
                codes.append(p.interrupt())
            finally:
                p.close()
        return codes


def read_seq_log(path: Path) -> List[object]:
    """The mock board's sequence log: ints, and "reset" where the board restarted."""
    with open(path) as f:
        rows = f.read().split()
    assert rows[0] == "seq"
    return [r if r == "reset" else int(r) for r in rows[1:]]


def read_trace(path: Path, z: bool = False) -> List[tuple]:
    """The mock board's step trace: (t_s, x_steps, y_steps) a step, with
    `z` (a board with a Z axis) (t_s, x_steps, y_steps, z_steps)."""
    with open(path) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    assert header[:3] == ["t_s", "x_steps", "y_steps"] and header[3:] in ([], ["z_steps"]), header
    assert header[3:] == ["z_steps"] or not z, "the trace has no z_steps: a board without a Z axis"
    if z:
        return [(float(t), int(x), int(y), int(zs)) for t, x, y, zs in rows[1:]]
    return [(float(t), int(x), int(y)) for t, x, y, *_ in rows[1:]]
