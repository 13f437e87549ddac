#!/usr/bin/env python3
"""Big drawings: `plotter check` beside LinuxCNC's rs274 on the same files, wall time and peak
resident memory of each process, for random walks of 10k, 100k and 1M lines
(benchmarks/big_drawing.py); then each drawing sent with `plotter stream` to the node graph on
the mock board (each node its own process, as `ros2 run` starts them): the time from the command
to the pen's first move, the peak resident memory of each process by then, and the bytes of the
two messages that carry the job (run_program's goal, the program; stream_commands', its board
commands), as DDS serializes them.  And the pictures of each drawing: `plotter check --png`,
`plotter svg --preview` of the same walk written as SVG paths, and the page's check of an upload
(plotter_web/jobs.py check_upload, and the bytes of the JSON the page gets): time, peak memory and
the tolerance the preview was drawn within (gcode/thinning.py).

    bash scripts/setup.sh && source ros_ws/install/setup.bash && \
        .venv/bin/python benchmarks/big_jobs.py [--sizes 10000 100000 1000000] [--no-graph] [--no-pictures]

rs274 is fetched as tests/test_gcode_oracle.py does (Debian's linuxcnc-uspace, cached in
~/.cache/plotter-rs274); without it its columns say why.  Each figure is one run of its own
process (os.wait4 gives that process's own peak memory); the machine's load is printed first.
"""
from __future__ import annotations

import argparse
import math
import os
import re
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, List, Optional

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "benchmarks")]

from big_drawing import write, write_svg  # noqa: E402

# The page's check of an upload, as its node runs it (in its own process here, for its peak memory).
PAGE_CHECK = """
import json, sys
from plotter_bridge.gcode.limits import WorkArea
from plotter_web.jobs import check_upload
job = check_upload(sys.argv[1], open(sys.argv[1], "rb").read(), WorkArea(), (0.0, 0.0))
print(len(json.dumps(job.as_json())), job.ok, (job.plan or {}).get("tolerance_mm"), job.errors[:1])
"""


@dataclass
class Run:
    seconds: float
    peak_mb: float
    code: int
    said: str


def measure(cmd: List[str], env: Optional[dict] = None) -> Run:
    """Wall time, the process's own peak resident memory (ru_maxrss, kB on Linux) and the end of
    what it said.  A child's ru_maxrss starts from this process's size when it forks: these come
    before the graph's rclpy makes it big."""
    with tempfile.TemporaryFile() as out:
        t0 = time.monotonic()
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.monotonic() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        # the end of what it said: rs274 says a line for each of a million, and this process's own
        # size is where a child's peak starts
        out.seek(max(0, out.seek(0, os.SEEK_END) - 65536))
        said = out.read().decode(errors="replace")
    return Run(seconds, usage.ru_maxrss / 1024.0, proc.returncode, said)


def rs274_command():
    """(argv prefix, env) of rs274, or the reason it is not here."""
    try:
        from test_gcode_oracle import Unavailable, obtain_rs274
    except ImportError as exc:          # pytest missing: the oracle's module imports it
        return None, f"cannot load tests/test_gcode_oracle.py: {exc}"
    cache = Path(os.environ.get("PLOTTER_RS274_CACHE") or Path.home() / ".cache" / "plotter-rs274")
    try:
        tool = obtain_rs274(cache)
    except Unavailable as exc:
        return None, str(exc)
    return ([str(tool.binary), "-t", str(tool.table), "-g"], tool.env), ""


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    p.add_argument("--no-graph", action="store_true", help="no node graph")
    p.add_argument("--no-pictures", action="store_true", help="no previews")
    args = p.parse_args()
    plotter = shutil.which("plotter") or str(Path(sys.executable).parent / "plotter")
    oracle, why = rs274_command()
    load = os.getloadavg()[0]
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, load average {load:.1f} at the start, "
          f"Python {platform.python_version()}; rs274: {'found' if oracle else why}\n")
    print("| lines | MB | plotter check s | peak MB | rs274 s | peak MB | check / rs274 |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="plotter-big-") as tmp:
        for size in args.sizes:
            path = Path(tmp) / f"walk{size}.ngc"
            with open(path, "w") as f:
                write(size, f)
            check = measure([plotter, "check", str(path)])
            if check.code != 0:
                print(f"plotter check {path.name} exited {check.code}:\n{check.said[-2000:]}", file=sys.stderr)
            row = [f"{size}", f"{path.stat().st_size / 1e6:.1f}", f"{check.seconds:.2f}", f"{check.peak_mb:.0f}"]
            if oracle:
                prefix, env = oracle
                ref = measure([*prefix, str(path)], env=env)
                row += [f"{ref.seconds:.2f}", f"{ref.peak_mb:.0f}", f"{check.seconds / ref.seconds:.1f}"]
            else:
                row += ["-", "-", "-"]
            print("| " + " | ".join(row) + " |", flush=True)
        if not args.no_pictures:
            table(["check --png s", "peak MB", "within mm", "svg MB", "svg --preview s", "peak MB", "within mm",
                   "page check s", "peak MB", "within mm", "page JSON MB"], args.sizes,
                  lambda size: pictures_row(Path(tmp) / f"walk{size}.ngc", plotter))
        if not args.no_graph:
            table(["first step s", "of it after the check s", "peak MB: mock_board", "serial_bridge", "gcode_streamer",
                   "plotter stream", "run_program goal MB", "stream_commands goal MB"], args.sizes,
                  lambda size: graph_row(Path(tmp) / f"walk{size}.ngc", Path(tmp) / f"graph{size}", plotter))
        for path in [*Path(tmp).glob("walk*.ngc"), *Path(tmp).glob("walk*.svg")]:
            path.unlink()
    return 0


def table(columns: List[str], sizes: List[int], row: Callable[[int], List[str]]) -> None:
    """A Markdown table, a row for each size as it is measured."""
    print("\n| lines | " + " | ".join(columns) + " |")
    print("|---" * (len(columns) + 1) + "|")
    for size in sizes:
        print("| " + " | ".join([f"{size}", *row(size)]) + " |", flush=True)


def _within(said: str) -> str:
    found = re.search(r"drawn here to within ([0-9.e+-]+) mm", said)
    return found.group(1) if found else "0 (every point)"


def pictures_row(path: Path, plotter: str) -> List[str]:
    """plotter check --png, plotter svg --preview of the walk as SVG, the page's check of the file."""
    row = []
    png = path.with_suffix(".png")
    check = measure([plotter, "check", str(path), "--png", str(png)])
    if check.code != 0:
        print(f"plotter check --png exited {check.code}:\n{check.said[-2000:]}", file=sys.stderr)
    row += [f"{check.seconds:.1f}", f"{check.peak_mb:.0f}", _within(check.said)]
    svg = path.with_suffix(".svg")
    with open(svg, "w") as f:
        write_svg(sum(1 for _ in open(path)), f)
    preview = measure([plotter, "svg", str(svg), "--preview", str(png)])
    if preview.code != 0:
        print(f"plotter svg --preview exited {preview.code}:\n{preview.said[-2000:]}", file=sys.stderr)
    row += [f"{svg.stat().st_size / 1e6:.1f}", f"{preview.seconds:.1f}", f"{preview.peak_mb:.0f}",
            _within(preview.said)]
    page = measure([sys.executable, "-c", PAGE_CHECK, str(path)])
    said = page.said.split()
    if page.code != 0 or len(said) < 3 or said[1] != "True":
        print(f"the page's check exited {page.code}:\n{page.said[-2000:]}", file=sys.stderr)
        return row + ["-", "-", "-", "-"]
    within = said[2] if said[2] not in ("0.0", "None") else "0 (every point)"
    return row + [f"{page.seconds:.1f}", f"{page.peak_mb:.0f}", within, f"{int(said[0]) / 1e6:.1f}"]


def _peak_mb(pid: int) -> float:
    """The process's own peak resident memory so far (VmHWM), MB."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def message_mb(path: Path) -> List[str]:
    """Serialized sizes of the goals that carry the job: the program, and its board commands."""
    from rclpy.serialization import serialize_message
    from plotter_interfaces.action import RunProgram, StreamCommands
    from plotter_bridge.motion.compiler import StreamerConfig, compile_texts
    text = path.read_text()
    run = len(serialize_message(RunProgram.Goal(program=text, name=path.name)))
    job = compile_texts(text, StreamerConfig())
    goal = StreamCommands.Goal()
    goal.command_text, goal.lines = job.texts.text, job.lines       # as the streamer sends a compiled job
    return [f"{run / 1e6:.1f}", f"{len(serialize_message(goal)) / 1e6:.1f}"]


def graph_row(path: Path, workdir: Path, plotter: str) -> List[str]:
    """`plotter stream FILE` on a running graph: seconds to the pen's first move, each process's
    peak memory by then; canceled with Ctrl-C as a user would."""
    import signal
    from node_processes import PlotterGraph, new_domain, wait_until
    from ros_graph import Probe
    from geometry_msgs.msg import PointStamped
    workdir.mkdir()
    domain = new_domain()
    graph = PlotterGraph(domain, workdir)
    probe = Probe(domain)
    from plotter_bridge.nodes.qos import latched
    from plotter_interfaces.msg import BoardState
    moved, idle = threading.Event(), threading.Event()
    first_move: List[float] = []

    def on_position(m) -> None:
        if not moved.is_set() and abs(m.point.x) + abs(m.point.y) > 0:
            first_move.append(time.time())
            moved.set()
    probe.node.create_subscription(PointStamped, "position", on_position, 10)
    probe.node.create_subscription(BoardState, "state",
                                   lambda m: idle.set() if m.state == BoardState.IDLE else None, latched())
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    try:
        wait_until(idle.is_set, 120, "the board idle")
        from plotter_interfaces.action import RunProgram
        if not probe.action_client(RunProgram, "run_program").wait_for_server(timeout_sec=120):
            raise RuntimeError("gcode_streamer's run_program does not answer")
        t0 = time.monotonic()
        cli = subprocess.Popen([plotter, "stream", str(path)], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)
        while not moved.wait(0.5) and cli.poll() is None and time.monotonic() - t0 < 1800:
            pass
        first = moved.is_set()
        seconds = time.monotonic() - t0
        if not first:
            print(f"{path.name}: no step: {cli.stderr.read() if cli.poll() is not None else 'still waiting'}",
                  file=sys.stderr)
        peaks = [_peak_mb(p.proc.pid) for p in (graph.board, graph.bridge, graph.streamer)] + [_peak_mb(cli.pid)]
        # the streamer's log line "checked and planned" carries the wall time of the check's end
        checked = re.search(r"\[(\d+\.\d+)\] \[[^]]*gcode_streamer\]: [^\n]*checked and planned",
                            graph.streamer.output())
        after_check = first_move[0] - float(checked.group(1)) if first and checked else math.nan
        cli.send_signal(signal.SIGINT)
        cli.wait(120)
    finally:
        probe.close()
        graph.close()
    return [f"{seconds:.1f}" if first else "none in 30 min", f"{after_check:.1f}", *[f"{m:.0f}" for m in peaks],
            *message_mb(path)]


if __name__ == "__main__":
    sys.exit(main())
