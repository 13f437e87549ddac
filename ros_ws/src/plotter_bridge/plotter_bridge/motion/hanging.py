"""The hanging machine's cut: every programmed line and arc becomes straight
board lines between whole motor steps, so that each step the board takes
keeps the pen within the tolerance of the programmed path.

A straight line of motor steps is a curve on paper, and the board draws it
as a staircase.  For a board line from motor position m0 to m1 (whole
steps) that stands for the path from t0 to t1, the pen strays from the path
by at most the sum of

- the chord: how far the motor line's image on paper lies across the path,
  its ends included (rounding them to whole steps moves them off the path).
  Measured, not estimated: across the path's normal, at the same fraction of
  both, at five places, and at the extreme of the parabola through three of
  them (a short chord's bulge plus its ends' rounding is one);
- the staircase: point-by-point comparison (firmware/core/stepper.c) keeps
  every step within one step of either motor of the motor line, on either
  side, so across the path at most max(|n.sL|, |n.sR|) for the pen steps
  sL, sR of the two motors there (kinematics.HangingGeometry.pen_steps) and
  the path's normal n; nothing for a line of one motor alone.

A board line is taken when the sum is within the tolerance (less MARGIN),
and as long as it can be.  Cut points are rounded to the corner of their step that lies
nearest the path across it (not nearest the point), which keeps that
rounding within half a pen step.

Chords can be cut as short as needed; the staircase and the rounding
cannot.  Where a motor step moves the pen by s (HangingGeometry.pen_step),
they take up to 1.5 s across the worst direction, and s grows without bound
towards the pulleys' height, where the strings come into line.  The
accurate area (`holds`) is where they leave CHORD_SHARE of the tolerance or
more to the chords; a drawn move that leaves it is refused, naming the
point (pen-up travel is not).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple, Union

from plotter_bridge.gcode.types import GCodeError
from .commands import MAX_DELTA, BoardCommand, straight
from .kinematics import HangingGeometry, Point

Steps = Tuple[int, int]

# Of the tolerance, what the chords keep at least where the board takes the
# most: more than MARGIN, so that a piece of a few steps holds in any
# direction, however its ends round.
CHORD_SHARE = 0.05
BOARD_SHARE = 1.5          # the staircase's pen step plus half of one for rounding
CHECK_SPACING = 1.0        # mm between the points of a drawn move checked against the accurate area
SAMPLES = (0.0, 0.25, 0.5, 0.75, 1.0)
REFINE = 0.125             # a piece is kept within this fraction of the longest that holds
# Of the tolerance, kept for what the samples and the linearised staircase
# can miss between them.
MARGIN = 0.01
MAX_TURN = math.pi / 2     # an arc piece turns no more: five samples always see it whole
# Pen-up travel only has to stay near its line (inside the work area), and
# near the pulleys one step can be more than the drawing tolerance.
TRAVEL_TOLERANCE = 1.0     # mm


@dataclass(frozen=True)
class LinePath:
    start: Point
    end: Point

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    def point(self, t: float) -> Point:
        return (self.start[0] + (self.end[0] - self.start[0]) * t,
                self.start[1] + (self.end[1] - self.start[1]) * t)

    def normal(self, t: float) -> Point:
        n = self.length
        return (-(self.end[1] - self.start[1]) / n, (self.end[0] - self.start[0]) / n)


@dataclass(frozen=True)
class ArcPath:
    centre: Point
    radius: float
    angle: float       # rad, where it starts, seen from the centre
    sweep: float       # rad, positive counter-clockwise

    @classmethod
    def through(cls, start: Point, end: Point, centre: Point, cw: bool) -> "ArcPath":
        """The arc of G2 (cw) or G3 from start to end about centre; a full
        circle where end is start."""
        a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
        a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
        sweep = ((a0 - a1) if cw else (a1 - a0)) % (2 * math.pi)
        if sweep == 0.0:
            sweep = 2 * math.pi
        return cls(centre, math.dist(start, centre), a0, -sweep if cw else sweep)

    @property
    def length(self) -> float:
        return self.radius * abs(self.sweep)

    def point(self, t: float) -> Point:
        a = self.angle + self.sweep * t
        return (self.centre[0] + self.radius * math.cos(a), self.centre[1] + self.radius * math.sin(a))

    def normal(self, t: float) -> Point:
        a = self.angle + self.sweep * t
        return (math.cos(a), math.sin(a))


PenPath = Union[LinePath, ArcPath]


class Unholdable(ValueError):
    """A drawn path reaches a point where the tolerance cannot be held."""

    def __init__(self, point: Point, message: str) -> None:
        super().__init__(message)
        self.point = point


def board_share(geometry: HangingGeometry, p: Point) -> float:
    """The most the board's steps (staircase and rounding) can add to the
    pen's deviation at p, in the worst direction (mm)."""
    return BOARD_SHARE * geometry.pen_step(p)


def holds(geometry: HangingGeometry, p: Point, tolerance: float) -> bool:
    """Whether p lies in the accurate area for this tolerance."""
    return board_share(geometry, p) <= (1.0 - CHORD_SHARE) * tolerance


def largest_pen_step(tolerance: float) -> float:
    """The largest pen step (mm per motor step) the accurate area allows."""
    return (1.0 - CHORD_SHARE) * tolerance / BOARD_SHARE


def string_angle(geometry: HangingGeometry, p: Point) -> float:
    """The angle between the two strings at the pen, degrees."""
    a = math.atan2(geometry.left[1] - p[1], geometry.left[0] - p[0])
    b = math.atan2(geometry.right[1] - p[1], geometry.right[0] - p[0])
    d = abs(a - b) % (2 * math.pi)
    return math.degrees(min(d, 2 * math.pi - d))


def refusal(geometry: HangingGeometry, p: Point, tolerance: float) -> str:
    """Why the pen cannot be held within the tolerance at p."""
    return (f"the pen cannot be held within {tolerance:g} mm of the path at X{p[0]:.1f} Y{p[1]:.1f}: "
            f"a motor step moves it {geometry.pen_step(p):.4f} mm there (the strings meet at "
            f"{string_angle(geometry, p):.0f} degrees); at {geometry.steps_per_mm:.1f} steps per mm of "
            f"string this machine holds {tolerance:g} mm only where a step moves the pen "
            f"{largest_pen_step(tolerance):.4f} mm or less (a larger tolerance or more steps per mm "
            f"reach further)")


def first_unheld(path: PenPath, geometry: HangingGeometry, tolerance: float) -> Optional[Point]:
    """The first point of path outside the accurate area, or None."""
    n = max(1, math.ceil(path.length / CHECK_SPACING))
    for k in range(n + 1):
        p = path.point(k / n)
        if not holds(geometry, p, tolerance):
            return p
    return None


def _dot(a: Point, b: Point) -> float:
    return a[0] * b[0] + a[1] * b[1]


def _corners(m: Point):
    fx, fy = math.floor(m[0]), math.floor(m[1])
    return ((fx, fy), (fx + 1, fy), (fx, fy + 1), (fx + 1, fy + 1))


def round_across(geometry: HangingGeometry, p: Point, normal: Point) -> Steps:
    """The whole-step motor position nearest the path through p with this
    normal, among the four around p's."""
    m = geometry.inverse(p)
    sl, sr = geometry.pen_steps(p)
    a, b = _dot(normal, sl), _dot(normal, sr)
    return min(_corners(m), key=lambda c: abs(a * (c[0] - m[0]) + b * (c[1] - m[1])))


def round_nearest(geometry: HangingGeometry, p: Point) -> Steps:
    """The whole-step motor position whose pen lies nearest p, among the four
    around p's: where a programmed move ends (and the next starts)."""
    m = geometry.inverse(p)
    sl, sr = geometry.pen_steps(p)

    def distance(c: Steps) -> float:
        dl, dr = c[0] - m[0], c[1] - m[1]
        return math.hypot(sl[0] * dl + sr[0] * dr, sl[1] * dl + sr[1] * dr)
    return min(_corners(m), key=distance)


def staircase(geometry: HangingGeometry, p: Point, normal: Point) -> float:
    """How far across the path the board's staircase strays at p (mm)."""
    sl, sr = geometry.pen_steps(p)
    return max(abs(_dot(normal, sl)), abs(_dot(normal, sr)))


def piece_error(path: PenPath, geometry: HangingGeometry, t0: float, m0: Steps, t1: float, m1: Steps) -> float:
    """Bound of the pen's distance from path while the board draws the motor
    line m0-m1 that stands for the path from t0 to t1 (mm)."""
    across = []
    stair = 0.0
    both = m0[0] != m1[0] and m0[1] != m1[1]
    for f in SAMPLES:
        t = t0 + (t1 - t0) * f
        p, n = path.point(t), path.normal(t)
        q = geometry.forward((m0[0] + (m1[0] - m0[0]) * f, m0[1] + (m1[1] - m0[1]) * f))
        across.append((q[0] - p[0]) * n[0] + (q[1] - p[1]) * n[1])
        if both and 0.0 < f < 1.0:
            stair = max(stair, staircase(geometry, q, n))
    worst = max(abs(d) for d in across)
    d0, dm, d1 = across[0], across[2], across[4]
    c2 = 2 * d0 - 4 * dm + 2 * d1
    c1 = 4 * dm - 3 * d0 - d1
    if c2 != 0.0 and 0.0 < -c1 / (2 * c2) < 1.0:
        f = -c1 / (2 * c2)
        worst = max(worst, abs(d0 + c1 * f + c2 * f * f))
    return worst + stair


def cut(path: PenPath, geometry: HangingGeometry, tolerance: float, start: Steps,
        drawn: bool = True) -> List[Tuple[float, Steps]]:
    """Board lines for path from the motor position start: (t, motor
    position) at the end of each, the last at t = 1.  Each is about as long
    as the tolerance allows (within REFINE) and at most MAX_DELTA steps on
    either motor.  A drawn path that leaves the accurate area raises
    Unholdable; travel (drawn False) is cut the same way, to
    TRAVEL_TOLERANCE at least, and never refused."""
    if not drawn:
        tolerance = max(tolerance, TRAVEL_TOLERANCE)
    else:
        p = first_unheld(path, geometry, tolerance)
        if p is not None:
            raise Unholdable(p, refusal(geometry, p, tolerance))
    budget = (1.0 - MARGIN) * tolerance
    end = round_nearest(geometry, path.point(1.0))
    longest = 1.0 if isinstance(path, LinePath) else min(1.0, MAX_TURN / abs(path.sweep))
    out: List[Tuple[float, Steps]] = []
    t0, m0 = 0.0, start
    dt = longest

    def fits(t1: float) -> Tuple[Steps, bool]:
        m1 = end if t1 >= 1.0 else round_across(geometry, path.point(t1), path.normal(t1))
        if max(abs(m1[0] - m0[0]), abs(m1[1] - m0[1])) > MAX_DELTA:
            return m1, False
        return m1, piece_error(path, geometry, t0, m0, t1, m1) <= budget

    while t0 < 1.0:
        room = min(1.0 - t0, longest)
        dt = min(2 * dt, room)
        good: Optional[Tuple[float, Steps]] = None
        bad: Optional[float] = None
        while True:
            t1 = 1.0 if dt >= 1.0 - t0 else t0 + dt
            m1, ok = fits(t1)
            if ok:
                good = (dt, m1)
                if dt >= room or (bad is not None and bad - dt <= REFINE * dt):
                    break
                dt = min(2 * dt, room) if bad is None else (dt + bad) / 2
                continue
            bad = dt
            if good is not None and bad - good[0] <= REFINE * good[0]:
                break
            if good is None and max(abs(m1[0] - m0[0]), abs(m1[1] - m0[1])) <= 1:
                # A single step that does not hold: only where the area check let it by.
                if drawn:
                    p = path.point(t0)
                    raise Unholdable(p, refusal(geometry, p, tolerance))
                good = (dt, m1)
                break
            dt = dt / 2 if good is None else (good[0] + bad) / 2
        dt, m1 = good
        t0 = 1.0 if dt >= 1.0 - t0 else t0 + dt
        out.append((t0, m1))
        m0 = m1
    return out


def path_of(move) -> Optional[PenPath]:
    """The pen's path of a programmed move (gcode.types.Move); None for a
    line that goes nowhere."""
    start, end = (move.sx, move.sy), (move.x, move.y)
    if move.kind == "arc":
        return ArcPath.through(start, end, (move.cx, move.cy), bool(move.cw))
    return LinePath(start, end) if start != end else None


def hanging_motion(geometry: HangingGeometry, tolerance: float) -> Callable[[object, float], List[BoardCommand]]:
    """A motion converter (commands.to_commands) for the hanging machine:
    each programmed move (gcode.types.Move, mm) becomes board lines between
    whole-step motor positions, each chosen once from the path, so errors
    never add up; GCodeError naming the line and the point for a drawn move
    that leaves the accurate area."""
    here: List[Optional[Steps]] = [None]

    def convert(move, feed: float) -> List[BoardCommand]:
        if here[0] is None:
            here[0] = round_nearest(geometry, (move.sx, move.sy))
        path = path_of(move)
        if path is None:
            return []
        try:
            pieces = cut(path, geometry, tolerance, here[0], drawn=not move.rapid and move.pen == "down")
        except Unholdable as exc:
            raise GCodeError(move.line, str(exc)) from None
        out = []
        t_prev = 0.0
        for t, m in pieces:
            dx, dy = m[0] - here[0][0], m[1] - here[0][1]
            if dx or dy:
                out.append(straight(dx, dy, move.line, feed, path.length * (t - t_prev)))
                t_prev = t
            here[0] = m
        return out

    return convert
