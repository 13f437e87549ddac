#!/usr/bin/env python3
"""A mock board (plotter_bridge.sim.mock_board) as a process of its own, for the benchmark.

Like the mock_board node, without ROS: a pty (symlinked at --link) with the
firmware core behind it in real time, and its step trace.  In addition it
keeps a small JSON file up to date (--stats) with what the host cannot see
from outside: the wall-clock time (time.time()) at which the board's clock
started, so that trace times (board seconds) map to wall-clock times, and
the board's underrun counter (status field U), and how often the board was
behind real time (sampled every 10 ms: `samples`, and `late` of them more
than LATE seconds behind; a starved process delays the board's replies and
steps, and the measurement is then of the machine rather than the plotter),
and how often its loop ran 3 ms or more after it meant to (`stalls`: the
steps catch up, but replies went out and lines came in that much late).
Optional `$k=v` settings are applied at power-on, before the pty opens for
the host.
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

from plotter_bridge.sim.mock_board import MockBoard, MockBoardConfig

LATE = 0.005          # seconds behind real time that count as late


def write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--link", required=True)
    ap.add_argument("--trace", required=True)
    ap.add_argument("--stats", required=True)
    ap.add_argument("--baud", type=int, default=115200)
    ap.add_argument("--no-cpu", action="store_true", help="a board that parses and plans in no time")
    ap.add_argument("--setting", action="append", default=[], metavar="K=V")
    args = ap.parse_args()

    # The board stands for hardware of its own: the host nodes' load must not
    # delay it.  A real-time priority (it sleeps most of the time) or, failing
    # that, a higher nice level needs root; without either the board just
    # shares the CPUs, and its stalls say how much that cost.
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
    except (OSError, AttributeError):
        try:
            os.nice(-10)
        except OSError:
            pass
    board = MockBoard(MockBoardConfig(baud=args.baud, trace=args.trace, cpu=not args.no_cpu))
    for s in args.setting:
        board.core.receive(f"${s}\n".encode())
        board.core.poll(4)
        reply = board.core.transmitted()
        if b"ok" not in reply:
            raise SystemExit(f"${s}: {reply!r}")
    # What exists now lives as long as the process: keep the collector's full
    # passes, which would look at all of it, short.
    gc.freeze()
    # The board's thread must not wait long for the interpreter after a sleep.
    sys.setswitchinterval(0.0002)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    stats = Path(args.stats)
    start = time.time()
    board.start()
    link = Path(args.link)
    if link.is_symlink() or link.exists():
        link.unlink()
    link.symlink_to(board.port_path)
    samples = late = 0
    lag_max = 0.0
    last_write = 0.0
    while not stop.wait(0.01):
        now = time.time()
        lag = (now - start) - board.board_time
        samples += 1
        if lag > LATE:
            late += 1
        lag_max = max(lag_max, lag)
        if now - last_write >= 0.05:
            last_write = now
            write_json(stats, {"start": start, "underruns": board.core.underruns, "steps": board.steps,
                               "samples": samples, "late": late, "lag_max": lag_max,
                               "stalls": board.stalls, "stall_max": board.stall_max})
    board.stop()
    write_json(stats, {"start": start, "underruns": board.core.underruns, "steps": board.steps,
                       "samples": samples, "late": late, "lag_max": lag_max,
                       "stalls": board.stalls, "stall_max": board.stall_max, "stopped": True})
    link.unlink(missing_ok=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
