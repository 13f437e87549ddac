#!/usr/bin/env python3
"""Board time of curves written as chords, with and without arc fitting
(gcode_streamer's fit_arcs), at the board's 9600 baud and at 115200: how
much of a chord drawing's time the link sets, and what fitting gives back.

Runs the simulated board (benchmarks/simboard.py: the firmware core behind a
UART at the baud rate, driven by the host's BoardLink as serial_bridge drives
it).  The programs: a spiral of 1 mm chords at F6000 and a circle of 0.5 mm
chords at F3000 (benchmarks/programs.py).  A benchmark: it prints a markdown
table and asserts nothing.

    .venv/bin/python benchmarks/arcfit.py
"""
from __future__ import annotations

import argparse
import shlex
import sys
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from plotter_bridge.motion.compiler import StreamerConfig, compile_program  # noqa: E402
from programs import polygon_program, spiral_program  # noqa: E402
from simrun import SimSession  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, default=0.02, help="fit_arcs tolerance, mm (default 0.02)")
    ap.add_argument("--segments", type=int, default=600, help="chords of each program (default 600)")
    args = ap.parse_args()
    programs = [spiral_program(args.segments, 1.0, 6000.0), polygon_program(args.segments, 0.5, 3000.0, radius=40.0)]
    rows = ["| program | baud | fit_arcs mm | board commands | board time s | vs chords at 115200 |",
            "|---|---|---|---|---|---|"]
    for prog in programs:
        reference = None
        for baud in (115200, 9600):
            for fit in (0.0, args.tolerance):
                config = replace(StreamerConfig(), link_baud=baud, fit_arcs=fit)
                commands = compile_program(prog.gcode, config, (0, 0))
                session = SimSession(baud=baud)
                try:
                    result = session.stream(commands)
                finally:
                    session.close()
                if reference is None:
                    reference = result.board_time
                rows.append(f"| {prog.name} | {baud} | {fit:g} | {len(commands)} | {result.board_time:.2f} | "
                            f"{result.board_time / reference:.2f}x |")
    command = " ".join(["python benchmarks/arcfit.py", shlex.join(sys.argv[1:])]).strip()
    print(f"`{command}`")
    print()
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
