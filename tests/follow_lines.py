"""Lines to follow, and how far a followed path strays from them.

Each line is a polyline in mm with where the pen is put on it and the way
it sets out; tests/test_follow.py runs the firmware's follow mode on them;
`python tests/follow_lines.py` prints the figures of firmware/README.md
("Line following"): sensors 3 mm from the pen, 80 steps/mm; with
`--corners` the sweep that finds the sharpest corner followed, with
`--ends` how lines that end are stopped.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import List, Sequence, Tuple

import numpy as np

Point = Tuple[float, float]
CAP_STEPS = 100_000             # a run that has not stopped by then is reported as "cap"


@dataclass(frozen=True)
class Line:
    name: str
    points: Tuple[Point, ...]
    start: Point
    heading_deg: float
    closed: bool = True
    sharp: bool = False          # has corners the pen overshoots

    @property
    def length(self) -> float:
        return sum(math.dist(a, b) for a, b in zip(self.points, self.points[1:]))


def _curve(f, n: int) -> Tuple[Point, ...]:
    return tuple(f(2 * math.pi * k / n) for k in range(n + 1))


def circle(cx: float, cy: float, r: float, ccw: bool = True) -> Line:
    pts = _curve(lambda t: (cx + r * math.cos(t), cy + r * math.sin(t)), 720)
    return Line(f"circle r{r:g} {'ccw' if ccw else 'cw'}", pts, (cx + r, cy), 90.0 if ccw else 270.0)


def square(cx: float, cy: float, side: float, ccw: bool = True) -> Line:
    h = side / 2
    pts = ((cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h), (cx - h, cy - h))
    return Line(f"square {side:g} {'ccw' if ccw else 'cw'}", pts, (cx + h, cy), 90.0 if ccw else 270.0,
                sharp=True)


def rounded_rectangle(cx: float, cy: float, w: float, h: float, r: float) -> Line:
    pts: List[Point] = []
    corners = ((cx + w / 2 - r, cy + h / 2 - r, 0), (cx - w / 2 + r, cy + h / 2 - r, 90),
               (cx - w / 2 + r, cy - h / 2 + r, 180), (cx + w / 2 - r, cy - h / 2 + r, 270))
    for x, y, a0 in corners:
        for k in range(31):
            a = math.radians(a0 + 3 * k)
            pts.append((x + r * math.cos(a), y + r * math.sin(a)))
    pts.append(pts[0])
    return Line(f"rounded rectangle {w:g}x{h:g} r{r:g}", tuple(pts), (cx + w / 2, cy), 90.0)


def polygon(cx: float, cy: float, n: int, side: float, ccw: bool = True) -> Line:
    """A regular n-gon, a side upright on the right, the pen put in its middle: each corner turns 360/n degrees."""
    r = side / (2 * math.sin(math.pi / n))
    pts = tuple((cx + r * math.cos(math.pi * (2 * k - 1) / n), cy + r * math.sin(math.pi * (2 * k - 1) / n))
                for k in range(n + 1))
    return Line(f"{n}-gon side {side:g} ({360 / n:g} degree corners) {'ccw' if ccw else 'cw'}",
                pts if ccw else pts[::-1], (cx + r * math.cos(math.pi / n), cy), 90.0 if ccw else 270.0,
                sharp=True)


def figure_eight(cx: float, cy: float, a: float) -> Line:
    """A lemniscate of Gerono on its side: it crosses itself at the centre."""
    pts = _curve(lambda t: (cx + a * math.cos(t), cy + a / 2 * math.sin(2 * t)), 1440)
    return Line(f"figure eight {2 * a:g}", pts, (cx + a, cy), 90.0)


def lollipop(cx: float, y0: float, stem: float, spread_deg: float, r: float) -> Line:
    """A stem up from (cx, y0) into a loop, both of whose legs leave its top spread_deg apart and meet a
    bulb of radius r: a pen set out up the stem goes round the loop and comes back down the stem, through
    its start the other way.  Open: the stem's foot is an end."""
    top = (cx, y0 + stem)
    half = math.radians(spread_deg / 2)
    centre = (cx, top[1] + r / math.sin(half))
    a0, a1 = 90 - spread_deg / 2 - 90, 90 + spread_deg / 2 + 90      # the legs' tangent points on the bulb
    bulb = tuple((centre[0] + r * math.cos(math.radians(a0 + (a1 - a0) * k / 180)),
                  centre[1] + r * math.sin(math.radians(a0 + (a1 - a0) * k / 180))) for k in range(181))
    pts = ((cx, y0), top) + bulb + (top, (cx, y0))
    return Line(f"lollipop {spread_deg:g} degrees r{r:g}", pts, (cx, y0 + 0.4 * stem), 90.0, closed=False)


def sine_wave(x0: float, y0: float, length: float, amplitude: float, wavelength: float) -> Line:
    n = 600
    pts = tuple((x0 + length * k / n, y0 + amplitude * math.sin(2 * math.pi * length * k / n / wavelength))
                for k in range(n + 1))
    return Line(f"sine wave {length:g} mm", pts, pts[30], 0.0, closed=False)


def straight(x0: float, y0: float, heading_deg: float, length: float) -> Line:
    """A straight line from (x0, y0) the given way, the pen put 3 mm along it: an open line with two ends."""
    a = math.radians(heading_deg)
    n = 200
    pts = tuple((x0 + length * k / n * math.cos(a), y0 + length * k / n * math.sin(a)) for k in range(n + 1))
    return Line(f"straight {heading_deg:g} degrees", pts, pts[10], heading_deg, closed=False)


def with_gap(line: Line, gap_mm: float) -> Tuple[Tuple[Point, ...], ...]:
    """The line as two pieces with a gap of at least gap_mm half way round."""
    pts = line.points
    half = len(pts) // 2
    cut, gone = half, 0.0
    while cut + 1 < len(pts) and gone < gap_mm:
        gone += math.dist(pts[cut], pts[cut + 1])
        cut += 1
    return pts[:half + 1], pts[cut:]


def distances(trace: Sequence[Point], lines: Sequence[Sequence[Point]]) -> np.ndarray:
    """Each trace point's distance from the nearest line centre."""
    segs_a = []
    segs_b = []
    for line in lines:
        p = np.asarray(line, dtype=float)
        segs_a.append(p[:-1])
        segs_b.append(p[1:])
    a = np.concatenate(segs_a)
    ab = np.concatenate(segs_b) - a
    l2 = np.maximum((ab ** 2).sum(1), 1e-12)
    out = np.empty(len(trace))
    for i, (x, y) in enumerate(trace):
        q = np.array((x, y))
        t = np.clip(((q - a) * ab).sum(1) / l2, 0.0, 1.0)
        out[i] = np.sqrt((((a + t[:, None] * ab) - q) ** 2).sum(1)).min()
    return out


def path_length(trace: Sequence[Point], every: int = 20) -> float:
    """The trace's length, sampled every few steps so that the staircase of single-axis steps counts as
    the path it makes, not its Manhattan length."""
    pts = list(trace[::every]) + [trace[-1]]
    return sum(math.dist(a, b) for a, b in zip(pts, pts[1:]))


def main(argv: Sequence[str]) -> int:
    sys.path[:0] = ["ros_ws/src/plotter_bridge"]
    from plotter_bridge.sim.firmware_core import FirmwareCore
    from plotter_bridge.sim.follow import FollowGoal, follow
    from plotter_bridge.sim.sheet import SensorRing, Sheet
    corners, ends = "--corners" in argv, "--ends" in argv
    argv = [a for a in argv if a not in ("--corners", "--ends")]
    core = FirmwareCore(argv[0] if argv else None)
    ring = SensorRing(3.0)
    if ends:
        print("| line | width mm | why it stopped | stop from the end mm |")
        print("|---|---|---|---|")
    else:
        print("| line | width mm | why it stopped | path / line | most off centre mm |")
        print("|---|---|---|---|---|")
    for width in (7.0, 8.0):
        for line in LINE_ENDS if ends else CORNERS if corners else LINES:
            sheet = Sheet([line.points], width)
            goal = FollowGoal(line.heading_deg, gate_mm=width / 2)
            run = follow(core, sheet, ring, line.start, goal, cap_steps=CAP_STEPS)
            trace = run.trace_mm(80.0)
            if ends:
                print(f"| {line.name} | {width:g} | {run.reason} | {math.dist(trace[-1], line.points[-1]):.1f} |",
                      flush=True)
                continue
            dev = distances(trace[::4], [line.points]).max()
            print(f"| {line.name} | {width:g} | {run.reason} | {path_length(trace) / line.length:.2f} | {dev:.2f} |",
                  flush=True)
    return 0


LINES = (
    circle(100, 100, 30), circle(100, 100, 30, ccw=False), circle(60, 140, 12),
    square(100, 100, 60), square(150, 80, 40, ccw=False),
    rounded_rectangle(100, 100, 80, 50, 10),
    figure_eight(100, 100, 40),
)

# Lines that end: the pen reaches the end heading every way, sensors not square to it (a sine wave's end
# slopes), so that the end is met by each sensor first.
LINE_ENDS = (
    *(sine_wave(40, 100, length, 10, 80) for length in (100, 120, 140)),
    *(straight(100, 100, heading, 60) for heading in (0, 55, 100, 125, 200, 270, 325)),
)

# Corners: vertices turning 30 to 120 degrees, and right angles rounded to a radius (the sweep of --corners).
CORNERS = (
    *(polygon(100, 100, n, side, ccw) for n in (12, 10, 9, 8, 6, 5, 4, 3) for side in (20, 40)
      for ccw in (True, False)),
    *(rounded_rectangle(100, 100, 60, 60, r) for r in (2, 4, 6, 8, 10, 12)),
)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
