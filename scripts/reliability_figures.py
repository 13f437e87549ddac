#!/usr/bin/env python3
"""Fault-injection figures of the serial link (docs/reliability.md).

Runs 1,000-segment jobs through the bridge's session (BoardSession) and the
firmware's own core on simulated time (tests/reliability_sim.py), with
seeded faults on the wire in both directions, and prints a Markdown table:
faults injected, lines retransmitted, jobs completed, final positions exact
to the step, and every segment executed exactly once (the board's sequence
log against the job).

    .venv/bin/python scripts/reliability_figures.py [--jobs 5] [--segments 1000]
        [--rates drop=0.02,corrupt=0.02,dup=0.002,delay=0.002 ...]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "ros_ws" / "src" / "plotter_bridge")]

from firmware_build import host_library  # noqa: E402
from plotter_bridge.sim.faults import FaultCounts, parse_faults  # noqa: E402
from reliability_sim import fault_run  # noqa: E402

RATES = [
    "",
    "drop=0.001,corrupt=0.001,dup=0.001,delay=0.001",
    "drop=0.01,corrupt=0.01,dup=0.001,delay=0.001",
    "drop=0.02,corrupt=0.02,dup=0.002,delay=0.002",
]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--jobs", type=int, default=5, help="jobs per fault rate (seeds 1..N)")
    p.add_argument("--segments", type=int, default=1000, help="segments per job")
    p.add_argument("--rates", nargs="+", default=RATES, metavar="FAULTS",
                   help="rows of fault rates (faults syntax, '' for none; default: the four of the docs)")
    args = p.parse_args()
    lib = host_library()
    print("| faults per byte, each direction | jobs x segments | bytes on the wire | dropped | corrupted "
          "| duplicated | delayed | lines retransmitted | resend requests | time-outs | damaged replies "
          "| jobs completed | positions exact | every segment once | jobs hit by a damaged line taken as valid |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    t0 = time.monotonic()
    for rates in args.rates:
        total, retx, rs, tmo, bad = FaultCounts(), 0, 0, 0, 0
        completed = exact = once = undetected = 0
        for seed in range(1, args.jobs + 1):
            spec = parse_faults(f"{rates},seed={seed}" if rates else f"seed={seed}")
            fig = fault_run(spec, args.segments, seed=seed, library=lib)
            total = total.add(fig.injected)
            retx += fig.retransmissions
            rs += fig.resend_requests
            tmo += fig.timeouts
            bad += fig.garbled_replies
            completed += fig.completed
            exact += fig.exact
            once += fig.once_in_order
            undetected += "board refused" in fig.message or "passed its checksum" in fig.message
            if not fig.completed:
                print(f"  seed {seed}: {fig.message}", file=sys.stderr)
        n = args.jobs
        print(f"| {rates or 'none'} | {n} x {args.segments} | {total.bytes or '-'} | {total.dropped} "
              f"| {total.corrupted} | {total.duplicated} | {total.delayed} | {retx} | {rs} | {tmo} | {bad} "
              f"| {completed}/{n} | {exact}/{n} | {once}/{n} | {undetected} |")
    print(f"\n({time.monotonic() - t0:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
