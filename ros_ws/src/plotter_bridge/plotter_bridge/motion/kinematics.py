"""Machine kinematics: where the motors must be for a pen position.

cartesian: one motor per axis, steps = mm * steps_per_mm.

hanging (seed 003, a "V-plotter"): the pen hangs from two strings wound on
spools; the strings run over pulleys at fixed points above the board.  With
the pen at (x, y) the string lengths are (seed 003, equations (1), (2))

    a^2 = (x - xl)^2 + (yl - y)^2        b^2 = (xr - x)^2 + (yr - y)^2

and each motor turns pulses_per_rev pulses per spool circumference of string.
Motor positions count from the power-on origin, where the pen is at (0, 0).
A straight line in motor space is a curve on paper: motion/hanging.py cuts
every programmed line and arc into board lines that keep the pen within a
tolerance of the path, staircase included.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

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

    def pen_steps(self, p: Point) -> Tuple[Point, Point]:
        """Where one step of the left motor moves the pen at p, and where one
        step of the right motor does (mm, for a step that lengthens its
        string): the columns of the inverse of the Jacobian of `inverse`.
        A step of one motor swings the pen about the other pulley, so it
        moves across the other string, by one step of string divided by the
        sine of the angle between the strings: large where they are nearly
        in line (near the pulleys' height) or nearly parallel (far below)."""
        a, b = self.lengths(p)
        ua = ((p[0] - self.left[0]) / a, (p[1] - self.left[1]) / a)
        ub = ((p[0] - self.right[0]) / b, (p[1] - self.right[1]) / b)
        det = (ua[0] * ub[1] - ua[1] * ub[0]) * self.steps_per_mm
        return (ub[1] / det, -ub[0] / det), (-ua[1] / det, ua[0] / det)

    def pen_step(self, p: Point) -> float:
        """How far one motor step moves the pen at p (mm); the same for both
        motors."""
        a, b = self.lengths(p)
        cross = ((p[0] - self.left[0]) * (p[1] - self.right[1])
                 - (p[1] - self.left[1]) * (p[0] - self.right[0])) / (a * b)
        return 1.0 / (abs(cross) * self.steps_per_mm)


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

    def settings(self) -> Dict[str, str]:
        """The parameters (the nodes' names) that turn this machine's motor
        counts into millimetres, those of its kind only, with exact values."""
        out = {"machine": self.kind}
        if self.kind == "hanging":
            h = self.hanging
            out.update(pulley_left=_exact(h.left), pulley_right=_exact(h.right),
                       spool_circumference=_exact(h.spool_circumference), pulses_per_rev=_exact(h.pulses_per_rev))
        else:
            out["steps_per_mm"] = _exact(self.steps_per_mm)
        out["z_mode"] = self.z_mode
        if self.z_axis:
            out["z_steps_per_mm"] = _exact(self.z_steps_per_mm)
        return out

    def text(self) -> str:
        """settings() as words `name=value`: what a job was planned for."""
        return " ".join(f"{k}={v}" for k, v in self.settings().items())

    def refuses(self, planned: str) -> Optional[str]:
        """Why commands planned for the machine `planned` (another Machine's
        text()) must not run on this one, which would turn their steps into
        other millimetres; None if they may ('' says nothing: not checked)."""
        if not planned:
            return None
        words = planned.split()
        if not all("=" in w for w in words):
            return f"the job's machine {planned[:120]!r} is not name=value words"
        theirs = dict(w.split("=", 1) for w in words)
        mine = self.settings()
        differ = [f"{k} {theirs.get(k, 'unset')} in the job, {mine.get(k, 'unset')} here"
                  for k in sorted(set(theirs) | set(mine)) if theirs.get(k) != mine.get(k)]
        if not differ:
            return None
        return ("the job was planned for another machine: " + "; ".join(differ)
                + " (give gcode_streamer and serial_bridge the same machine parameters)")


def _exact(v) -> str:
    """A number, or a point, in words that compare equal only for equal values."""
    if isinstance(v, tuple):
        return "[" + ",".join(repr(float(c)) for c in v) + "]"
    return repr(float(v))


def check_z(z_mode: str, z_steps_per_mm: float) -> None:
    """ValueError naming the bad value of a Z mode or Z scale."""
    if z_mode not in Z_MODES:
        raise ValueError(f"z_mode must be one of {', '.join(Z_MODES)}, not {z_mode!r}")
    if not (math.isfinite(z_steps_per_mm) and z_steps_per_mm > 0):
        raise ValueError(f"z_steps_per_mm must be a positive number, not {z_steps_per_mm!r}")
