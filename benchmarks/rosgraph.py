"""The plotter's nodes on the mock board, measured from outside.

Processes, as `ros2 run` would start them: the mock board (mockproc.py: the
firmware core in real time behind a pty), serial_bridge and gcode_streamer.
The benchmark process holds a probe node: it sends programs through the
streamer's `run_program` action, listens to /plotter/position and
/plotter/state, and samples the host nodes' CPU time and resident memory
from /proc.  Board times come from the mock board's step trace.
"""
from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))   # the node graph as processes
from node_processes import NodeProcess, params_file, wait_until  # noqa: E402
from plotter_bridge.motion.commands import BoardCommand
from plotter_bridge.motion.compiler import StreamerConfig

from latency import report_ages
from programs import Program, compile_for

STEPS_PER_MM = 80.0
CLK_TCK = os.sysconf("SC_CLK_TCK")
PAGE_KB = os.sysconf("SC_PAGE_SIZE") // 1024
HERE = Path(__file__).resolve().parent


@dataclass
class ProcSample:
    t: float           # wall clock
    cpu_s: float       # user + system CPU seconds so far
    rss_kb: int


@dataclass
class Position:
    recv: float        # wall clock when the probe got it
    stamp: float       # header stamp (the bridge's clock when it parsed the status)
    x: int             # steps
    y: int


@dataclass
class MockRun:
    name: str
    ok: bool
    message: str
    commands: List[BoardCommand]
    steps: List[Tuple[float, int, int]]          # (wall time, x, y) of every step of the run
    underruns: int
    t_sent: float
    t_done: float
    first_seq: int                                # sequence number of its first command on the wire
    late: float                                   # part of the run the mock board was behind real time
    positions: List[Position] = field(default_factory=list)
    cpu: Dict[str, float] = field(default_factory=dict)      # node: CPU % of one core
    rss_mb: Dict[str, float] = field(default_factory=dict)   # node: largest resident set
    stalls: int = 0                               # mock board loop passes 3 ms or more late

    @property
    def board_time(self) -> float:
        return self.steps[-1][0] - self.steps[0][0] if len(self.steps) > 1 else 0.0


def read_proc(pid: int) -> Optional[Tuple[float, int]]:
    """(CPU seconds, resident kB) of a process, from /proc."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        statm = Path(f"/proc/{pid}/statm").read_text().split()
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2:].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK, int(statm[1]) * PAGE_KB


class ProcSampler:
    def __init__(self, pids: Dict[str, int], period: float = 0.2) -> None:
        self.pids = pids
        self.samples: Dict[str, List[ProcSample]] = {name: [] for name in pids}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._period = period
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.sample()
            self._stop.wait(self._period)

    def sample(self) -> None:
        now = time.time()
        for name, pid in self.pids.items():
            r = read_proc(pid)
            if r:
                self.samples[name].append(ProcSample(now, r[0], r[1]))

    def window(self, t0: float, t1: float) -> Tuple[Dict[str, float], Dict[str, float]]:
        """CPU % and peak RSS (MB) of each process between t0 and t1."""
        cpu, rss = {}, {}
        for name, ss in self.samples.items():
            inside = [s for s in ss if t0 <= s.t <= t1]
            if len(inside) >= 2:
                a, b = inside[0], inside[-1]
                cpu[name] = 100.0 * (b.cpu_s - a.cpu_s) / max(1e-9, b.t - a.t)
                rss[name] = max(s.rss_kb for s in inside) / 1024.0
        return cpu, rss

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)


class TraceReader:
    """Reads the mock board's step trace as it grows; wall-clock times."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._offset = 0
        self._rest = b""
        self.start = 0.0                   # wall clock of board time 0
        self.rows: List[Tuple[float, int, int]] = []

    def update(self) -> None:
        try:
            with open(self.path, "rb") as f:
                f.seek(self._offset)
                data = f.read()
        except OSError:
            return
        self._offset += len(data)
        data = self._rest + data
        *lines, self._rest = data.split(b"\n")
        for line in lines:
            if not line or line.startswith(b"t_s"):
                continue
            t, x, y = line.split(b",")
            self.rows.append((self.start + float(t), int(x), int(y)))


class BenchGraph:
    """mock board + serial_bridge + gcode_streamer, and a probe in this process."""

    def __init__(self, workdir: Path, baud: int = 115200, settings: Sequence[str] = (),
                 domain: Optional[int] = None) -> None:
        import rclpy
        from rclpy.action import ActionClient
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from plotter_bridge.nodes.spinning import SpinThread
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from geometry_msgs.msg import PointStamped
        from plotter_interfaces.action import RunProgram
        from plotter_interfaces.msg import BoardState

        self.domain = domain if domain is not None else random.SystemRandom().randint(101, 199)
        os.environ["ROS_DOMAIN_ID"] = str(self.domain)
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        workdir.mkdir(parents=True, exist_ok=True)
        self.link = workdir / "board.pty"
        self.stats_path = workdir / "board.json"
        self.trace = TraceReader(workdir / "trace.csv")
        self.baud = baud
        # A board that parses in no time, planned for as such: these programs measure the link and the
        # planner, as on the simulated board (the chip's CPU: benchmarks/arcfit.py --chip).
        cmd = [sys.executable, str(HERE / "mockproc.py"), "--link", str(self.link),
               "--trace", str(self.trace.path), "--stats", str(self.stats_path), "--baud", str(baud), "--no-cpu"]
        for s in settings:
            cmd += ["--setting", s]
        self._mock_log = open(workdir / "mock.log", "w")
        self.mock = subprocess.Popen(cmd, stdout=self._mock_log, stderr=subprocess.STDOUT)
        wait_until(lambda: self.link.exists() and self.stats_path.exists(), 20, "the mock board")
        self.trace.start = self.board_stats()["start"]
        ns = ("-r", "__ns:=/plotter", "--params-file", params_file())
        self.bridge = NodeProcess("plotter_bridge.nodes.serial_bridge", self.domain,
                                  ns + ("-p", f"port:={self.link}", "-p", f"baud:={baud}"))
        # chords as written: these programs measure the link and the planner (benchmarks/arcfit.py: fitting)
        self.streamer = NodeProcess("plotter_bridge.nodes.gcode_streamer", self.domain,
                                    ns + ("-p", "fit_arcs:=false", "-p", "board_cpu:=false"))
        self.sampler = ProcSampler({"serial_bridge": self.bridge.proc.pid,
                                    "gcode_streamer": self.streamer.proc.pid,
                                    "mock_board": self.mock.pid})

        self.context = Context()
        rclpy.init(context=self.context, domain_id=self.domain)
        self.node = rclpy.create_node("benchmark_probe", namespace="/plotter", context=self.context)
        self.positions: List[Position] = []
        self.state = None
        self._lock = threading.Lock()
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(PointStamped, "position", self._on_position, 100)
        self.node.create_subscription(BoardState, "state", self._on_state, latched)
        self._client = ActionClient(self.node, RunProgram, "run_program")
        self._RunProgram = RunProgram
        self._idle = BoardState.IDLE
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._spin = SpinThread(self.executor)
        wait_until(lambda: self.state is not None and self.state.state == self._idle, 60, "the bridge")
        if not self._client.wait_for_server(timeout_sec=30.0):
            raise RuntimeError("gcode_streamer's run_program action did not appear")

    # --- probe callbacks ---------------------------------------------------------
    def _on_position(self, msg) -> None:
        now = time.time()
        s = msg.header.stamp
        self.positions.append(Position(now, s.sec + s.nanosec * 1e-9,
                                       round(msg.point.x * 1000 * STEPS_PER_MM), round(msg.point.y * 1000 * STEPS_PER_MM)))

    def _on_state(self, msg) -> None:
        self.state = msg

    def board_stats(self) -> dict:
        return json.loads(self.stats_path.read_text())

    # --- running programs --------------------------------------------------------
    def run(self, program: Program, timeout: float = 300.0) -> MockRun:
        """Draw one program; everything measured while it ran."""
        wait_until(lambda: self.state is not None and self.state.state == self._idle
                   and self.state.queue_free == self.state.queue_size, 30, "an idle board")
        start = (self.state.x_steps, self.state.y_steps)
        first_seq = self.state.next_seq
        # As gcode_streamer compiles it: the link cap at the bridge's baud.
        config = StreamerConfig(link_baud=self.baud, link_seq=first_seq, fit_arcs=False, board_cpu=False)
        commands = compile_for(program, start, config=config)
        self.trace.update()
        first_row = len(self.trace.rows)
        first_pos = len(self.positions)
        stats0 = self.board_stats()
        goal = self._RunProgram.Goal()
        goal.program, goal.name = program.gcode, program.name
        t_sent = time.time()
        done = threading.Event()
        result: dict = {}

        def on_result(fut) -> None:
            r = fut.result().result
            result.update(ok=r.success, message=r.message)
            done.set()

        def on_goal(fut) -> None:
            handle = fut.result()
            if not handle.accepted:
                result.update(ok=False, message="goal refused")
                done.set()
                return
            handle.get_result_async().add_done_callback(on_result)

        self._client.send_goal_async(goal).add_done_callback(on_goal)
        if not done.wait(timeout):
            raise RuntimeError(f"{program.name}: no result within {timeout} s")
        t_done = time.time()
        time.sleep(0.3)                       # the trace is flushed when the board comes to rest
        self.trace.update()
        steps = self.trace.rows[first_row:]
        cpu, rss = self.sampler.window(t_sent, t_done)
        stats1 = self.board_stats()
        late = (stats1["late"] - stats0["late"]) / max(1, stats1["samples"] - stats0["samples"])
        return MockRun(program.name, bool(result.get("ok")), str(result.get("message", "")),
                       commands, steps, stats1["underruns"] - stats0["underruns"], t_sent, t_done,
                       first_seq, late, self.positions[first_pos:], cpu, rss,
                       stats1.get("stalls", 0) - stats0.get("stalls", 0))

    def close(self) -> None:
        import rclpy
        self.sampler.close()
        self._spin.stop()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        for p in (self.streamer, self.bridge):
            try:
                p.interrupt()
            finally:
                p.close()
        self.mock.terminate()
        try:
            self.mock.wait(10)
        except subprocess.TimeoutExpired:
            self.mock.kill()
            self.mock.wait()
        self._mock_log.close()


def position_latencies(run: MockRun) -> Tuple[List[float], List[float], int]:
    """Ages (latency.report_ages) of the position messages of a run: by the
    time the probe received them, and by their header stamp (when
    serial_bridge parsed the status report); and the unmatched count."""
    recv, unmatched = report_ages(run.steps, [(p.recv, p.x, p.y) for p in run.positions])
    stamp, _ = report_ages(run.steps, [(p.stamp, p.x, p.y) for p in run.positions])
    return recv, stamp, unmatched


def segment_end_times(run: MockRun) -> List[float]:
    """Wall time of the last step of each motion command, counting steps
    (exact for lines, the planner's count for arcs)."""
    out, n = [], 0
    for c in run.commands:
        if c.is_motion:
            n += c.steps
            if n - 1 < len(run.steps):
                out.append(run.steps[n - 1][0])
    return out
