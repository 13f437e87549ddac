"""Machine kinematics: where the motors must be for a pen position.

cartesian: one motor per axis, steps = mm * steps_per_mm.

hanging (seed 003, a "V-plotter"): the pen hangs from two strings wound on
spools; the strings run over pulleys at fixed points above the board.  With
the pen at (x, y) the string lengths are (seed 003, equations (1), (2))

    a^2 = (x - xl)^2 + (yl - y)^2        b^2 = (xr - x)^2 + (yr - y)^2

and each motor turns pulses_per_rev pulses per spool circumference of string.
Motor positions count from the power-on origin, where the pen is at (0, 0).
A straight line in motor space is a curve on paper, so every programmed line
and arc is cut into pieces short enough that the pen stays within a
tolerance of the programmed path while the board interpolates each piece as
a straight line of motor steps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, List, Tuple

Point = Tuple[float, float]


@dataclass(frozen=True)
class HangingGeometry:
    """Seed 003's machine, in mm: pulleys at (-15, 115) and (95, 115) cm from the
    board origin, spools of 7.7 cm circumference, 3200 pulses per revolution."""
    left: Point = (-150.0, 1150.0)
    right: Point = (950.0, 1150.0)
    spool_circumference: float = 77.0
    pulses_per_rev: float = 3200.0

    @property
    def steps_per_mm(self) -> float:
        """Motor steps per mm of string."""
        return self.pulses_per_rev / self.spool_circumference

    def lengths(self, p: Point) -> Point:
        """String lengths (mm) to the left and right pulley."""
        return (math.hypot(p[0] - self.left[0], self.left[1] - p[1]),
                math.hypot(self.right[0] - p[0], self.right[1] - p[1]))

    def inverse(self, p: Point) -> Point:
        """Motor positions (steps, not rounded) with the pen at p (mm)."""
        a0, b0 = self.lengths((0.0, 0.0))
        a, b = self.lengths(p)
        k = self.steps_per_mm
        return ((a - a0) * k, (b - b0) * k)

    def forward(self, m: Point) -> Point:
        """Pen position (mm) for motor positions m (steps): where the two
        string circles meet, below the pulleys."""
        a0, b0 = self.lengths((0.0, 0.0))
        k = self.steps_per_mm
        a, b = a0 + m[0] / k, b0 + m[1] / k
        (x1, y1), (x2, y2) = self.left, self.right
        d = math.hypot(x2 - x1, y2 - y1)
        along = (a * a - b * b + d * d) / (2 * d)
        h = math.sqrt(max(a * a - along * along, 0.0))
        ux, uy = (x2 - x1) / d, (y2 - y1) / d
        # The pen hangs below the line through the pulleys.
        return (x1 + along * ux + h * uy, y1 + along * uy - h * ux)


MACHINES = ("cartesian", "hanging")
Z_MODES = ("pen", "axis")     # what G-code Z drives: the pen up/down, or a third axis (ZAXIS=1)
DEFAULT_Z_STEPS_PER_MM = 400.0   # a leadscrew of 8 mm lead at 3200 steps per turn


@dataclass(frozen=True)
class Machine:
    """Which machine the board drives, for turning its motor counts into the
    pen's position and back."""
    kind: str = "cartesian"
    steps_per_mm: float = 80.0                     # cartesian: steps per mm of each axis
    hanging: HangingGeometry = HangingGeometry()
    z_mode: str = "pen"                            # see Z_MODES
    z_steps_per_mm: float = DEFAULT_Z_STEPS_PER_MM  # z_mode axis: steps per mm of Z

    def __post_init__(self) -> None:
        if self.kind not in MACHINES:
            raise ValueError(f"machine must be one of {', '.join(MACHINES)}, not {self.kind!r}")
        check_z(self.z_mode, self.z_steps_per_mm)

    @property
    def z_axis(self) -> bool:
        return self.z_mode == "axis"

    def pen_mm(self, motor: Point) -> Point:
        if self.kind == "hanging":
            return self.hanging.forward(motor)
        return (motor[0] / self.steps_per_mm, motor[1] / self.steps_per_mm)

    def motor_steps(self, pen: Point) -> Point:
        if self.kind == "hanging":
            return self.hanging.inverse(pen)
        return (pen[0] * self.steps_per_mm, pen[1] * self.steps_per_mm)


def check_z(z_mode: str, z_steps_per_mm: float) -> None:
    """ValueError naming the bad value of a Z mode or Z scale."""
    if z_mode not in Z_MODES:
        raise ValueError(f"z_mode must be one of {', '.join(Z_MODES)}, not {z_mode!r}")
    if not (math.isfinite(z_steps_per_mm) and z_steps_per_mm > 0):
        raise ValueError(f"z_steps_per_mm must be a positive number, not {z_steps_per_mm!r}")


def motor_pieces(path: Callable[[float], Point], geometry: HangingGeometry,
                 tolerance: float) -> List[float]:
    """Parameters 0 = t_0 < t_1 < ... = 1 cutting path (a function of t in [0, 1]
    giving the pen position in mm) into pieces that, drawn as straight motor
    lines, keep the pen within `tolerance` mm of the path.  Half of the
    tolerance goes to the pieces' curvature; the other half is left for the
    board's staircase (one motor step off the motor line, about 0.025 mm of
    string) and for rounding the piece ends to whole steps."""
    budget = tolerance / 2

    def error(t0: float, t1: float) -> float:
        # Point against point at the same fraction: stricter than the distance
        # to the path, and it notices a piece whose ends coincide (a full circle).
        m0, m1 = geometry.inverse(path(t0)), geometry.inverse(path(t1))
        worst = 0.0
        for f in (0.25, 0.5, 0.75):
            q = geometry.forward((m0[0] + (m1[0] - m0[0]) * f, m0[1] + (m1[1] - m0[1]) * f))
            p = path(t0 + (t1 - t0) * f)
            worst = max(worst, math.hypot(q[0] - p[0], q[1] - p[1]))
        return worst

    cuts = [0.0]
    stack = [(0.0, 1.0)]
    # Depth-first from the start so that the cuts come out in order.
    while stack:
        t0, t1 = stack.pop()
        if t1 - t0 > 1e-6 and error(t0, t1) > budget:
            mid = (t0 + t1) / 2
            stack.append((mid, t1))
            stack.append((t0, mid))
        else:
            cuts.append(t1)
    return cuts


def line_path(p0: Point, p1: Point) -> Callable[[float], Point]:
    return lambda t: (p0[0] + (p1[0] - p0[0]) * t, p0[1] + (p1[1] - p0[1]) * t)


def arc_path(p0: Point, p1: Point, centre: Point, cw: bool) -> Callable[[float], Point]:
    r = math.hypot(p0[0] - centre[0], p0[1] - centre[1])
    a0 = math.atan2(p0[1] - centre[1], p0[0] - centre[0])
    a1 = math.atan2(p1[1] - centre[1], p1[0] - centre[0])
    sweep = ((a0 - a1) if cw else (a1 - a0)) % (2 * math.pi)
    if sweep == 0.0:
        sweep = 2 * math.pi
    sign = -1.0 if cw else 1.0
    return lambda t: (centre[0] + r * math.cos(a0 + sign * sweep * t),
                      centre[1] + r * math.sin(a0 + sign * sweep * t))


def hanging_motion(geometry: HangingGeometry, tolerance: float):
    """A motion converter (commands.to_commands) for the hanging machine:
    each programmed move (gcode.types.Move, mm) becomes straight board lines
    between motor positions rounded once, absolutely, so errors never add up."""
    from .commands import MAX_DELTA, straight

    here = {"motor": None}

    def convert(move, feed: float):
        start = (move.sx, move.sy)
        end = (move.x, move.y)
        if move.kind == "arc":
            path = arc_path(start, end, (move.cx, move.cy), bool(move.cw))
        else:
            path = line_path(start, end)
        if here["motor"] is None:
            here["motor"] = tuple(round(v) for v in geometry.inverse(start))
        cuts = motor_pieces(path, geometry, tolerance)
        out = []
        prev_pen = start
        for t in cuts[1:]:
            pen = path(t)
            target = tuple(round(v) for v in geometry.inverse(pen))
            dx, dy = target[0] - here["motor"][0], target[1] - here["motor"][1]
            length = math.hypot(pen[0] - prev_pen[0], pen[1] - prev_pen[1])
            pieces = max(1, math.ceil(max(abs(dx), abs(dy)) / MAX_DELTA))
            for k in range(pieces):
                px = round(dx * (k + 1) / pieces) - round(dx * k / pieces)
                py = round(dy * (k + 1) / pieces) - round(dy * k / pieces)
                if px or py:
                    out.append(straight(px, py, move.line, feed, length / pieces))
            here["motor"] = target
            prev_pen = pen
        return out

    return convert
