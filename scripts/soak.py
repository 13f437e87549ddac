#!/usr/bin/env python3
"""Soak: many jobs back to back through the node graph on the mock board,
beside CPU-bound processes, each held against what the board drew.

mock_board, serial_bridge, gcode_streamer and shape_server run as processes
(as `ros2 run` starts them) beside `--hogs` CPU-bound processes.  A seeded
mix of jobs follows: programs as run_program goals and on /plotter/program,
shapes as draw goals and on /plotter/shape, goals cancelled part-way, and
goals held (feed hold) for a while and resumed.  Each job's slice of the
board's step trace is held step for step against the steps the firmware
core takes for its program (drawing_check.py), and each job falls in one row:

- completed: reported done, and drawn whole;
- canceled: cancelled as asked, reported canceled, and drawn as far as it
  got along its path (a start of its steps);
- cut: reported as not done (with its reason) without being asked to stop;
- silent: reported done (or not reported at all) while it was not drawn
  whole, or drawn off its path.  This must be 0.

Prints one line a job and a table at the end; exits 1 if any job was cut
or silent.

    .venv/bin/python scripts/soak.py --jobs 200 --hogs 2
"""
from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import rclpy
from action_msgs.msg import GoalStatus
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import Trigger

from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.nodes.action_client import ActionClient
from plotter_bridge.nodes.spinning import SpinThread
from plotter_bridge.sim.expected import drawn_whole, first_difference, program_steps
from plotter_interfaces.action import DrawShape, RunProgram
from plotter_interfaces.msg import BoardState, ShapeGoal

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))   # the node graph as processes
from node_processes import PlotterGraph, new_domain, wait_until  # noqa: E402
from drawing_check import figure_program, graph_configs  # noqa: E402

KINDS = ("program goal", "program topic", "shape goal", "shape topic", "cancel", "hold")
WEIGHTS = (35, 15, 20, 10, 8, 12)
SHAPES = ("diamond", "star", "circle", "cone", "car")
JOB_TIMEOUT = 180.0


@dataclass
class Job:
    number: int
    kind: str
    name: str
    program: str = ""                      # G-code (a program job, or the shape's program)
    shape: Optional[dict] = None           # ShapeGoal fields (a shape job)
    reported: str = ""                     # succeeded, aborted, canceled, error, or "" (nothing heard)
    message: str = ""
    verdict: str = ""
    why: str = ""
    problem: str = ""                      # seen while it ran (the pen moved while held)


@dataclass
class Probe:
    """The soak's own ROS node: what it sends and what it hears."""
    node: object
    states: List[Tuple[float, BoardState]] = field(default_factory=list)
    errors: List[Tuple[float, str]] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def latest(self) -> Optional[BoardState]:
        with self.lock:
            return self.states[-1][1] if self.states else None

    def since(self, t0: float) -> List[BoardState]:
        with self.lock:
            return [m for t, m in self.states if t >= t0]

    def errors_since(self, t0: float) -> List[str]:
        with self.lock:
            return [text for t, text in self.errors if t >= t0]


class TraceTail:
    """The steps the mock board adds to its trace, read from where the last
    read ended: over a soak the trace grows to millions of rows."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.offset = len(path.read_bytes().split(b"\n", 1)[0]) + 1     # past the header
        self.last: Tuple[int, int] = (0, 0)                             # the board powers on at 0

    def settled_size(self, quiet: float = 0.5, timeout: float = 30.0) -> int:
        """The file's size once it has not grown for `quiet` seconds (the
        mock board flushes its trace every 0.1 s while it runs)."""
        end = time.monotonic() + timeout
        size, since = -1, time.monotonic()
        while time.monotonic() < end:
            now_size = self.path.stat().st_size
            if now_size != size:
                size, since = now_size, time.monotonic()
            elif time.monotonic() - since >= quiet:
                return size
            time.sleep(0.05)
        raise TimeoutError(f"the step trace {self.path} still grows after {timeout:g} s")

    def take(self) -> List[Tuple[int, int]]:
        """The steps since the last take, once the trace has settled."""
        self.settled_size()
        with open(self.path, "rb") as f:
            f.seek(self.offset)
            data = f.read()
        data = data[:data.rfind(b"\n") + 1]
        self.offset += len(data)
        steps = []
        for row in data.decode().splitlines():
            _, x, y = row.split(",")[:3]
            steps.append((int(x), int(y)))
        if steps:
            self.last = steps[-1]
        return steps


def random_program(rng: random.Random, name: str) -> str:
    """A pen drawing of a few lines and arcs near a random place, inside the 200 x 200 mm area."""
    x, y = rng.uniform(30, 170), rng.uniform(30, 170)
    lines = [f"({name})", "G21 G90", f"G0 X{x:.3f} Y{y:.3f}", "M3", f"F{rng.choice((1200, 2400, 3600))}"]
    for _ in range(rng.randint(2, 6)):
        r = rng.uniform(3, 15)
        if rng.random() < 0.3 and 20 + r <= y <= 180 - r:
            # A full circle through the pen, its centre beside it on the side that keeps it inside.
            i = r if x + 2 * r <= 180 else -r if x - 2 * r >= 20 else 0.0
            if i:
                lines.append(f"G{rng.choice((2, 3))} X{x:.3f} Y{y:.3f} I{i:.3f} J0")
                continue
        x, y = min(max(x + rng.uniform(-40, 40), 20), 180), min(max(y + rng.uniform(-40, 40), 20), 180)
        lines.append(f"G1 X{x:.3f} Y{y:.3f}")
    lines += ["M5", "M2"]
    return "\n".join(lines) + "\n"


def random_shape(rng: random.Random) -> dict:
    shape = rng.choice(SHAPES)
    size = rng.uniform(8, 15) if shape == "circle" else rng.uniform(15, 30)
    return dict(shape=shape, x=rng.uniform(60, 140), y=rng.uniform(60, 140), size=size,
                clockwise=rng.random() < 0.5, reverse=shape == "car" and rng.random() < 0.5,
                feed=rng.choice((1500.0, 3000.0)))


def make_jobs(count: int, seed: int, shapes_params: Dict[str, object]) -> List[Job]:
    rng = random.Random(seed)
    jobs = []
    for k in range(count):
        kind = rng.choices(KINDS, WEIGHTS)[0]
        name = f"soak {k + 1}"
        if kind.startswith("shape"):
            fig = random_shape(rng)
            jobs.append(Job(k + 1, kind, name, figure_program(fig, shapes_params), shape=fig))
        else:
            jobs.append(Job(k + 1, kind, name, random_program(rng, name)))
    return jobs


def judge(job: Job, drawn: List[Tuple[int, int]], expected: List[Tuple[int, int]], start, steps_per_mm) -> None:
    """The job's row, from what was reported and what was drawn."""
    whole = drawn_whole(drawn, expected, start, steps_per_mm)
    on_path = first_difference(drawn, expected) == len(drawn) <= len(expected)
    if job.problem:
        job.verdict, job.why = "cut", job.problem
    elif job.kind == "cancel" and job.reported == "canceled":
        job.verdict, job.why = ("canceled", "") if on_path else ("silent", f"canceled, but {whole}")
    elif job.reported == "succeeded":
        job.verdict, job.why = ("completed", "") if not whole else ("silent", f"reported done, but {whole}")
    elif job.reported:
        job.verdict, job.why = ("cut", job.message) if on_path else ("silent", f"{job.message}; and {whole}")
    else:
        job.verdict, job.why = "silent", f"no outcome reported; {whole or 'drawn whole'}"


class Soak:
    def __init__(self, graph: PlotterGraph, context: Context) -> None:
        node = rclpy.create_node("soak", namespace="/plotter", context=context)
        self.graph = graph
        self.tail = TraceTail(graph.trace)
        self.probe = Probe(node)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(BoardState, "state", self._on_state, latched)
        for topic in ("shape_error", "program_error"):
            node.create_subscription(String, topic, lambda m, topic=topic: self._on_error(topic, m), 50)
        self.pub_program = node.create_publisher(String, "program", 10)
        self.pub_shape = node.create_publisher(ShapeGoal, "shape", 10)
        self.run_client = ActionClient(node, RunProgram, "run_program")
        self.draw_client = ActionClient(node, DrawShape, "draw")
        self.hold = node.create_client(Trigger, "hold")
        self.resume = node.create_client(Trigger, "resume")
        self.executor = MultiThreadedExecutor(num_threads=2, context=context)
        self.executor.add_node(node)
        self.spin = SpinThread(self.executor)

    def _on_state(self, msg: BoardState) -> None:
        with self.probe.lock:
            self.probe.states.append((time.monotonic(), msg))

    def _on_error(self, topic: str, msg: String) -> None:
        with self.probe.lock:
            self.probe.errors.append((time.monotonic(), f"/plotter/{topic}: {msg.data}"))

    def ready(self) -> None:
        wait_until(lambda: (self.probe.latest() is not None and self.probe.latest().state == BoardState.IDLE), 90,
                   "the board")
        wait_until(lambda: self.run_client.server_is_ready() and self.draw_client.server_is_ready(), 60,
                   "the action servers")
        wait_until(lambda: self.pub_program.get_subscription_count() > 0
                   and self.pub_shape.get_subscription_count() > 0, 60, "the topic listeners")
        assert self.hold.wait_for_service(timeout_sec=30) and self.resume.wait_for_service(timeout_sec=30)

    def at_rest(self) -> bool:
        m = self.probe.latest()
        return m is not None and m.state == BoardState.IDLE and m.queue_free == m.queue_size

    def run(self, job: Job, rng: random.Random) -> None:
        t0 = time.monotonic()
        if job.kind.endswith("topic"):
            self._topic_job(job, t0)
            return
        if job.shape is not None:
            handle = self._send(self.draw_client, DrawShape.Goal(shape=ShapeGoal(**job.shape)))
        else:
            handle = self._send(self.run_client, RunProgram.Goal(program=job.program, name=job.name))
        if handle is None:
            job.reported, job.message = "error", "goal not accepted"
            return
        result = handle.get_result_async()
        if job.kind in ("cancel", "hold"):
            wait_until(lambda: any(m.state == BoardState.RUNNING for m in self.probe.since(t0)) or result.done(),
                       60, "the job to run")
            time.sleep(rng.uniform(0.3, 1.5))
            if job.kind == "cancel":
                handle.cancel_goal_async()
            else:
                self._hold_and_resume(job, rng.uniform(1.0, 3.0))
        _wait(result, JOB_TIMEOUT)
        if not result.done():
            return                                                      # nothing heard: judged silent
        wrapped = result.result()
        job.reported = {GoalStatus.STATUS_SUCCEEDED: "succeeded",
                        GoalStatus.STATUS_CANCELED: "canceled"}.get(wrapped.status, "aborted")
        job.message = wrapped.result.message

    def _send(self, client: ActionClient, goal):
        send = client.send_goal_async(goal)
        if not _wait(send, 30.0) or not send.result().accepted:
            return None
        return send.result()

    def _hold_and_resume(self, job: Job, seconds: float) -> None:
        held = _call(self.hold)
        if not held.success:
            job.problem = f"hold refused: {held.message}"
            return
        time.sleep(0.5)                                    # the hold brakes along the ramp
        before = self.tail.settled_size(quiet=0.3)
        time.sleep(seconds)
        after = self.tail.settled_size(quiet=0.3)
        resumed = _call(self.resume)
        if after != before:
            job.problem = f"the trace grew by {after - before} bytes while held"
        if not resumed.success:
            job.problem = f"resume refused: {resumed.message}"

    def _topic_job(self, job: Job, t0: float) -> None:
        if job.shape is not None:
            self.pub_shape.publish(ShapeGoal(**job.shape))
        else:
            self.pub_program.publish(String(data=job.program))

        def ran() -> bool:
            seen = self.probe.since(t0)
            run = [k for k, m in enumerate(seen) if m.state == BoardState.RUNNING]
            return bool(run) and any(m.state == BoardState.IDLE and m.queue_free == m.queue_size
                                     for m in seen[run[0]:])
        end = time.monotonic() + JOB_TIMEOUT
        while time.monotonic() < end:
            errors = self.probe.errors_since(t0)
            if errors and self.at_rest():
                job.reported, job.message = "error", "; ".join(errors)
                return
            if ran():
                time.sleep(0.5)                            # an error published as the board stops
                errors = self.probe.errors_since(t0)
                job.reported, job.message = ("error", "; ".join(errors)) if errors else ("succeeded", "")
                return
            time.sleep(0.05)

    def close(self) -> None:
        self.spin.stop()
        self.probe.node.destroy_node()


def _wait(future, timeout: float) -> bool:
    event = threading.Event()
    future.add_done_callback(lambda _: event.set())
    return event.wait(timeout) or future.done()


def _call(client) -> Trigger.Response:
    future = client.call_async(Trigger.Request())
    if not _wait(future, 15.0):
        return Trigger.Response(success=False, message="no answer")
    return future.result()


def start_hogs(count: int) -> List[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]


def table(jobs: List[Job], hogs: int) -> str:
    rows = ["| jobs | beside | completed | canceled (as asked) | cut | silent |", "|---|---|---|---|---|---|"]
    c = Counter(j.verdict for j in jobs)
    rows.append(f"| {len(jobs)} | {hogs} CPU-bound processes | {c['completed']} | {c['canceled']} | {c['cut']} "
                f"| {c['silent']} |")
    kinds = Counter(j.kind for j in jobs)
    rows.append("")
    rows.append("jobs by kind: " + ", ".join(f"{kinds[k]} {k}" for k in KINDS))
    return "\n".join(rows)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=200)
    ap.add_argument("--hogs", type=int, default=2, help="CPU-bound processes beside the graph (default 2)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    config, shapes = graph_configs()
    jobs = make_jobs(args.jobs, args.seed, shapes)
    rng = random.Random(args.seed + 1)
    work = Path(tempfile.mkdtemp(prefix="plotter-soak-"))
    domain = new_domain() if "ROS_DOMAIN_ID" not in os.environ else int(os.environ["ROS_DOMAIN_ID"])
    hogs = start_hogs(args.hogs)
    graph = PlotterGraph(domain, work)
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    soak: Optional[Soak] = None
    t_start = time.monotonic()
    try:
        soak = Soak(graph, context)
        soak.ready()
        for job in jobs:
            wait_until(soak.at_rest, 60, "the board at rest")
            soak.tail.take()
            start = soak.tail.last
            soak.run(job, rng)
            wait_until(soak.at_rest, 60, "the board at rest after the job")
            drawn = soak.tail.take()
            try:
                expected = program_steps(job.program, config, start)
            except GCodeError as exc:
                expected = []
                job.message = f"{job.message} (the program is refused here too: {exc})"
            judge(job, drawn, expected, start, config.steps_per_mm)
            print(f"{job.number:4d} {job.kind:13s} {job.verdict:9s} {len(drawn):6d} of {len(expected):6d} steps"
                  + (f"  {job.why}" if job.why else ""), flush=True)
    finally:
        if soak is not None:
            soak.close()
        rclpy.try_shutdown(context=context)
        codes = graph.close()
        for h in hogs:
            h.kill()
            h.wait()
    done = [j for j in jobs if j.verdict]
    print(f"\n{len(done)} jobs in {time.monotonic() - t_start:.0f} s (seed {args.seed}); node exit codes {codes}")
    print(table(done, args.hogs))
    bad = [j for j in done if j.verdict in ("cut", "silent")]
    for j in bad:
        print(f"job {j.number} ({j.kind}) {j.verdict}: {j.why}", file=sys.stderr)
    return 1 if bad or any(codes) or len(done) < len(jobs) else 0


if __name__ == "__main__":
    sys.exit(main())
