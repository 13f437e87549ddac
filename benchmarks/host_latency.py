#!/usr/bin/env python3
"""How late messages between the plotter's node processes arrive, with CPU-bound processes beside them.

Starts the node graph as processes (tests/node_processes.PlotterGraph: mock_board, serial_bridge,
gcode_streamer, shape_server), `--hogs N` busy loops beside it, and keeps a job drawing on the mock
board (run_program goals of a zig-zag of 1 mm segments, as the command-line client sends them).
Meanwhile two probe processes, this file run with `--probe send` and `--probe recv`, measure:

- /plotter/position: its header stamp (serial_bridge's clock as the board's status arrived) to the
  moment the receiving probe's callback runs, and the gaps between consecutive messages there;
- a std_msgs/String carrying time.time(), published every 0.5 s by one probe and received by the
  other (depth 10, reliable), the way the streamer's job lease travelled to serial_bridge;
- the gaps between the streamer's own renewals on /plotter/job_lease, while its build still has them;
- how late a thread of the sender probe wakes from a 10 ms sleep: what CPU contention alone costs.

Arrivals until 1 s after the receiver first heard both topics (it starting and matching) are left out.  The mock board
and serial_bridge talk at `--baud` (115200 by default, so that /plotter/position comes at 25 Hz
while drawing and a stall shows as a gap).

It also times plotter_bridge.link.journal.Journal.update (a small file written with fsync) in a
directory under the ROS home, before anything starts and again under load, and samples each
process's CPU time and run-queue wait (/proc/<pid>/task/*/schedstat) over the measurement window.

    python benchmarks/host_latency.py --hogs 2 --seconds 40
    python benchmarks/host_latency.py --sweep 0,1,2,4 --runs 3 --seconds 30

Prints a markdown table to paste into docs/reliability.md (with --sweep, one row per number of hogs
over all its runs).  A benchmark, not a test: it asserts
nothing.  Every process it started is stopped at the end, also on Ctrl-C or an error.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))   # the node graph as processes

PING_TOPIC = "/host_latency/ping"
PING_PERIOD = 0.5          # s: the lease's renewal period (lease 2 s / 4)
THRESHOLDS = (0.5, 1.0, 2.0)
WARMUP = 1.0              # s: left out after the receiver first hears each topic
WAKE_PERIOD = 0.01         # s: the sender's thread that measures wake-up lateness
STEPS_PER_MM = 80.0


# --- statistics (pure) ------------------------------------------------------------------

@dataclass(frozen=True)
class Summary:
    count: int
    median: float
    p99: float
    p999: float
    max: float
    over: Tuple[int, ...]      # how many exceed each of THRESHOLDS


def percentile(ordered: Sequence[float], q: float) -> float:
    """The q-th percentile (0..100) of sorted values, interpolated between the closest ranks."""
    if not ordered:
        return math.nan
    pos = (len(ordered) - 1) * q / 100.0
    lo = math.floor(pos)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (pos - lo)


def summarize(values: Sequence[float], thresholds: Sequence[float] = THRESHOLDS) -> Summary:
    ordered = sorted(values)
    return Summary(len(ordered), percentile(ordered, 50), percentile(ordered, 99), percentile(ordered, 99.9),
                   ordered[-1] if ordered else math.nan, tuple(sum(v > t for v in ordered) for t in thresholds))


def gaps(times: Sequence[float]) -> List[float]:
    """Intervals between consecutive arrivals, in arrival order."""
    return [b - a for a, b in zip(times, times[1:])]


def gaps_by_key(arrivals: Sequence[Tuple[float, str]]) -> List[float]:
    """Intervals between consecutive arrivals with the same key (a job id: the time between two
    jobs, when no lease is renewed, is no gap)."""
    last: Dict[str, float] = {}
    out = []
    for t, key in arrivals:
        if key in last:
            out.append(t - last[key])
        last[key] = t
    return out


def window_start(arrivals: Sequence[Sequence[Sequence[float]]], warmup: float) -> float:
    """`warmup` after the latest of the first arrivals of each stream (records start with the arrival
    time); inf if a stream is empty."""
    if not all(arrivals):
        return math.inf
    return max(stream[0][0] for stream in arrivals) + warmup


def path_length(points: Sequence[Tuple[float, float]]) -> float:
    return sum(math.hypot(bx - ax, by - ay) for (ax, ay), (bx, by) in zip(points, points[1:]))


def missing(seqs: Sequence[int], sent: int) -> int:
    """Sequence numbers 0..sent-1 that never arrived."""
    return len(set(range(sent)) - set(seqs))


def share(calls: Sequence["Call"], part: str) -> float:
    """Per cent of the calls' time spent in `part` ('cpu', 'queued' or 'blocked')."""
    wall = sum(c.wall for c in calls)
    return 100.0 * sum(getattr(c, part) for c in calls) / wall if wall > 0 else math.nan


def ms(seconds: float) -> str:
    return "-" if math.isnan(seconds) else f"{seconds * 1000:.1f}"


# --- the job -----------------------------------------------------------------------------

def zigzag(strokes: int, width: float = 40.0, pitch: float = 0.5, feed: float = 2400.0,
           x0: float = 20.0, y0: float = 20.0) -> str:
    """A pen-down zig-zag of `strokes` strokes, each of 1 mm G1 segments: at this feed about 40 board
    commands a second, so the streamer journals progress and the bridge sends lines continuously,
    as for a real drawing (about 1.1 s a stroke)."""
    lines = ["(host_latency zig-zag)", "G21 G90", f"G0 X{x0:.1f} Y{y0:.1f}", "M3", f"F{feed:.0f}"]
    for k in range(strokes):
        y = y0 + pitch * k
        ahead = k % 2 == 0
        for i in range(1, int(width) + 1):
            lines.append(f"G1 X{x0 + (i if ahead else width - i):.1f} Y{y:.1f}")
        lines.append(f"G1 Y{y + pitch:.1f}")
    lines += ["M5", "M2"]
    return "\n".join(lines) + "\n"


@dataclass
class JobResult:
    success: bool
    message: str
    lines_done: int
    seconds: float


class JobDriver:
    """Sends run_program goals one after another from a thread, until stopped."""

    def __init__(self, probe, program: str) -> None:
        self.probe = probe
        self.program = program
        self.results: List[JobResult] = []
        self.error = ""
        self._handle = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="jobs", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from plotter_interfaces.action import RunProgram
        try:
            client = self.probe.action_client(RunProgram, "run_program")
            if not client.wait_for_server(timeout_sec=30):
                self.error = "run_program server not found"
                return
            while not self._stop.is_set():
                t0 = time.monotonic()
                send = client.send_goal_async(RunProgram.Goal(program=self.program, name="host_latency"))
                if not self._wait(send.done, 30):
                    self.error = self.error or "run_program goal not answered in 30 s"
                    return
                handle = send.result()
                if not handle.accepted:
                    self.results.append(JobResult(False, "goal rejected", 0, 0.0))
                    self._stop.wait(1.0)
                    continue
                self._handle = handle
                result = handle.get_result_async()
                if not self._wait(result.done, 1e9):
                    return
                r = result.result().result
                self.results.append(JobResult(r.success, r.message, r.lines_done, time.monotonic() - t0))
                self._handle = None
        except Exception as exc:            # reported with the figures; the latency probes go on
            self.error = f"{type(exc).__name__}: {exc}"

    def _wait(self, done, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while not done():
            if self._stop.is_set() or time.monotonic() > end:
                return False
            time.sleep(0.05)
        return True

    def stop(self) -> None:
        self._stop.set()
        handle = self._handle
        if handle is not None:
            # Cancelled rather than cut by the graph's shutdown: the nodes then stop idle.
            future = handle.cancel_goal_async()
            end = time.monotonic() + 5.0
            while not future.done() and time.monotonic() < end:
                time.sleep(0.05)
        self._thread.join(timeout=10)


# --- /proc sampling ----------------------------------------------------------------------

@dataclass(frozen=True)
class SchedSample:
    t: float           # monotonic s
    cpu: float         # s on a CPU, all threads
    wait: float        # s runnable but waiting for a CPU, all threads


def read_sched(pid: int) -> Optional[Tuple[float, float]]:
    """(CPU s, run-queue wait s) summed over a process's live threads (threads that ended are lost)."""
    cpu = wait = 0.0
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return None
    for tid in tasks:
        try:
            fields = Path(f"/proc/{pid}/task/{tid}/schedstat").read_text().split()
        except OSError:
            continue
        cpu += int(fields[0]) / 1e9
        wait += int(fields[1]) / 1e9
    return cpu, wait


def sample(pids: Dict[str, int]) -> Dict[str, SchedSample]:
    now = time.monotonic()
    out = {}
    for name, pid in pids.items():
        r = read_sched(pid)
        if r is not None:
            out[name] = SchedSample(now, *r)
    return out


def read_cpu_times() -> Tuple[float, float]:
    """(busy, total) jiffies of the whole machine, from /proc/stat."""
    values = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    idle = values[3] + values[4]          # idle + iowait
    return float(sum(values) - idle), float(sum(values))


def machine_busy(before: Tuple[float, float], after: Tuple[float, float], cpus: int) -> float:
    """CPU % of one core the whole machine used between two read_cpu_times() (2 busy cores: 200)."""
    total = after[1] - before[1]
    return 100.0 * cpus * (after[0] - before[0]) / total if total > 0 else math.nan


def shares(before: Dict[str, SchedSample], after: Dict[str, SchedSample]) -> Dict[str, Tuple[float, float]]:
    """Per process: (CPU % of one core, run-queue wait in ms per second) between two samples."""
    out = {}
    for name, a in before.items():
        b = after.get(name)
        if b is not None and b.t > a.t:
            span = b.t - a.t
            out[name] = (100.0 * (b.cpu - a.cpu) / span, 1000.0 * (b.wait - a.wait) / span)
    return out


# --- the journal -------------------------------------------------------------------------

def ros_home() -> Path:
    return Path(os.environ.get("ROS_HOME") or Path.home() / ".ros")


@dataclass(frozen=True)
class Call:
    wall: float        # s the call took
    cpu: float         # s of it on a CPU
    queued: float      # s of it runnable but waiting for a CPU

    @property
    def blocked(self) -> float:
        """Neither running nor runnable: in this single-threaded process, blocked in the kernel (in fsync,
        on the disk and whatever the file system waits for)."""
        return max(0.0, self.wall - self.cpu - self.queued)


def thread_sched() -> Tuple[float, float]:
    """(CPU s, run-queue wait s) of the calling thread so far, from its schedstat."""
    fields = Path(f"/proc/self/task/{threading.get_native_id()}/schedstat").read_text().split()
    return int(fields[0]) / 1e9, int(fields[1]) / 1e9


def time_journal(directory: Path, calls: int, limit_s: float = 60.0) -> List[Call]:
    """Each Journal.update, with new progress every time (an unchanged one writes nothing)."""
    from plotter_bridge.link.journal import RUNNING, Journal, Progress
    journal = Journal(directory)
    job_id = uuid.uuid4().hex
    out = []
    end = time.monotonic() + limit_s
    for k in range(calls):
        (c0, q0), t0 = thread_sched(), time.perf_counter()
        journal.update(job_id, Progress(k, RUNNING))
        t1, (c1, q1) = time.perf_counter(), thread_sched()
        out.append(Call(t1 - t0, c1 - c0, q1 - q0))
        if time.monotonic() > end:
            break
    return out


def run_journal_probe(out: Path, calls: int) -> int:
    # Beside the streamer's own journal (~/.ros/plotter_journal): the same disk and file system.
    home = ros_home()
    home.mkdir(parents=True, exist_ok=True)
    directory = Path(tempfile.mkdtemp(prefix="host_latency_journal-", dir=home))
    try:
        out.write_text(json.dumps([[c.wall, c.cpu, c.queued] for c in time_journal(directory, calls)]))
    finally:
        shutil.rmtree(directory, ignore_errors=True)
    return 0


def journal_figures(calls: int, work: Path) -> List[Call]:
    """Timed in a process of its own with one thread: no other thread holds its GIL, so the time a call
    neither runs nor waits for a CPU is spent blocked in the kernel (fsync)."""
    out = work / "journal.json"
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--probe", "journal", "--out", str(out),
                    "--journal-calls", str(calls)], check=True, timeout=120)
    return [Call(*c) for c in json.loads(out.read_text())]


# --- probe processes ---------------------------------------------------------------------

def run_sender(domain: int, out: Path, seconds: float) -> int:
    """Publishes '<seq> <time.time()>' every PING_PERIOD from the main thread, on a node nothing
    spins (as the streamer published the lease from its job thread), for `seconds`."""
    import rclpy
    from std_msgs.msg import String
    from plotter_bridge.nodes.teardown import teardown_watchdog
    rclpy.init(domain_id=domain)
    node = rclpy.create_node("host_latency_sender")
    pub = node.create_publisher(String, PING_TOPIC, 10)
    sent = 0
    late: List[float] = []
    done = threading.Event()

    def wake_up() -> None:
        # How late this process gets a CPU back after a sleep: the scheduling share of any delay.
        while not done.is_set():
            due = time.monotonic() + WAKE_PERIOD
            time.sleep(WAKE_PERIOD)
            late.append(time.monotonic() - due)
    threading.Thread(target=wake_up, daemon=True).start()
    try:
        end = time.monotonic() + 30.0
        while pub.get_subscription_count() == 0 and time.monotonic() < end:
            time.sleep(0.05)
        # The writer matches before the reader has: a message sent now would wait for a repair.
        time.sleep(1.0)
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds:
            pub.publish(String(data=f"{sent} {time.time():.6f}"))
            sent += 1
            # On a fixed schedule: a late wake-up is not carried into the next period.
            time.sleep(max(0.0, t0 + sent * PING_PERIOD - time.monotonic()))
    except KeyboardInterrupt:
        pass
    finally:
        done.set()
        out.write_text(json.dumps({"sent": sent, "wake_late": late}))
        with teardown_watchdog():
            node.destroy_node()
            rclpy.try_shutdown()
    return 0


def run_receiver(domain: int, out: Path, threads: int) -> int:
    """Records the arrival (time.time()) of every /plotter/position and ping until Ctrl-C, then writes
    them to `out`; a plain rclpy node, default QoS depth 10 (reliable)."""
    import rclpy
    from geometry_msgs.msg import PointStamped
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor
    from std_msgs.msg import String
    from plotter_bridge.nodes.teardown import teardown_watchdog
    rclpy.init(domain_id=domain)
    node = rclpy.create_node("host_latency_receiver")
    positions: List[Tuple[float, float, float, float]] = []
    pings: List[Tuple[float, int, float]] = []
    leases: List[Tuple[float, str]] = []

    def on_position(msg: PointStamped) -> None:
        now = time.time()          # first: whatever this callback does after is not latency
        positions.append((now, msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, msg.point.x, msg.point.y))

    def on_ping(msg: String) -> None:
        now = time.time()
        seq, sent = msg.data.split()
        pings.append((now, int(seq), float(sent)))

    node.create_subscription(PointStamped, "/plotter/position", on_position, 10)
    node.create_subscription(String, PING_TOPIC, on_ping, 10)
    # The streamer's own renewals, while its build still has them: their path, not a stand-in's.
    node.create_subscription(String, "/plotter/job_lease", lambda m: leases.append((time.time(), m.data)), 10)
    executor = MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
    executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        # Written before the teardown, which Fast DDS can hang (nodes/teardown.py).
        out.write_text(json.dumps({"positions": positions, "pings": pings, "leases": leases}))
        with teardown_watchdog():
            executor.shutdown(timeout_sec=2.0)
            node.destroy_node()
            rclpy.try_shutdown()
    return 0


# --- the run -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Row:
    name: str
    summary: Summary
    period: float = 0.0        # nominal interval of a gap row: a threshold at or below it counts nothing useful


@dataclass
class Figures:
    command: str
    hogs: int
    seconds: float
    baud: int
    rows: List[Row] = field(default_factory=list)
    pings_sent: int = 0
    pings_lost: int = 0
    journal_idle: List[Call] = field(default_factory=list)
    journal_loaded: List[Call] = field(default_factory=list)
    load: Dict[str, Tuple[float, float]] = field(default_factory=dict)
    machine: float = math.nan    # CPU % of one core, every process on the machine
    pen_travel_mm: float = 0.0
    analysed: float = 0.0        # s of arrivals in the figures (the window less the receiver's start)
    jobs: List[JobResult] = field(default_factory=list)
    job_error: str = ""
    loadavg: str = ""


def start_hogs(n: int) -> List[subprocess.Popen]:
    # A session of their own: a Ctrl-C does not print their tracebacks; stop_hogs() ends them.
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, start_new_session=True) for _ in range(n)]


def stop_hogs(hogs: List[subprocess.Popen]) -> None:
    for p in hogs:
        if p.poll() is None:
            p.kill()
        p.wait()


def stop_probe(p) -> None:
    """Ctrl-C to a probe process (again: a no-op once it has ended)."""
    if p.log.closed:
        return
    try:
        p.interrupt(timeout=10.0)
    except RuntimeError as exc:
        log(f"warning: {exc}")
    finally:
        p.close()


def close_graph(graph) -> None:
    codes = graph.close()
    if any(codes):
        log(f"node exit codes {codes}")


def log(text: str) -> None:
    print(f"[host_latency] {text}", file=sys.stderr, flush=True)


def measure(args: argparse.Namespace, command: str) -> Figures:
    from node_processes import NodeProcess, PlotterGraph, new_domain, wait_until
    from ros_graph import Probe
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from plotter_interfaces.msg import BoardState

    fig = Figures(command, args.hogs, args.seconds, args.baud)
    domain = new_domain()
    # Each thing started is stopped on the way out, in reverse order, even when stopping another fails.
    with contextlib.ExitStack() as stack:
        # Under the ROS home like the real journal: the streamer's fsyncs go to the same disk.
        ros_home().mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix="host_latency-", dir=ros_home()))
        stack.callback(shutil.rmtree, work, ignore_errors=True)
        log(f"timing Journal.update x{args.journal_calls}, nothing else running")
        fig.journal_idle = journal_figures(args.journal_calls, work)
        hogs = start_hogs(args.hogs)
        stack.callback(stop_hogs, hogs)
        log(f"{args.hogs} CPU hogs; starting the node graph (ROS domain {domain}) in {work}")
        baud = ("-p", f"baud:={args.baud}")
        graph = PlotterGraph(domain, work, board_args=baud, bridge_args=baud)
        stack.callback(close_graph, graph)
        probe = Probe(domain)
        stack.callback(probe.close)
        # rclpy.init put in its own SIGINT handler, which only shuts the probe's context down: a Ctrl-C
        # must end this run (the stack stops everything), not leave it to print a partial table.
        signal.signal(signal.SIGINT, signal.default_int_handler)
        states: List[int] = []
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        probe.node.create_subscription(BoardState, "state", lambda m: states.append(m.state), latched)
        wait_until(lambda: BoardState.IDLE in states, 90, "the board (IDLE)")
        # Long enough that one job normally spans the whole window; JobDriver sends another if not.
        driver = JobDriver(probe, zigzag(strokes=int(args.seconds / 1.1) + 30))

        def stop_driver() -> None:
            driver.stop()
            fig.jobs, fig.job_error = driver.results, driver.error
        stack.callback(stop_driver)
        wait_until(lambda: BoardState.RUNNING in states or driver.error or driver.results, 60, "the job")

        recv_out, send_out = work / "receiver.json", work / "sender.json"
        me = [sys.executable, str(Path(__file__).resolve())]
        receiver = NodeProcess("host_latency receiver", domain, command=me + [
            "--probe", "recv", "--domain", str(domain), "--out", str(recv_out),
            "--receiver-threads", str(args.receiver_threads)])
        stack.callback(stop_probe, receiver)
        sender = NodeProcess("host_latency sender", domain, command=me + [
            "--probe", "send", "--domain", str(domain), "--out", str(send_out), "--seconds", str(args.seconds)])
        stack.callback(stop_probe, sender)
        pids = {"mock_board": graph.board.proc.pid, "serial_bridge": graph.bridge.proc.pid,
                "gcode_streamer": graph.streamer.proc.pid, "shape_server": graph.shapes.proc.pid,
                "receiver": receiver.proc.pid, "this process": os.getpid()}   # not the sender: it has ended
        pids.update({f"hog {k + 1}": p.pid for k, p in enumerate(hogs)})
        log(f"measuring for {args.seconds:g} s")
        before, cpu_before = sample(pids), read_cpu_times()
        wait_until(lambda: not sender.alive(), args.seconds + 60, "the sender probe")
        fig.load = shares(before, sample(pids))
        fig.machine = machine_busy(cpu_before, read_cpu_times(), os.cpu_count() or 1)
        fig.loadavg = Path("/proc/loadavg").read_text().split(" ")[0]
        time.sleep(1.0)            # the last pings in flight
        stop_probe(receiver)       # it writes what it received as it stops

        log(f"timing Journal.update x{args.journal_calls} under the same load")
        fig.journal_loaded = journal_figures(args.journal_calls, work)

        data = json.loads(recv_out.read_text())
        sender_data = json.loads(send_out.read_text())
        fig.pings_sent = sender_data["sent"]
        if args.raw:
            shutil.copyfile(recv_out, args.raw)
        # The first messages after the receiver matches a writer waited for the match, not for the graph
        # (/plotter/position's first ones arrive up to ~0.3 s old, ~2 s after the first ping): the
        # window opens WARMUP after the first message of each topic.
        start = window_start([data["pings"], data["positions"]], WARMUP)
        pings = [p for p in data["pings"] if p[0] >= start]
        positions = [p for p in data["positions"] if p[0] >= start]
        leases = [p for p in data["leases"] if p[0] >= start]
        fig.rows = [
            Row("/plotter/position: bridge stamp to probe callback", summarize([r - s for r, s, _, _ in positions])),
            Row("ping String, probe to probe (every 0.5 s)", summarize([r - s for r, _, s in pings])),
            Row("/plotter/position: gap between arrivals (25 Hz)", summarize(gaps([r for r, _, _, _ in positions])),
                period=0.04),
            Row("ping String: gap between arrivals (sent every 0.5 s)", summarize(gaps([r for r, _, _ in pings])),
                period=PING_PERIOD),
            Row("wake-up lateness of a 10 ms sleep (a thread in the sender probe)",
                summarize(sender_data["wake_late"])),
            Row("/plotter/job_lease: gap between arrivals (renewed every 0.5 s)", summarize(gaps_by_key(leases)),
                period=PING_PERIOD),
        ]
        fig.pen_travel_mm = 1000.0 * path_length([(x, y) for _, _, x, y in positions])
        fig.pings_lost = missing([q for _, q, _ in data["pings"]], fig.pings_sent)
        fig.analysed = max(p[0] for p in data["pings"] + data["positions"]) - start if pings else 0.0
    return fig


def render(fig: Figures) -> str:
    cpus = os.cpu_count()
    out = [f"`{fig.command}` ({fig.baud} baud; {cpus} CPUs, {platform.machine()}, Python {platform.python_version()}; "
           f"{fig.hogs} CPU-bound processes beside the graph, {fig.seconds:g} s of pings, the last "
           f"{fig.analysed:.0f} s of arrivals analysed, "
           f"1-minute load average {fig.loadavg} at its end)", ""]
    heads = " | ".join(f"> {t:g} s" for t in THRESHOLDS)
    absent: List[str] = []
    out += [f"| message delivery | count | median ms | p99 ms | p99.9 ms | max ms | {heads} |",
            "|---|---|---|---|---|---|" + "---|" * len(THRESHOLDS)]
    for row in fig.rows:
        s = row.summary
        if s.count == 0:           # /plotter/job_lease with a build that no longer has the lease
            absent.append(row.name.split(":")[0])
            continue
        over = " | ".join(str(n) if t > row.period else "n/a" for n, t in zip(s.over, THRESHOLDS))
        out.append(f"| {row.name} | {s.count} | {ms(s.median)} | {ms(s.p99)} | {ms(s.p999)} | {ms(s.max)} | {over} |")
    out += ["", "| Journal.update (write + fsync + rename) | calls | median ms | p99 ms | max ms "
                "| slowest call: on a CPU / waiting for one / blocked in the kernel, ms |", "|---|---|---|---|---|---|"]
    for name, calls in (("before the graph starts, no hogs", fig.journal_idle),
                        (f"beside the graph, its job and {fig.hogs} hogs", fig.journal_loaded)):
        s = summarize([c.wall for c in calls])
        slowest = max(calls, key=lambda c: c.wall)
        out.append(f"| {name} | {s.count} | {ms(s.median)} | {ms(s.p99)} | {ms(s.max)} "
                   f"| {ms(slowest.cpu)} / {ms(slowest.queued)} / {ms(slowest.blocked)} |")
    loaded = fig.journal_loaded
    out += ["", f"Of all Journal.update time beside the graph: {share(loaded, 'cpu'):.0f} % on a CPU, "
                f"{share(loaded, 'queued'):.0f} % waiting for one, "
                f"{share(loaded, 'blocked'):.0f} % blocked in the kernel (fsync)."]
    others = fig.machine - sum(c for c, _ in fig.load.values())
    out += ["", "CPU % of one core / run-queue wait ms per s, over the window: " +
            ", ".join(f"{n} {c:.0f} % / {w:.0f}" for n, (c, w) in fig.load.items()) +
            f"; the whole machine {fig.machine:.0f} %, of it {max(0.0, others):.0f} % processes not started here."]
    jobs = ", ".join(f"{'done' if j.success else 'ended: ' + j.message} ({j.lines_done} lines, {j.seconds:.0f} s)"
                     for j in fig.jobs) or "none finished before the end"
    out.append(f"Pings lost: {fig.pings_lost} of {fig.pings_sent}. Pen travel in the window (from /plotter/position): "
               f"{fig.pen_travel_mm:.0f} mm. Jobs: {jobs}."
               + (f" Job driver: {fig.job_error}." if fig.job_error else "")
               + (f" Nothing arrived on {', '.join(absent)}." if absent else ""))
    return "\n".join(out)


def render_sweep(command: str, runs: Dict[int, List[Figures]]) -> str:
    """One row per number of hogs: the median run's median and the worst run's tail, so one bad run shows."""
    def worst(figs: List[Figures], row: int, attr: str) -> float:
        return max(getattr(f.rows[row].summary, attr) for f in figs)

    def mid(figs: List[Figures], row: int) -> float:
        return percentile(sorted(f.rows[row].summary.median for f in figs), 50)

    first = next(iter(runs.values()))[0]
    out = [f"`{command}` ({first.baud} baud; {os.cpu_count()} CPUs, {platform.machine()}, Python "
           f"{platform.python_version()}; each run {first.seconds:g} s of pings)", "",
           "| hogs | runs | position latency median / worst p99 / worst max, ms | ping latency worst max, ms "
           "| position gap worst max, ms (25 Hz) | 10 ms sleep worst lateness, ms | pings lost "
           "| Journal.update under load worst max, ms | machine CPU, % of one core |",
           "|---|---|---|---|---|---|---|---|---|"]
    for hogs, figs in runs.items():
        journal = max(c.wall for f in figs for c in f.journal_loaded)
        cpu = percentile(sorted(f.machine for f in figs), 50)
        out.append(f"| {hogs} | {len(figs)} | {ms(mid(figs, 0))} / {ms(worst(figs, 0, 'p99'))} / "
                   f"{ms(worst(figs, 0, 'max'))} | {ms(worst(figs, 1, 'max'))} | {ms(worst(figs, 2, 'max'))} "
                   f"| {ms(worst(figs, 4, 'max'))} | {sum(f.pings_lost for f in figs)} of "
                   f"{sum(f.pings_sent for f in figs)} | {ms(journal)} | {cpu:.0f} |")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hogs", type=int, default=2, help="CPU-bound processes beside the graph (default 2)")
    ap.add_argument("--seconds", type=float, default=60.0, help="measurement window, s (default 60)")
    ap.add_argument("--journal-calls", type=int, default=500, help="Journal.update calls timed (default 500)")
    ap.add_argument("--receiver-threads", type=int, default=1,
                    help="executor threads of the receiving probe: 1 = SingleThreadedExecutor (default), "
                         "4 = the nodes' MultiThreadedExecutor")
    ap.add_argument("--baud", type=int, default=115200,
                    help="serial line of the mock board and serial_bridge (default 115200: /plotter/position at its "
                         "25 Hz while drawing; at 9600, the link's default, status polls are held to ~1 Hz)")
    ap.add_argument("--sweep", help="comma-separated numbers of hogs to measure in turn (overrides --hogs)")
    ap.add_argument("--runs", type=int, default=1, help="runs per number of hogs with --sweep (default 1)")
    ap.add_argument("--raw", type=Path, help="also write the receiving probe's arrivals (JSON) here")
    ap.add_argument("--probe", choices=("send", "recv", "journal"), help=argparse.SUPPRESS)
    ap.add_argument("--domain", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.probe == "send":
        return run_sender(args.domain, args.out, args.seconds)
    if args.probe == "recv":
        return run_receiver(args.domain, args.out, args.receiver_threads)
    if args.probe == "journal":
        return run_journal_probe(args.out, args.journal_calls)
    if args.hogs < 0 or args.seconds <= 0 or args.journal_calls <= 0:
        ap.error("--hogs must be >= 0, --seconds and --journal-calls > 0")
    command = "python benchmarks/host_latency.py " + shlex.join(sys.argv[1:])
    if args.sweep:
        try:
            counts = [int(n) for n in args.sweep.split(",")]
        except ValueError:
            ap.error(f"--sweep: numbers of hogs separated by commas, not {args.sweep!r}")
        if min(counts) < 0 or args.runs < 1:
            ap.error("--sweep counts must be >= 0 and --runs >= 1")
        runs: Dict[int, List[Figures]] = {}
        try:
            for hogs in counts:
                for k in range(args.runs):
                    log(f"sweep: {hogs} hogs, run {k + 1} of {args.runs}")
                    one = argparse.Namespace(**{**vars(args), "hogs": hogs, "raw": None})
                    runs.setdefault(hogs, []).append(measure(one, command))
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return 130
        print(render_sweep(command, runs))
        return 0
    try:
        fig = measure(args, command)
    except KeyboardInterrupt:      # every process is stopped by now
        print("interrupted", file=sys.stderr)
        return 130
    print(render(fig))
    return 0


if __name__ == "__main__":
    sys.exit(main())
