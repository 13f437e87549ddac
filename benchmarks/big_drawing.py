#!/usr/bin/env python3
"""Big pen-plotter drawings as stippling, TSP art and hatching tools write them: a random walk
of 1.5 mm G1 segments inside the work area, the pen lifted and moved every 50 segments.

    python benchmarks/big_drawing.py 100000 > b100k.gcode      # lines of G-code, about 20 bytes each
    python benchmarks/big_drawing.py 100000 --svg > b100k.svg  # the same walk as SVG paths (vpype's kind)

Every line is one word group a G-code sender streams: `G1 X.. Y..`, and per 50 of them
`M5`, `G0 X.. Y..`, `M3`.  Seeded: the same count and seed give the same bytes.
"""
from __future__ import annotations

import argparse
import math
import random
import sys
from typing import Iterator, TextIO

SEGMENT_MM = 1.5
LIFT_EVERY = 50
MARGIN_MM = 10.0


def random_walk(lines: int, seed: int = 1, width: float = 200.0, height: float = 200.0) -> Iterator[str]:
    """`lines` lines of G-code (header included), one at a time: a drawing of any size
    without holding it."""
    rng = random.Random(seed)
    lo_x, hi_x, lo_y, hi_y = MARGIN_MM, width - MARGIN_MM, MARGIN_MM, height - MARGIN_MM
    x, y, heading = width / 2, height / 2, 0.0
    header = ["(random walk: %d lines, seed %d)" % (lines, seed), "G21 G90", "G0 X%.3f Y%.3f" % (x, y), "M3"]
    yield from header[:lines]
    n, moves = len(header), 0
    while n < lines:
        if moves and moves % LIFT_EVERY == 0 and n + 3 <= lines:
            x, y = rng.uniform(lo_x, hi_x), rng.uniform(lo_y, hi_y)
            yield "M5"
            yield "G0 X%.3f Y%.3f" % (x, y)
            yield "M3"
            n += 3
        heading += rng.uniform(-1.2, 1.2)
        nx, ny = x + SEGMENT_MM * math.cos(heading), y + SEGMENT_MM * math.sin(heading)
        if not (lo_x <= nx <= hi_x and lo_y <= ny <= hi_y):
            heading += math.pi                      # turn back from the edge
            nx, ny = x + SEGMENT_MM * math.cos(heading), y + SEGMENT_MM * math.sin(heading)
        x, y = nx, ny
        yield "G1 X%.3f Y%.3f F3000" % (x, y) if moves == 0 else "G1 X%.3f Y%.3f" % (x, y)
        n += 1
        moves += 1


def write(lines: int, out: TextIO, seed: int = 1) -> None:
    for line in random_walk(lines, seed):
        out.write(line + "\n")


def write_svg(lines: int, out: TextIO, seed: int = 1) -> None:
    """The walk of `lines` lines as an SVG drawing in mm: each pen-down run one <path>, as vpype
    writes a plot (a 1M-line walk: 20000 paths of 50 segments, about 17 MB)."""
    out.write('<?xml version="1.0" encoding="UTF-8"?>\n<svg xmlns="http://www.w3.org/2000/svg" '
              'width="200mm" height="200mm" viewBox="0 0 200 200">\n<g fill="none" stroke="black">\n')
    run: list = []

    def flush() -> None:
        if len(run) > 1:
            out.write('<path d="M' + " L".join(run) + '"/>\n')
        run.clear()
    for line in random_walk(lines, seed):
        if line.startswith(("G0 ", "G1 ")):
            words = line.split()
            x, y = float(words[1][1:]), float(words[2][1:])
            if line.startswith("G0 "):
                flush()
            run.append("%.3f,%.3f" % (x, 200.0 - y))
        elif line == "M5":
            flush()
    flush()
    out.write("</g>\n</svg>\n")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("lines", type=int, help="lines of G-code")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--svg", action="store_true", help="write the walk as an SVG drawing instead")
    args = p.parse_args()
    if args.lines < 1:
        p.error(f"lines = {args.lines}: give at least 1")
    (write_svg if args.svg else write)(args.lines, sys.stdout, args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
