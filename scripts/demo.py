#!/usr/bin/env python3
"""The main job on the mock board: the reference board's figures through the whole node graph.

Starts mock_board, serial_bridge, gcode_streamer and shape_server as separate
processes (as `ros2 run` would), publishes one ShapeGoal per figure on
/plotter/shape (as `ros2 topic pub --once` would), waits for the board to
finish each, prints live positions from /plotter/position, and writes a
picture of what the board drew (docs/demo.svg and docs/demo.png by default).

Then it holds each figure's slice of the board's step trace against the
steps the firmware core takes for that figure's program, compiled as the
streamer compiles it (plotter_bridge.sim.expected), and exits 1 naming every
figure not drawn whole, or refused on /plotter/shape_error or
/plotter/program_error.
"""
from __future__ import annotations

import argparse
import os
import random
import sys
import tempfile
import time
from pathlib import Path
from typing import List, Sequence, Tuple

import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from plotter_bridge.cli.picture import figure_polylines, runs_near_path, write_picture
from plotter_bridge.nodes.spinning import SpinThread
from plotter_interfaces.msg import BoardState, ShapeGoal
from plotter_shapes.geometry import SEED_FIGURES, ShapeError, build_shape

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))   # the node graph as processes
from node_processes import PlotterGraph, read_trace, wait_until  # noqa: E402
from drawing_check import figure_problems, figure_program, graph_configs, settled_rows  # noqa: E402

STEPS_PER_MM = 80.0
ERROR_TOPICS = ("shape_error", "program_error")
Point = Tuple[int, int]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--svg", default="docs/demo.svg", help="picture to write (default docs/demo.svg)")
    ap.add_argument("--png", default="docs/demo.png", help="the same picture as PNG ('' for none)")
    ap.add_argument("--trace", default="", help="keep the step trace here (CSV)")
    args = ap.parse_args()

    work = Path(tempfile.mkdtemp(prefix="plotter-demo-"))
    domain = int(os.environ.get("ROS_DOMAIN_ID", random.randint(1, 100)))
    print(f"starting mock_board, serial_bridge, gcode_streamer, shape_server (ROS domain {domain})", flush=True)
    graph = PlotterGraph(domain, work)
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("demo", namespace="/plotter", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    states = []
    errors: List[Tuple[float, str]] = []     # (when, "/plotter/topic: message")
    last_print = [0.0]

    def on_position(msg: PointStamped) -> None:
        now = time.monotonic()
        if now - last_print[0] >= 0.25:
            last_print[0] = now
            print(f"  /plotter/position  X {msg.point.x * 1000:8.3f}  Y {msg.point.y * 1000:8.3f} mm", flush=True)

    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(PointStamped, "position", on_position, 10)
    node.create_subscription(BoardState, "state", lambda m: states.append((time.monotonic(), m)), latched)

    def on_error(topic: str, msg: String) -> None:
        errors.append((time.monotonic(), f"/plotter/{topic}: {msg.data}"))
        print(f"  /plotter/{topic}  {msg.data}", flush=True)
    for topic in ERROR_TOPICS:
        node.create_subscription(String, topic, lambda m, topic=topic: on_error(topic, m), 10)
    pub = node.create_publisher(ShapeGoal, "shape", 10)
    spin = SpinThread(executor)
    failed = False
    starts: List[float] = []        # when each figure was published
    rows: List[int] = []            # steps in the trace before each figure, and after the last
    try:
        wait_until(lambda: any(m.state == BoardState.IDLE for _, m in states), 60, "the board")
        wait_until(lambda: pub.get_subscription_count() > 0, 30, "shape_server")
        # Programs are published once: the streamer must already be listening.
        wait_until(lambda: node.count_subscribers("program") > 0, 30, "gcode_streamer")
        rows.append(settled_rows(graph.trace))
        for fig in SEED_FIGURES:
            label = fig["shape"] + (" reversed" if fig.get("reverse") else "")
            print(f"drawing {label} at ({fig['x']:g}, {fig['y']:g}) mm", flush=True)
            t0 = time.monotonic()
            starts.append(t0)
            pub.publish(ShapeGoal(**fig))

            def finished() -> bool:
                after = [m for t, m in states if t >= t0]
                run = [k for k, m in enumerate(after) if m.state == BoardState.RUNNING]
                return bool(run) and any(m.state == BoardState.IDLE and m.queue_free == m.queue_size
                                         for m in after[run[0]:])

            def refused() -> bool:
                # A refused figure never runs: its error ends the wait, once
                # whatever did run of it is over.
                last = states[-1][1]
                return (any(t >= t0 for t, _ in errors) and last.state == BoardState.IDLE
                        and last.queue_free == last.queue_size)
            wait_until(lambda: finished() or refused(), 300, f"the {label}")
            if states[-1][1].last_error:
                print(f"  board reports: {states[-1][1].last_error}", flush=True)
                failed = True
            rows.append(settled_rows(graph.trace))
    finally:
        spin.stop()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        codes = graph.close()

    trace = read_trace(graph.trace)
    verdicts = check_figures([(x, y) for _, x, y in trace], rows, starts, errors)
    drawn = [(x / STEPS_PER_MM, y / STEPS_PER_MM) for _, x, y in trace]
    programmed = []
    for fig in SEED_FIGURES:
        programmed += figure_polylines(build_shape(fig["shape"], fig["x"], fig["y"], fig["size"],
                                                   fig.get("clockwise", False), fig.get("reverse", False)))
    runs = runs_near_path(drawn, programmed)
    pictures = [p for p in (args.svg, args.png) if p]
    for path in pictures:
        write_picture(path, runs, programmed, title="seed figures on the mock board")
    if args.trace:
        Path(args.trace).write_bytes(graph.trace.read_bytes())
    print(f"{len(trace)} steps in {trace[-1][0] if trace else 0.0:.1f} s of board time; "
          f"pictures: {' '.join(pictures)}")
    for label, problems, steps in verdicts:
        for line in problems or [f"drawn whole, {steps} steps"]:
            print(f"{label}: {line}", flush=True)
    bad = [label for label, problems, _ in verdicts if problems]
    if bad:
        print(f"problems: not drawn whole: {', '.join(bad)}", file=sys.stderr)
    if failed or any(codes):
        print(f"problems: node exit codes {codes}", file=sys.stderr)
    return 1 if bad or failed or any(codes) else 0


def check_figures(trace: Sequence[Point], rows: Sequence[int], starts: Sequence[float],
                  errors: Sequence[Tuple[float, str]]) -> List[Tuple[str, List[str], int]]:
    """(label, problems, steps drawn) of each figure published: its slice of
    the trace held against its program, and the errors published while it
    was drawn."""
    config, shapes = graph_configs()
    # The last figure's slice runs to the trace's end: a step after it is one too many.
    bounds = list(rows[:len(starts)]) + [len(trace)]
    verdicts = []
    for k, (fig, t0) in enumerate(zip(SEED_FIGURES, starts)):
        label = fig["shape"] + (" reversed" if fig.get("reverse") else "")
        t1 = starts[k + 1] if k + 1 < len(starts) else float("inf")
        start = trace[bounds[k] - 1] if bounds[k] > 0 else (0, 0)     # the board powers on at 0
        drawn = trace[bounds[k]:bounds[k + 1]]
        try:
            problems = figure_problems(figure_program(fig, shapes), drawn, start, config)
        except ShapeError as exc:
            problems = [f"cannot be built: {exc}"]
        problems += [text for t, text in errors if t0 <= t < t1]
        verdicts.append((label, problems, len(drawn)))
    return verdicts


if __name__ == "__main__":
    sys.exit(main())
