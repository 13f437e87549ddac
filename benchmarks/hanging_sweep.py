"""The hanging plotter's accuracy over its work area, measured on the
firmware's own core.

Each case is a G-code circle or line drawn with the pen down, compiled as
gcode_streamer compiles it (motion.compiler, machine hanging, its tolerance)
and run through the firmware's C core on the host (sim.firmware_core,
`core_plan_line` and `core_run_steps`): every step the core takes becomes
the pen's position by the machine's forward kinematics and is measured
against the programmed path.  The cases of a sweep are drawn one after the
other on one core, the pen travelling up between them, as a program would.

No ROS: tests/test_hanging_accuracy.py, benchmarks/bench.py (section 5) and
scripts/hanging_accuracy.py use it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple

import numpy as np

from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from plotter_bridge.motion.kinematics import HangingGeometry
from plotter_bridge.sim.firmware_core import FirmwareCore

Point = Tuple[float, float]
HANGING_AREA = WorkArea(0.0, 800.0, 0.0, 1000.0)   # `plotter --machine hanging`'s default work area
FEED = 6000.0                                        # mm/min
QUEUE_SIZE = 6                                       # firmware/core/config.h: board lines queued at once


def hanging_config(area: WorkArea = HANGING_AREA, tolerance: float = 0.1,
                   geometry: HangingGeometry = HangingGeometry()) -> StreamerConfig:
    return StreamerConfig(machine="hanging", area=area, tolerance=tolerance, hanging=geometry)


@dataclass(frozen=True)
class Case:
    """A circle (centre, radius) or a line (start, end) drawn with the pen down."""
    kind: str                  # "circle" or "line"
    a: Point                   # circle: centre; line: start
    b: Point                   # circle: (radius, start angle in degrees); line: end
    cw: bool = False           # circle: G2
    group: str = ""            # which family of the sweep it belongs to

    @property
    def start(self) -> Point:
        if self.kind == "line":
            return self.a
        # Starts on a quarter so that the G-code's numbers are exact and a
        # circle that touches an edge of the area stays inside it.
        r, quarter = self.b[0], round(self.b[1] / 90.0) % 4
        return (self.a[0] + r * (1, 0, -1, 0)[quarter], self.a[1] + r * (0, 1, 0, -1)[quarter])

    @property
    def end(self) -> Point:
        return self.b if self.kind == "line" else self.start

    @property
    def length(self) -> float:
        return math.dist(self.a, self.b) if self.kind == "line" else 2 * math.pi * self.b[0]

    @property
    def name(self) -> str:
        if self.kind == "line":
            return f"line X{self.a[0]:g} Y{self.a[1]:g} -> X{self.b[0]:g} Y{self.b[1]:g}"
        return (f"{'G2' if self.cw else 'G3'} circle r{self.b[0]:g} at X{self.a[0]:g} Y{self.a[1]:g} "
                f"from {self.b[1]:g} deg")

    def gcode(self) -> str:
        sx, sy = self.start
        out = [f"G0 X{sx:.4f} Y{sy:.4f}", "M3"]
        if self.kind == "line":
            out.append(f"G1 X{self.b[0]:.4f} Y{self.b[1]:.4f} F{FEED:g}")
        else:
            out.append(f"{'G2' if self.cw else 'G3'} X{sx:.4f} Y{sy:.4f} I{self.a[0] - sx:.4f} "
                       f"J{self.a[1] - sy:.4f} F{FEED:g}")
        out.append("M5")
        return "\n".join(out) + "\n"

    def distances(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The pen's distance from the programmed path at each (x, y), mm."""
        if self.kind == "circle":
            return np.abs(np.hypot(x - self.a[0], y - self.a[1]) - self.b[0])
        (x0, y0), (x1, y1) = self.a, self.b
        dx, dy = x1 - x0, y1 - y0
        t = np.clip(((x - x0) * dx + (y - y0) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
        return np.hypot(x - x0 - t * dx, y - y0 - t * dy)


@dataclass
class Drawn:
    case: Case
    commands: int              # board lines drawn with the pen down
    steps: int                 # steps taken with the pen down
    worst: float               # the largest distance of a drawn step from the path, mm
    where: Point               # the pen there


def pen_positions(geometry: HangingGeometry, mx: np.ndarray, my: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """HangingGeometry.forward for arrays of motor positions (steps)."""
    a0, b0 = geometry.lengths((0.0, 0.0))
    k = geometry.steps_per_mm
    a, b = a0 + mx / k, b0 + my / k
    (x1, y1), (x2, y2) = geometry.left, geometry.right
    d = math.hypot(x2 - x1, y2 - y1)
    along = (a * a - b * b + d * d) / (2 * d)
    h = np.sqrt(np.maximum(a * a - along * along, 0.0))
    ux, uy = (x2 - x1) / d, (y2 - y1) / d
    return x1 + along * ux + h * uy, y1 + along * uy - h * ux


StepsSeen = Callable[[Case, np.ndarray, np.ndarray, np.ndarray], None]


def _run(core: FirmwareCore, lines: Sequence[Tuple[int, int, int, int]], start: Tuple[int, int],
         geometry: HangingGeometry, case: Optional[Case],
         seen: Optional[StepsSeen] = None) -> Tuple[Tuple[int, int], int, float, Point]:
    """Run board lines (dx, dy, rate, exit) on the core from motor position
    start; with a case, measure every step against it (and hand the pen's
    positions and distances to seen)."""
    x, y = start
    steps, worst, where = 0, 0.0, geometry.forward(start)
    for k in range(0, len(lines), QUEUE_SIZE):
        batch = lines[k:k + QUEUE_SIZE]
        for dx, dy, rate, exit_rate in batch:
            if core.plan_line(dx, dy, rate, exit_rate) != 0:
                raise RuntimeError(f"the core refused L {dx} {dy} {rate} {exit_rate}")
        taken = np.frombuffer(core.run_steps_packed(sum(abs(dx) + abs(dy) for dx, dy, _, _ in batch)),
                              dtype=np.int32).reshape(-1, 3)
        mx = x + np.cumsum(taken[:, 0], dtype=np.int64)
        my = y + np.cumsum(taken[:, 1], dtype=np.int64)
        if len(taken):
            x, y = int(mx[-1]), int(my[-1])
        if case is not None and len(taken):
            steps += len(taken)
            px, py = pen_positions(geometry, mx.astype(float), my.astype(float))
            dist = case.distances(px, py)
            if seen is not None:
                seen(case, px, py, dist)
            i = int(np.argmax(dist))
            if dist[i] > worst:
                worst, where = float(dist[i]), (float(px[i]), float(py[i]))
    return (x, y), steps, worst, where


def draw_cases(cases: Iterable[Case], config: StreamerConfig, core: Optional[FirmwareCore] = None,
               seen: Optional[StepsSeen] = None) -> List[Drawn]:
    """Draw each case in turn on the core, from where the previous one
    ended; GCodeError if the compiler refuses one.  seen, if given, gets
    every pen-down step: the case, pen x, y and distance from the path."""
    own = core is None
    core = core or FirmwareCore()
    geometry = config.hanging
    here = core.position
    out = []
    try:
        for case in cases:
            commands = compile_program(case.gcode(), config, start_steps=here)
            pen, runs = False, [[]]
            for c in commands:
                if c.verb == "P":
                    pen = bool(c.args[0])
                    runs.append([])
                elif c.verb == "L":
                    runs[-1].append((pen, (c.args[0], c.args[1], c.rate, c.exit_rate)))
                else:
                    raise RuntimeError(f"unexpected board command {c.text}")
            drawn = Drawn(case, 0, 0, 0.0, case.start)
            for run in runs:
                if not run:
                    continue
                down = run[0][0]
                here, steps, worst, where = _run(core, [line for _, line in run], here, geometry,
                                                 case if down else None, seen)
                if down:
                    drawn.commands += len(run)
                    drawn.steps += steps
                    if worst >= drawn.worst:
                        drawn.worst, drawn.where = worst, where
            if here != core.position:
                raise RuntimeError(f"the core is at {core.position}, the host thinks {here}")
            out.append(drawn)
    finally:
        if own:
            core.close()
    return out


def sweep_cases(area: WorkArea = HANGING_AREA) -> List[Case]:
    """Circles and lines over a grid of places covering the area, corners
    and edges included, in several sizes and directions, in an order that
    keeps the travel between them short."""
    x0, x1, y0, y1 = area.x_min, area.x_max, area.y_min, area.y_max
    w, h = x1 - x0, y1 - y0
    cases: List[Case] = []
    # Small circles (4 cm and 4 mm across) on a 7 x 7 grid whose outer ones
    # touch the edges and corners.
    grid = [k / 6 for k in range(7)]
    for r in (20.0, 2.0):
        for j, fy in enumerate(grid):
            row = []
            for i, fx in enumerate(grid):
                c = (x0 + r + fx * (w - 2 * r), y0 + r + fy * (h - 2 * r))
                row.append(Case("circle", c, (r, 90.0 * ((i + j) % 4)), cw=(i + j) % 2 == 1,
                                group=f"circles {2 * r:g} mm across, 7 x 7 places"))
            cases += row if j % 2 == 0 else row[::-1]
    # Medium circles (20 cm across) at the corners and the middles of the edges.
    r = 100.0
    for k, (fx, fy) in enumerate(((0, 0), (0.5, 0), (1, 0), (1, 0.5), (1, 1), (0.5, 1), (0, 1), (0, 0.5),
                                  (0.5, 0.5))):
        c = (x0 + r + fx * (w - 2 * r), y0 + r + fy * (h - 2 * r))
        cases.append(Case("circle", c, (r, 90.0 * (k % 4)), cw=k % 2 == 0,
                          group="circles 200 mm across, corners, edges, middle"))
    # The 50 cm circle of seed 003's test, on a 3 x 3 grid that reaches every edge.
    r = 250.0
    for j, fy in enumerate((0.0, 0.5, 1.0)):
        row = []
        for i, fx in enumerate((0.0, 0.5, 1.0)):
            c = (x0 + r + fx * (w - 2 * r), y0 + r + fy * (h - 2 * r))
            row.append(Case("circle", c, (r, 90.0 * ((i + 3 * j) % 4)), cw=(i + j) % 2 == 0,
                            group="circles 500 mm across (seed 003), 3 x 3 places"))
        cases += row if j % 2 == 0 else row[::-1]
    # The four edges, both ways round, and the two diagonals.
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    edges = "edges both ways, diagonals"
    for k in range(4):
        cases.append(Case("line", corners[k], corners[(k + 1) % 4], group=edges))
    cases.append(Case("line", (x0, y0), (x1, y1), group=edges))
    cases.append(Case("line", (x1, y0), (x0, y1), group=edges))
    for k in range(4):
        cases.append(Case("line", corners[(4 - k) % 4], corners[3 - k], group=edges))
    # Strokes of 8 cm in eight directions from a 6 x 6 grid of places, turned
    # a little from place to place, cut short at the edges.
    stroke = 80.0
    grid = [k / 5 for k in range(6)]
    for j, fy in enumerate(grid):
        places = [(x0 + fx * w, y0 + fy * h) for fx in grid]
        for i, (px, py) in enumerate(places if j % 2 == 0 else places[::-1]):
            for deg in range(0, 360, 45):
                a = math.radians(deg + 7.5 * ((i + 2 * j) % 6))
                q = (px + stroke * math.cos(a), py + stroke * math.sin(a))
                q = (min(x1, max(x0, q[0])), min(y1, max(y0, q[1])))
                if math.dist(q, (px, py)) > 1.0:
                    cases.append(Case("line", (px, py), q, group="strokes up to 80 mm, 8 directions, 6 x 6 places"))
    return cases


def summary(drawn: Sequence[Drawn]) -> Tuple[float, Drawn, float]:
    """The worst deviation, its case, and board lines per metre drawn."""
    worst = max(drawn, key=lambda d: d.worst)
    metres = sum(d.case.length for d in drawn) / 1000.0
    return worst.worst, worst, sum(d.commands for d in drawn) / metres


def by_group(drawn: Sequence[Drawn]) -> Dict[str, List[Drawn]]:
    out: Dict[str, List[Drawn]] = {}
    for d in drawn:
        out.setdefault(d.case.group, []).append(d)
    return out
