"""Figures of the pen plotter as lines and native arcs, and their G-code.

This module is pure Python (no ROS): it models what the pen draws, builds the
figures of the reference board (course report "基于嵌入式系统的运动控制器设计",
chapter 4 and key map figure 3.2) and turns them into G-code for the streamer.

Path model
==========
* ``Line(x0, y0, x1, y1)`` - a straight pen-down move.
* ``Arc(x0, y0, x1, y1, cx, cy, cw)`` - a circular pen-down move from
  (x0, y0) to (x1, y1) around the centre (cx, cy), clockwise when ``cw``.
  Start == end means one full circle (as G2/G3 in centre format).
* ``Stroke`` - segments drawn without lifting the pen; each segment starts
  where the previous one ended (checked on construction).
* ``Figure`` - an ordered tuple of strokes. Between strokes the pen is lifted
  and travels (G0) to the start of the next stroke.

Everything is millimetres in the plotter's work frame (+x right, +y away).
Shapes that contain curves use native arcs (G2/G3), never polylines, so the
firmware's point-by-point comparison arc interpolation draws them.

Anchor and size
===============
``x, y`` is the anchor: the centre for ``circle`` and ``arc``, the start point
for ``line``, and the centre of the figure's bounding box for ``diamond``,
``star``, ``cone`` and ``car``. ``size`` is the radius for ``circle`` and
``arc`` and the overall width (bounding-box width along x) for the other
figures. Sizes must lie in [MIN_SIZE_MM, MAX_SIZE_MM] = [1, 1000] mm.

Defaults (seed-faithful): the board asks for a position and a size on its
keypad, and its figure keys draw a preset figure when nothing is entered.
Here ``size == 0`` means "not given" and becomes DEFAULT_SIZE_MM (40 mm);
``x``/``y`` of ``None`` become the centre of the 200 x 200 mm work area,
(100, 100). ``resolve_placement`` implements the rule the ROS node uses for
messages, where 0 cannot be told from "not given": x == y == 0 puts the
figure at the work-area centre (a figure centred on the work area's corner
could never be drawn).

Figures
=======
diamond (seed 4.2, "four equal lines")
    A rhombus with width ``size`` and height 1.5 * ``size`` (a playing-card
    diamond; a rotated square would only exercise 45-degree lines). Drawn as
    one stroke counter-clockwise from the right vertex: right -> top -> left
    -> bottom -> right, so the four lines fall in quadrants II, III, IV and I
    of the seed's four-quadrant line interpolation (table 2.1).

star (seed 4.3)
    The seed gives the five tips of a regular five-pointed star with "edge"
    a, but its formulas lost the factor a on B, C and E. Here a is the length
    of one edge of the star's outline (tip to neighbouring inner corner) and
    the corrected tips, origin on the line through the two side tips, are::

        A ( a + a*sin18,  0)                       right tip
        B ( a*cos36,      a*cos18 - a*cos36*cot18)  bottom-right tip
        C (-a*cos36,      a*cos18 - a*cos36*cot18)  bottom-left tip
        D (-a - a*sin18,  0)                       left tip
        E ( 0,            a*cos18)                  top tip

    Derivation. Each tip is an isosceles triangle with legs a and apex angle
    36 deg, so its base (a side of the inner pentagon) is 2a*sin18 and its
    height is a*cos18. The line through D and A contains the base of the top
    triangle, hence E = (0, a*cos18). A line of the pentagram is made of a
    leg, an inner side and a leg: 2a + 2a*sin18, which spans D..A, so
    A.x = a + a*sin18. The outer pentagon side EA has length
    sqrt((a + a*sin18)^2 + (a*cos18)^2) = a*phi = 2a*cos36 (phi = golden
    ratio, cos36 = phi/2), and the bottom side CB is horizontal and centred,
    so B.x = a*cos36. The pentagram line E->B makes 18 deg with the vertical
    (half the 36 deg tip angle), so going down from E by B.x horizontally
    costs a*cos36*cot18 vertically: B.y = a*cos18 - a*cos36*cot18
    (= -1.5388a). All five pentagram lines have length 2a(1 + sin18) = a*phi^2
    and the tips lie on a circle, 72 deg apart.

    The figure's width is D..A = 2a(1 + sin18), so a = size / (2(1 + sin18))
    and its height is a*cos36*cot18 = 0.951 * size. It is drawn as one
    continuous stroke, the way one draws a star by hand: E -> C -> A -> D ->
    B -> E (top, bottom-left, right, left, bottom-right, top).

circle (seed 4.4)
    One full-circle arc (G2 when clockwise, else G3) that starts and ends at
    the rightmost point (cx + r, cy).

cone (seed 4.5, "lines and arcs")
    The seed does not give the shape. A cone seen from the side and slightly
    above: an isosceles triangle (base width = ``size``, apex 1.2 * ``size``
    above the base line) standing on an elliptical base. The ellipse (depth
    0.3 * ``size``, i.e. 0.15 * ``size`` above and below the base line) is
    drawn as two circular arcs through the base corners: the front half
    bulges down, the back half bulges up. Overall height 1.35 * ``size``.
    One stroke: left corner -> apex -> right corner (lines), front arc back to
    the left corner, back arc to the right corner; every arc is G2 for
    ``clockwise``. Counter-clockwise is the mirror image (start at the right
    corner, all arcs G3).

car (seed 4.6, "正反向画小车")
    The seed does not give the shape. A side view of a car facing +x, in
    units of the overall length L = ``size``: body outline with a straight
    sill at 0.11 L above the ground line from the rear (x = 0) to the front
    (x = L), the grille up to 0.28 L, a sloping bonnet to the windscreen foot
    at (0.78 L, 0.34 L), a rounded roof - one arc over the cabin, from
    (0.78 L, 0.34 L) to (0.20 L, 0.34 L), 0.58 L high at its top - and the
    tail down to (0, 0.30 L) and back to the start. Two wheels are full circles
    of radius 0.11 L centred on the sill at 0.23 L and 0.77 L, touching the
    ground line. Overall 1 L x 0.58 L. Forward drawing: body (counter-clockwise
    from the rear sill corner), rear wheel, front wheel, every arc G3.
    Reversed drawing (``reverse``): front wheel, rear wheel, body, each
    stroke traced backwards, every arc G2, ending where the forward drawing
    starts. ``clockwise`` does not apply to the car.

line, arc
    ``line`` is one stroke from (x, y) to (x2, y2). ``arc`` is centred at
    (x, y) with radius ``size`` from ``start_angle`` to ``end_angle``
    (degrees, counter-clockwise from +x) in the ``clockwise`` direction;
    equal angles (modulo 360) give a full circle starting at that angle.

For every figure ``reverse`` gives the same drawing in the opposite order
with every stroke traced backwards (arcs flip direction), see ``reverse``.
``clockwise`` is used by circle, arc and cone; diamond, star and car have a
fixed direction (use ``reverse`` to trace them the other way).

G-code
======
``figure_to_gcode`` writes the subset understood by LinuxCNC and by the
plotter's streamer: a ``(name)`` comment, ``G21 G90``, then for every stroke
``M5`` (pen up), ``G0`` to its start, ``M3`` (pen down) and ``G1``/``G2``/
``G3`` moves with ``F``; arcs in centre format with I/J relative to the arc
start. The program ends with ``M5`` and ``M2``. Numbers have 4 decimals; no
expressions or parameters are used.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Iterable, Optional, Union

__all__ = [
    "ShapeError",
    "Line",
    "Arc",
    "Segment",
    "Stroke",
    "Figure",
    "BoundingBox",
    "SHAPE_NAMES",
    "DEFAULT_SIZE_MM",
    "DEFAULT_CENTRE_MM",
    "WORK_AREA_MM",
    "MIN_SIZE_MM",
    "MAX_SIZE_MM",
    "MAX_COORD_MM",
    "MAX_FEED_MM_MIN",
    "STAR_WIDTH_PER_EDGE",
    "star_tips",
    "diamond",
    "star",
    "circle",
    "cone",
    "car",
    "line",
    "arc",
    "reverse",
    "translate",
    "bounding_box",
    "figure_to_gcode",
    "build_shape",
    "resolve_placement",
    "goal_program",
    "DEFAULT_FEED_MM_MIN",
]

#: Work area of the reference board's plotting table (mm, x by y).
WORK_AREA_MM: tuple[float, float] = (200.0, 200.0)
#: Anchor used when no position is given: the centre of the work area.
DEFAULT_CENTRE_MM: tuple[float, float] = (WORK_AREA_MM[0] / 2.0, WORK_AREA_MM[1] / 2.0)
#: Size used when the size is 0 ("not given").
DEFAULT_SIZE_MM: float = 40.0
#: The seed board's figures (seed 000, chapter 4) laid out on the work area,
#: as scripts/demo.py draws them and the benchmark times them: build_shape's arguments.
SEED_FIGURES: tuple[dict, ...] = (
    dict(shape="diamond", x=40.0, y=160.0, size=50.0),
    dict(shape="star", x=100.0, y=160.0, size=50.0),
    dict(shape="circle", x=160.0, y=160.0, size=25.0, clockwise=True),
    dict(shape="cone", x=40.0, y=70.0, size=50.0),
    dict(shape="car", x=100.0, y=70.0, size=50.0),
    dict(shape="car", x=160.0, y=70.0, size=50.0, reverse=True),
)
#: Feed used when a request gives none (mm/min).
DEFAULT_FEED_MM_MIN: float = 1500.0
#: Smallest size accepted: below 1 mm a pen line cannot show a figure.
MIN_SIZE_MM: float = 1.0
#: Largest size accepted (mm).
MAX_SIZE_MM: float = 1000.0
#: Coordinates beyond this are rejected as nonsense (mm); the work-area check
#: itself is done downstream by the G-code checker.
MAX_COORD_MM: float = 10000.0
#: Largest feed accepted (mm/min); the machine's own limit is applied downstream.
MAX_FEED_MM_MIN: float = 100000.0

#: Names accepted by ``build_shape``.
SHAPE_NAMES: tuple[str, ...] = ("diamond", "star", "circle", "cone", "car", "line", "arc")

_SIN18 = math.sin(math.radians(18.0))
_COS18 = math.cos(math.radians(18.0))
_COS36 = math.cos(math.radians(36.0))
_COT18 = 1.0 / math.tan(math.radians(18.0))

#: Width of the star (left tip to right tip) per unit edge length a.
STAR_WIDTH_PER_EDGE: float = 2.0 * (1.0 + _SIN18)

# Proportions of the designed figures (see the module docstring).
_DIAMOND_HEIGHT_RATIO = 1.5
_CONE_HEIGHT_RATIO = 1.2
_CONE_BASE_BULGE_RATIO = 0.15
_CAR_WHEEL_RADIUS = 0.11
_CAR_WHEEL_X = (0.23, 0.77)
_CAR_SILL_Y = 0.11
_CAR_GRILLE_TOP = (1.00, 0.28)
_CAR_SCREEN_FOOT = (0.78, 0.34)
_CAR_REAR_SCREEN_FOOT = (0.20, 0.34)
_CAR_ROOF_TOP_Y = 0.58
_CAR_TAIL_TOP = (0.00, 0.30)

_POINT_ABS_TOL = 1e-9
_POINT_REL_TOL = 1e-12


class ShapeError(ValueError):
    """A shape request that cannot be drawn.

    ``field`` names the offending input (``"shape"``, ``"size"``, ``"x"``...)
    and the message starts with it, e.g. ``"size: must be a finite number,
    got nan"``.
    """

    def __init__(self, message: str, field: Optional[str] = None) -> None:
        super().__init__(message)
        self.field = field


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=_POINT_REL_TOL, abs_tol=_POINT_ABS_TOL)


def _points_close(p: tuple[float, float], q: tuple[float, float]) -> bool:
    return _close(p[0], q[0]) and _close(p[1], q[1])


@dataclass(frozen=True)
class Line:
    """Straight pen-down move from (x0, y0) to (x1, y1)."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def start(self) -> tuple[float, float]:
        return (self.x0, self.y0)

    @property
    def end(self) -> tuple[float, float]:
        return (self.x1, self.y1)

    @property
    def length(self) -> float:
        return math.hypot(self.x1 - self.x0, self.y1 - self.y0)

    def reversed(self) -> "Line":
        """The same line traced from its end to its start."""
        return Line(self.x1, self.y1, self.x0, self.y0)

    def translated(self, dx: float, dy: float) -> "Line":
        return Line(self.x0 + dx, self.y0 + dy, self.x1 + dx, self.y1 + dy)


@dataclass(frozen=True)
class Arc:
    """Circular pen-down move from (x0, y0) to (x1, y1) about (cx, cy).

    ``cw`` selects clockwise (G2) or counter-clockwise (G3). When the start
    equals the end the arc is a full circle. Start and end must be at the same
    distance from the centre (checked on construction).
    """

    x0: float
    y0: float
    x1: float
    y1: float
    cx: float
    cy: float
    cw: bool

    def __post_init__(self) -> None:
        r0 = math.hypot(self.x0 - self.cx, self.y0 - self.cy)
        r1 = math.hypot(self.x1 - self.cx, self.y1 - self.cy)
        if not r0 > 0.0:
            raise ValueError(f"Arc: zero radius (start equals centre {self.cx, self.cy})")
        if not math.isclose(r0, r1, rel_tol=1e-9, abs_tol=1e-9):
            raise ValueError(
                f"Arc: start and end are not equidistant from the centre (r0={r0!r}, r1={r1!r})"
            )

    @property
    def start(self) -> tuple[float, float]:
        return (self.x0, self.y0)

    @property
    def end(self) -> tuple[float, float]:
        return (self.x1, self.y1)

    @property
    def centre(self) -> tuple[float, float]:
        return (self.cx, self.cy)

    @property
    def radius(self) -> float:
        return math.hypot(self.x0 - self.cx, self.y0 - self.cy)

    @property
    def is_full_circle(self) -> bool:
        return self.x0 == self.x1 and self.y0 == self.y1

    @property
    def start_angle(self) -> float:
        """Angle of the start point seen from the centre (radians)."""
        return math.atan2(self.y0 - self.cy, self.x0 - self.cx)

    @property
    def sweep(self) -> float:
        """Signed swept angle in radians: positive counter-clockwise, in (0, 2 pi]."""
        if self.is_full_circle:
            magnitude = 2.0 * math.pi
        else:
            a0 = self.start_angle
            a1 = math.atan2(self.y1 - self.cy, self.x1 - self.cx)
            magnitude = ((a0 - a1) if self.cw else (a1 - a0)) % (2.0 * math.pi)
            if magnitude == 0.0:
                magnitude = 2.0 * math.pi
        return -magnitude if self.cw else magnitude

    @property
    def length(self) -> float:
        return abs(self.sweep) * self.radius

    def contains_angle(self, theta: float) -> bool:
        """True when the direction ``theta`` (radians, from the centre) lies on the arc."""
        sweep = self.sweep
        offset = (theta - self.start_angle) % (2.0 * math.pi)
        if sweep < 0.0:
            offset = (2.0 * math.pi - offset) % (2.0 * math.pi)
        return offset <= abs(sweep)

    def reversed(self) -> "Arc":
        """The same arc traced from its end to its start (direction flips)."""
        return Arc(self.x1, self.y1, self.x0, self.y0, self.cx, self.cy, not self.cw)

    def translated(self, dx: float, dy: float) -> "Arc":
        return Arc(
            self.x0 + dx, self.y0 + dy, self.x1 + dx, self.y1 + dy,
            self.cx + dx, self.cy + dy, self.cw,
        )


Segment = Union[Line, Arc]


@dataclass(frozen=True)
class Stroke:
    """Segments drawn with the pen down, each starting where the previous ended."""

    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        segments = tuple(self.segments)
        object.__setattr__(self, "segments", segments)
        if not segments:
            raise ValueError("Stroke: needs at least one segment")
        for i in range(1, len(segments)):
            if not _points_close(segments[i - 1].end, segments[i].start):
                raise ValueError(
                    f"Stroke: segment {i} starts at {segments[i].start}, "
                    f"previous segment ends at {segments[i - 1].end}"
                )

    @property
    def start(self) -> tuple[float, float]:
        return self.segments[0].start

    @property
    def end(self) -> tuple[float, float]:
        return self.segments[-1].end

    def reversed(self) -> "Stroke":
        """The stroke traced backwards: segments in opposite order, each reversed."""
        return Stroke(tuple(seg.reversed() for seg in reversed(self.segments)))

    def translated(self, dx: float, dy: float) -> "Stroke":
        return Stroke(tuple(seg.translated(dx, dy) for seg in self.segments))


@dataclass(frozen=True)
class Figure:
    """Ordered strokes; the pen is lifted between consecutive strokes."""

    strokes: tuple[Stroke, ...]
    name: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "strokes", tuple(self.strokes))

    @property
    def segments(self) -> tuple[Segment, ...]:
        """All segments in drawing order."""
        return tuple(seg for stroke in self.strokes for seg in stroke.segments)

    @property
    def start(self) -> tuple[float, float]:
        return self.strokes[0].start

    @property
    def end(self) -> tuple[float, float]:
        return self.strokes[-1].end


@dataclass(frozen=True)
class BoundingBox:
    """Axis-aligned extent of the pen-down path (mm)."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    @property
    def width(self) -> float:
        return self.xmax - self.xmin

    @property
    def height(self) -> float:
        return self.ymax - self.ymin

    @property
    def centre(self) -> tuple[float, float]:
        return ((self.xmin + self.xmax) / 2.0, (self.ymin + self.ymax) / 2.0)


def _segment_points(seg: Segment) -> Iterable[tuple[float, float]]:
    """Points whose hull bounds the segment: its ends and, for arcs, the
    extreme points (0, 90, 180, 270 deg) that lie on the arc."""
    yield seg.start
    yield seg.end
    if isinstance(seg, Arc):
        r = seg.radius
        for k, (ux, uy) in enumerate(((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))):
            if seg.contains_angle(k * math.pi / 2.0):
                yield (seg.cx + ux * r, seg.cy + uy * r)


def bounding_box(figure: Figure) -> BoundingBox:
    """Exact bounding box of everything the pen draws (arcs included)."""
    points = [p for seg in figure.segments for p in _segment_points(seg)]
    if not points:
        raise ValueError("bounding_box: the figure has no strokes")
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    return BoundingBox(min(xs), min(ys), max(xs), max(ys))


def translate(figure: Figure, dx: float, dy: float) -> Figure:
    """The figure moved by (dx, dy)."""
    return Figure(tuple(s.translated(dx, dy) for s in figure.strokes), figure.name)


def reverse(figure: Figure) -> Figure:
    """The same drawing done backwards.

    Strokes come in the opposite order and each stroke is traced from its end
    to its start, so every line swaps its ends and every arc swaps its ends
    and flips between clockwise and counter-clockwise. The reversed figure
    ends where the original starts; ``reverse(reverse(f)) == f``.
    """
    return Figure(tuple(s.reversed() for s in reversed(figure.strokes)), figure.name)


_reverse_figure = reverse  # build_shape's ``reverse`` argument shadows the name


def _centred(strokes: Iterable[Stroke], x: float, y: float, name: str) -> Figure:
    """Figure from strokes in local coordinates, moved so that its bounding
    box is centred on (x, y)."""
    local = Figure(tuple(strokes), name)
    cx, cy = bounding_box(local).centre
    return translate(local, x - cx, y - cy)


def _check_number(field: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ShapeError(f"{field}: must be a number, got {value!r}", field)
    value = float(value)
    if not math.isfinite(value):
        raise ShapeError(f"{field}: must be a finite number, got {value!r}", field)
    return value


def _check_coord(field: str, value: float) -> float:
    value = _check_number(field, value)
    if abs(value) > MAX_COORD_MM:
        raise ShapeError(
            f"{field}: {value:g} mm is out of range (|{field}| must be <= {MAX_COORD_MM:g} mm)",
            field,
        )
    return value


def _check_size(value: float, field: str = "size") -> float:
    value = _check_number(field, value)
    if value <= 0.0:
        raise ShapeError(f"{field}: must be positive, got {value:g} mm", field)
    if value < MIN_SIZE_MM:
        raise ShapeError(
            f"{field}: {value:g} mm is too small (minimum {MIN_SIZE_MM:g} mm)", field
        )
    if value > MAX_SIZE_MM:
        raise ShapeError(
            f"{field}: {value:g} mm is too large (maximum {MAX_SIZE_MM:g} mm)", field
        )
    return value


def _cos_sin_deg(deg: float) -> tuple[float, float]:
    """cos and sin of an angle in degrees, exact at multiples of 90 degrees."""
    d = deg % 360.0
    exact = {0.0: (1.0, 0.0), 90.0: (0.0, 1.0), 180.0: (-1.0, 0.0), 270.0: (0.0, -1.0)}
    if d in exact:
        return exact[d]
    rad = math.radians(d)
    return (math.cos(rad), math.sin(rad))


def _arc_through(p: tuple[float, float], q: tuple[float, float], sagitta: float, cw: bool) -> Arc:
    """Minor arc from p to q whose midpoint is ``sagitta`` away from the chord.

    A clockwise arc turns right, so it bulges to the left of the chord p->q;
    a counter-clockwise arc bulges to the right. The centre lies on the
    chord's perpendicular bisector, radius (half_chord^2 + sagitta^2) /
    (2 sagitta) from the arc's midpoint.
    """
    (x0, y0), (x1, y1) = p, q
    chord = math.hypot(x1 - x0, y1 - y0)
    half = chord / 2.0
    radius = (half * half + sagitta * sagitta) / (2.0 * sagitta)
    # Unit normal pointing to the left of p->q.
    nx, ny = -(y1 - y0) / chord, (x1 - x0) / chord
    # The centre is on the side opposite the bulge.
    offset = (sagitta - radius) if cw else (radius - sagitta)
    return Arc(x0, y0, x1, y1, (x0 + x1) / 2.0 + offset * nx, (y0 + y1) / 2.0 + offset * ny, cw)


# Shape builders ------------------------------------------------------------


def star_tips(a: float) -> dict[str, tuple[float, float]]:
    """The five tips A..E of the seed's star (figure 4.3) for edge length ``a``,
    with the seed's formulas corrected (see the module docstring). Origin on
    the line through the side tips A and D, on the star's axis."""
    tip_y = a * _COS18 - a * _COS36 * _COT18
    return {
        "A": (a + a * _SIN18, 0.0),
        "B": (a * _COS36, tip_y),
        "C": (-a * _COS36, tip_y),
        "D": (-a - a * _SIN18, 0.0),
        "E": (0.0, a * _COS18),
    }


def diamond(x: float, y: float, size: float) -> Figure:
    """Rhombus of width ``size`` and height 1.5 * ``size`` centred on (x, y),
    one counter-clockwise stroke from the right vertex."""
    x, y = _check_coord("x", x), _check_coord("y", y)
    size = _check_size(size)
    hw, hh = size / 2.0, size * _DIAMOND_HEIGHT_RATIO / 2.0
    right, top, left, bottom = (x + hw, y), (x, y + hh), (x - hw, y), (x, y - hh)
    corners = (right, top, left, bottom, right)
    lines = tuple(Line(*corners[i], *corners[i + 1]) for i in range(4))
    return Figure((Stroke(lines),), "diamond")


def star(x: float, y: float, size: float) -> Figure:
    """Regular five-pointed star of width ``size`` with its bounding box
    centred on (x, y): the 5 lines of a pentagram, one stroke E-C-A-D-B-E."""
    x, y = _check_coord("x", x), _check_coord("y", y)
    size = _check_size(size)
    tips = star_tips(size / STAR_WIDTH_PER_EDGE)
    order = [tips[k] for k in ("E", "C", "A", "D", "B", "E")]
    lines = tuple(Line(*order[i], *order[i + 1]) for i in range(5))
    return _centred((Stroke(lines),), x, y, "star")


def circle(cx: float, cy: float, r: float, clockwise: bool = False) -> Figure:
    """Full circle of radius ``r`` about (cx, cy) as one G2/G3 arc starting
    and ending at the rightmost point (cx + r, cy)."""
    cx, cy = _check_coord("x", cx), _check_coord("y", cy)
    r = _check_size(r)
    start = (cx + r, cy)
    return Figure((Stroke((Arc(*start, *start, cx, cy, bool(clockwise)),)),), "circle")


def cone(x: float, y: float, size: float, clockwise: bool = True) -> Figure:
    """Cone of base width ``size`` (isosceles triangle on a two-arc elliptical
    base) with its bounding box centred on (x, y); one stroke."""
    x, y = _check_coord("x", x), _check_coord("y", y)
    size = _check_size(size)
    cw = bool(clockwise)
    half = size / 2.0
    height = size * _CONE_HEIGHT_RATIO
    bulge = size * _CONE_BASE_BULGE_RATIO
    side = 1.0 if cw else -1.0
    first, apex, second = (-side * half, 0.0), (0.0, height), (side * half, 0.0)
    # Front half of the base: second -> first below the base line; back half:
    # first -> second above it. Both turn the same way as the outline.
    front = _arc_through(second, first, bulge, cw)
    back = _arc_through(first, second, bulge, cw)
    segments = (Line(*first, *apex), Line(*apex, *second), front, back)
    return _centred((Stroke(segments),), x, y, "cone")


def car(x: float, y: float, size: float) -> Figure:
    """Side view of a small car of overall length ``size`` facing +x, bounding
    box centred on (x, y): body (lines and a roof arc), rear and front wheel."""
    x, y = _check_coord("x", x), _check_coord("y", y)
    size = _check_size(size)

    def p(u: float, v: float) -> tuple[float, float]:
        return (u * size, v * size)

    rear_sill, front_sill = p(0.0, _CAR_SILL_Y), p(1.0, _CAR_SILL_Y)
    grille_top = p(*_CAR_GRILLE_TOP)
    screen_foot = p(*_CAR_SCREEN_FOOT)
    rear_screen_foot = p(*_CAR_REAR_SCREEN_FOOT)
    tail_top = p(*_CAR_TAIL_TOP)
    roof_bulge = (_CAR_ROOF_TOP_Y - _CAR_SCREEN_FOOT[1]) * size
    body = Stroke((
        Line(*rear_sill, *front_sill),
        Line(*front_sill, *grille_top),
        Line(*grille_top, *screen_foot),
        # Roof: counter-clockwise from the windscreen foot over the cabin.
        _arc_through(screen_foot, rear_screen_foot, roof_bulge, False),
        Line(*rear_screen_foot, *tail_top),
        Line(*tail_top, *rear_sill),
    ))
    wheels = []
    for wx in _CAR_WHEEL_X:
        hub = p(wx, _CAR_WHEEL_RADIUS)
        rim = (hub[0] + _CAR_WHEEL_RADIUS * size, hub[1])
        wheels.append(Stroke((Arc(*rim, *rim, *hub, False),)))
    return _centred((body, *wheels), x, y, "car")


def line(x: float, y: float, x2: float, y2: float) -> Figure:
    """Single straight stroke from (x, y) to (x2, y2)."""
    x, y = _check_coord("x", x), _check_coord("y", y)
    x2, y2 = _check_coord("x2", x2), _check_coord("y2", y2)
    if x == x2 and y == y2:
        raise ShapeError("x2: the line end (x2, y2) equals its start (x, y)", "x2")
    return Figure((Stroke((Line(x, y, x2, y2),)),), "line")


def arc(
    cx: float, cy: float, r: float, start_deg: float, end_deg: float, clockwise: bool = False
) -> Figure:
    """Arc of radius ``r`` about (cx, cy) from ``start_deg`` to ``end_deg``
    (degrees counter-clockwise from +x), traced in the ``clockwise``
    direction; equal angles modulo 360 give a full circle."""
    cx, cy = _check_coord("x", cx), _check_coord("y", cy)
    r = _check_size(r)
    start_deg = _check_number("start_angle", start_deg)
    end_deg = _check_number("end_angle", end_deg)
    c0, s0 = _cos_sin_deg(start_deg)
    start = (cx + r * c0, cy + r * s0)
    if (end_deg - start_deg) % 360.0 == 0.0:
        end = start
    else:
        c1, s1 = _cos_sin_deg(end_deg)
        end = (cx + r * c1, cy + r * s1)
    return Figure((Stroke((Arc(*start, *end, cx, cy, bool(clockwise)),)),), "arc")


# Dispatcher ----------------------------------------------------------------


def _normalise_name(name: object) -> str:
    if not isinstance(name, str):
        raise ShapeError(f"shape: must be a string, got {name!r}", "shape")
    return name.strip().lower()


def resolve_placement(
    name: str,
    x: float,
    y: float,
    size: float,
    *,
    default_size: float = DEFAULT_SIZE_MM,
    default_centre: tuple[float, float] = DEFAULT_CENTRE_MM,
) -> tuple[float, float, float]:
    """Apply the defaults for a request whose numbers cannot be "not given"
    (a ROS message): size == 0 becomes ``default_size``, and x == y == 0
    becomes ``default_centre``: a figure centred on the work area's corner
    would never fit the work area, so (0, 0) can only mean "not given"
    (``{shape: star, size: 40.0}`` draws a 40 mm star in the middle). A
    ``line`` keeps its start point. Other values (including NaN) pass
    through for ``build_shape`` to judge."""
    if size == 0.0:
        size = default_size
    if x == 0.0 and y == 0.0 and _normalise_name(name) != "line":
        x, y = default_centre
    return x, y, size


def build_shape(
    name: str,
    x: Optional[float] = None,
    y: Optional[float] = None,
    size: float = 0.0,
    clockwise: bool = False,
    reverse: bool = False,
    feed: float = 0.0,
    x2: float = 0.0,
    y2: float = 0.0,
    start_angle: float = 0.0,
    end_angle: float = 0.0,
) -> Figure:
    """Validate a shape request and build its figure.

    ``name`` is one of SHAPE_NAMES (case and surrounding blanks ignored).
    ``x``/``y`` of None mean the work-area centre (100, 100); ``size`` 0 means
    DEFAULT_SIZE_MM. ``feed`` (mm/min, 0 = the caller's default) is only
    validated here; pass it to ``figure_to_gcode``. ``reverse`` returns the
    figure drawn backwards (``reverse``). Raises ShapeError naming the bad
    field.
    """
    shape = _normalise_name(name)
    if shape not in SHAPE_NAMES:
        raise ShapeError(
            f"shape: unknown shape {name!r}; expected one of {', '.join(SHAPE_NAMES)}",
            "shape",
        )
    ax = DEFAULT_CENTRE_MM[0] if x is None else _check_coord("x", x)
    ay = DEFAULT_CENTRE_MM[1] if y is None else _check_coord("y", y)
    size = _check_number("size", size)
    if size == 0.0:
        size = DEFAULT_SIZE_MM
    size = _check_size(size)
    feed = _check_number("feed", feed)
    if feed < 0.0 or feed > MAX_FEED_MM_MIN:
        raise ShapeError(
            f"feed: {feed:g} mm/min is out of range (0 = default, at most {MAX_FEED_MM_MIN:g})",
            "feed",
        )
    x2 = _check_coord("x2", x2)
    y2 = _check_coord("y2", y2)
    start_angle = _check_number("start_angle", start_angle)
    end_angle = _check_number("end_angle", end_angle)

    if shape == "diamond":
        figure = diamond(ax, ay, size)
    elif shape == "star":
        figure = star(ax, ay, size)
    elif shape == "circle":
        figure = circle(ax, ay, size, clockwise)
    elif shape == "cone":
        figure = cone(ax, ay, size, clockwise)
    elif shape == "car":
        figure = car(ax, ay, size)
    elif shape == "line":
        figure = line(ax, ay, x2, y2)
    else:
        figure = arc(ax, ay, size, start_angle, end_angle, clockwise)
    return _reverse_figure(figure) if reverse else figure


# G-code --------------------------------------------------------------------

_NAME_UNSAFE = re.compile(r"[^A-Za-z0-9 _.:+-]")


def _fmt(value: float) -> str:
    text = f"{value:.4f}"
    return "0.0000" if text == "-0.0000" else text


def _check_gcode_number(value: float) -> float:
    if not math.isfinite(value):
        raise ShapeError(f"figure: coordinate {value!r} is not finite", "figure")
    return value


def figure_to_gcode(figure: Figure, feed_mm_min: float, name: str = "") -> list[str]:
    """G-code lines that draw ``figure`` at ``feed_mm_min``.

    Layout: optional ``(name)`` comment (characters outside letters, digits
    and `` _.:+-`` dropped), ``G21 G90``; per stroke ``M5``, ``G0 X Y``,
    ``M3`` and its ``G1 X Y F`` / ``G2|G3 X Y I J F`` moves (I/J = centre
    minus arc start); then ``M5`` and ``M2``. 4 decimals everywhere.
    """
    feed = _check_number("feed", feed_mm_min)
    if feed <= 0.0 or feed > MAX_FEED_MM_MIN:
        raise ShapeError(
            f"feed: {feed:g} mm/min is out of range (0 < feed <= {MAX_FEED_MM_MIN:g})", "feed"
        )
    f_word = f"F{_fmt(feed)}"
    lines: list[str] = []
    label = _NAME_UNSAFE.sub("", name or "").strip()[:60]
    if label:
        lines.append(f"({label})")
    lines.append("G21 G90")
    for stroke in figure.strokes:
        sx, sy = (_check_gcode_number(v) for v in stroke.start)
        lines.append("M5")
        lines.append(f"G0 X{_fmt(sx)} Y{_fmt(sy)}")
        lines.append("M3")
        for seg in stroke.segments:
            ex, ey = (_check_gcode_number(v) for v in seg.end)
            if isinstance(seg, Line):
                lines.append(f"G1 X{_fmt(ex)} Y{_fmt(ey)} {f_word}")
            else:
                # I/J from the rounded start and centre, so that the centre
                # the interpreter reconstructs is the rounded true centre.
                i = round(seg.cx, 4) - round(seg.x0, 4)
                j = round(seg.cy, 4) - round(seg.y0, 4)
                code = "G2" if seg.cw else "G3"
                lines.append(
                    f"{code} X{_fmt(ex)} Y{_fmt(ey)} I{_fmt(i)} J{_fmt(j)} {f_word}"
                )
    lines.append("M5")
    lines.append("M2")
    return lines


def goal_program(
    shape: str,
    x: float,
    y: float,
    size: float,
    clockwise: bool = False,
    reverse: bool = False,
    feed: float = 0.0,
    x2: float = 0.0,
    y2: float = 0.0,
    start_angle: float = 0.0,
    end_angle: float = 0.0,
    *,
    default_feed: float = DEFAULT_FEED_MM_MIN,
    default_size: float = DEFAULT_SIZE_MM,
    default_centre: tuple[float, float] = DEFAULT_CENTRE_MM,
) -> tuple[str, list[str]]:
    """The G-code program for one shape request given as message fields
    (plotter_interfaces/msg/ShapeGoal): applies ``resolve_placement``,
    validates and builds the figure, and writes it at ``feed`` (0 = the
    ``default_feed``). Returns (program name, G-code lines); the name, e.g.
    ``"car reversed"``, is also the program's leading comment. Raises
    ShapeError naming the bad field.
    """
    x, y, size = resolve_placement(
        shape, x, y, size, default_size=default_size, default_centre=default_centre
    )
    figure = build_shape(
        shape, x, y, size, clockwise, reverse, feed, x2, y2, start_angle, end_angle
    )
    feed = float(feed) if feed > 0.0 else default_feed
    name = _normalise_name(shape) + (" reversed" if reverse else "")
    return name, figure_to_gcode(figure, feed, name)
