#!/usr/bin/env python3
"""Dense drawings on the board's 9600-baud link, with and without arc fitting
(gcode_streamer's fit_arcs): commands and bytes on the wire, board time at
9600 baud against the same drawing at 115200 and against the time-optimal
bound (benchmarks/bound.py) of the path the board was sent, at the board's
own limits (no link).

The drawings are chords as the tools write them:
- Hershey text written by vpype and vpype-gcode (the plotter_grbl profile of
  tests/data/corpus/vpype-gcode.toml);
- a logo with many Bézier curves, matplotlib's own (mpl-data/images/
  matplotlib.svg, installed with vpype's dependencies), read by vpype at its
  default 0.1 mm quantization and written by vpype-gcode, and the same logo
  as `plotter svg` writes it (curves as arcs already);
- two generative drawings of 1 mm chords at F6000 (benchmarks/programs.py):
  a spirograph and a 3:4 Lissajous figure.

Runs the simulated board (simboard.py: the firmware core behind a UART at the
baud rate, driven by the host's BoardLink as serial_bridge drives it).  A
benchmark: it prints a markdown table and asserts nothing.

    .venv/bin/python benchmarks/arcfit.py
"""
from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import List

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from plotter_bridge.motion.compiler import StreamerConfig, compile_program  # noqa: E402
from plotter_bridge.motion.planner import BOARD_CPU  # noqa: E402
from bench import bound_limits  # noqa: E402
from bound import program_time  # noqa: E402
from programs import Program, bound_items, lissajous_program, spirograph_program  # noqa: E402
from simrun import SimSession  # noqa: E402

PROFILES = ROOT / "tests" / "data" / "corpus" / "vpype-gcode.toml"
TEXT = "The quick brown fox jumps over the lazy dog. Pack my box with five dozen liquor jugs!"


@dataclass(frozen=True)
class Drawing:
    program: Program
    dialect: str


def vpype_gcode(name: str, pipeline: List[str]) -> Drawing:
    """A drawing as vpype and vpype-gcode write it, on a 200 mm square page (the work area)."""
    vpype = Path(sys.executable).parent / "vpype"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.gcode"
        subprocess.run([str(vpype), "--config", str(PROFILES), *pipeline, "layout", "200x200mm",
                        "gwrite", "-p", "plotter_grbl", str(out)], check=True, capture_output=True, timeout=300)
        return Drawing(Program(name, out.read_text()), "grbl")


def plotter_svg(name: str, path: Path, width: float) -> Drawing:
    """A drawing as `plotter svg --width W --feed 6000` writes it (its own arcs, fitted within 0.01 mm)."""
    from plotter_shapes.svg_input import Placement, svg_program
    return Drawing(Program(name, "\n".join(svg_program(str(path), Placement(width, (100.0, 100.0)), 6000.0)) + "\n"),
                   "linuxcnc")


def drawings() -> List[Drawing]:
    import matplotlib
    logo = Path(matplotlib.get_data_path()) / "images" / "matplotlib.svg"
    return [vpype_gcode("Hershey text (vpype futural 7 mm)", ["text", "-f", "futural", "-s", "7mm", "-w", "180mm",
                                                              TEXT]),
            vpype_gcode("matplotlib logo, 160 mm (vpype)", ["read", str(logo), "scaleto", "160mm", "160mm"]),
            plotter_svg("matplotlib logo, 160 mm (plotter svg)", logo, 160.0),
            Drawing(spirograph_program(), "linuxcnc"),
            Drawing(lissajous_program(), "linuxcnc")]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tolerance", type=float, default=StreamerConfig().arc_tolerance,
                    help="arc_tolerance, mm (default: the streamer's)")
    ap.add_argument("--chip", action="store_true",
                    help="charge the 8051's main loop for each command (BoardCpu, `make -C firmware plancost`) "
                         "on the simulated board, and let the streamer plan for it; default: a board that "
                         "parses and plans in no time, a streamer that does not plan for it")
    args = ap.parse_args()
    cpu = BOARD_CPU if args.chip else None
    rows = ["| drawing | G1 in the file | fit | board commands | command bytes (per command) | board s at 115200 | "
            "board s at 9600 | 9600 vs chords at 115200 | bound s | underruns 115200 / 9600 |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for d in drawings():
        chords_115200 = None
        g1 = sum(1 for line in d.program.gcode.splitlines() if line.startswith("G1 "))
        for fit in (False, True):
            times = {}
            for baud in (115200, 9600):
                config = replace(StreamerConfig(), link_baud=baud, fit_arcs=fit, arc_tolerance=args.tolerance,
                                 dialect=d.dialect, board_cpu=args.chip)
                commands = compile_program(d.program.gcode, config, (0, 0))
                session = (SimSession(baud=baud, line_cycles=round(cpu.command_cycles), step_cycles=cpu.step_cycles)
                           if cpu else SimSession(baud=baud))
                try:
                    result = session.stream(commands)
                finally:
                    session.close()
                times[baud] = result
            if chords_115200 is None:
                chords_115200 = times[115200].board_time
            free = compile_program(d.program.gcode, replace(config, link_baud=0), (0, 0))    # no link cap
            bound = program_time(bound_items(free), bound_limits())
            slow = times[9600]
            wire = sum(slow.wire_bytes)
            rows.append(f"| {d.program.name} | {g1} | {'on' if fit else 'off'} | {slow.commands} | "
                        f"{wire} ({wire / slow.commands:.1f}) | {times[115200].board_time:.2f} | "
                        f"{slow.board_time:.2f} | {slow.board_time / chords_115200:.2f}x | {bound:.2f} | "
                        f"{times[115200].underruns} / {slow.underruns} |")
    command = " ".join(["python benchmarks/arcfit.py", shlex.join(sys.argv[1:])]).strip()
    print(f"`{command}`")
    print()
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
