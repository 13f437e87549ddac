"""Runs of short straight moves as circular arcs, within a tolerance.

Most tools write curves as chords; the board draws an arc as one command,
so a run of chords that lies on a circle is sent as that arc (the idea of
ArcWelder for 3D printers on slow serial links).  An arc replaces a run only
when every chord of the run is within `tolerance` of it, both ways: each
vertex within the tolerance of the circle, and each chord's bulge (the
circle's distance from the chord) within it too; the run's two ends are the
arc's ends, exactly.  A run turning both ways (an inflection), flatter than
`max_radius` or tighter than `min_radius`, or whose arc would leave the work
area, stays as it was.  Only drawn moves (pen down, not rapid) of one feed
are joined: travel and pen changes end a run.  Pure functions on the parsed
items; nothing here knows the board.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import List, Optional, Sequence, Tuple

from .geometry import arc_extreme_points
from .limits import WorkArea
from .types import PEN_DOWN, Item, Move

Point = Tuple[float, float]
TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class FitConfig:
    tolerance: float = 0.02        # mm: the arc's greatest distance from the chords it replaces
    min_moves: int = 3             # chords a run needs before it is worth an arc
    max_moves: int = 400           # the longest run one arc is tried over
    min_radius: float = 0.1        # mm
    max_radius: float = 2000.0     # mm: flatter than this is a straight line to the board
    area: Optional[WorkArea] = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.tolerance) and self.tolerance > 0):
            raise ValueError(f"arc fitting tolerance must be a positive number of mm, not {self.tolerance!r}")
        if not 2 <= self.min_moves <= self.max_moves:
            raise ValueError(f"arc fitting: min_moves ({self.min_moves}) must be 2..max_moves ({self.max_moves})")
        if not 0 < self.min_radius < self.max_radius:
            raise ValueError(f"arc fitting: 0 < min_radius ({self.min_radius}) < max_radius ({self.max_radius})")


def _circle(a: Point, b: Point, c: Point) -> Optional[Tuple[Point, float]]:
    """The circle through three points: (centre, radius); None when they are (nearly) on a line."""
    ax, ay = a
    bx, by = b[0] - ax, b[1] - ay
    cx, cy = c[0] - ax, c[1] - ay
    d = 2.0 * (bx * cy - by * cx)
    scale = max(math.hypot(bx, by), math.hypot(cx, cy)) ** 2
    if abs(d) <= 1e-12 * max(scale, 1e-12):
        return None
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    ux = (cy * b2 - by * c2) / d
    uy = (bx * c2 - cx * b2) / d
    return (ax + ux, ay + uy), math.hypot(ux, uy)


def _chord_bulge(p: Point, q: Point, centre: Point, r: float) -> float:
    """How far the circle strays from the chord p-q: r less the centre's distance from the chord
    where the perpendicular foot lies on it (else the ends say it all)."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    length2 = dx * dx + dy * dy
    if length2 == 0.0:
        return 0.0
    t = ((centre[0] - p[0]) * dx + (centre[1] - p[1]) * dy) / length2
    if not 0.0 < t < 1.0:
        return 0.0
    foot = (p[0] + t * dx, p[1] + t * dy)
    return abs(r - math.hypot(centre[0] - foot[0], centre[1] - foot[1]))


def _angle(p: Point, centre: Point) -> float:
    return math.atan2(p[1] - centre[1], p[0] - centre[0])


def fit_run(points: Sequence[Point], config: FitConfig) -> Optional[Tuple[Point, bool]]:
    """The arc through a polyline's points, if one holds all of them within the tolerance:
    (centre, clockwise); None if not."""
    n = len(points) - 1
    if n < 2:
        return None
    closed = math.dist(points[0], points[-1]) <= 1e-9
    if closed:
        if n < 3:
            return None
        circle = _circle(points[0], points[n // 3], points[(2 * n) // 3])
    else:
        circle = _circle(points[0], points[n // 2], points[-1])
    if circle is None:
        return None
    centre, r = circle
    if not config.min_radius <= r <= config.max_radius:
        return None
    tol = config.tolerance
    for p in points:
        if abs(math.hypot(p[0] - centre[0], p[1] - centre[1]) - r) > tol:
            return None
    # One way round, never back, less than a turn (or exactly one for a closed run).
    sweep, sign = 0.0, 0.0
    for p, q in zip(points, points[1:]):
        step = (_angle(q, centre) - _angle(p, centre) + math.pi) % TWO_PI - math.pi
        if step == 0.0 or (sign and step * sign < 0):
            return None
        sign = sign or math.copysign(1.0, step)
        sweep += step
        if _chord_bulge(p, q, centre, r) > tol:
            return None
    if closed:
        if abs(abs(sweep) - TWO_PI) > 1e-6:
            return None
    elif abs(sweep) >= TWO_PI - 1e-9:
        return None
    return centre, sign < 0


def _arc_inside(start: Point, end: Point, centre: Point, cw: bool, area: Optional[WorkArea]) -> bool:
    if area is None:
        return True
    if math.dist(start, end) <= 1e-9:
        r = math.dist(start, centre)
        pts = [(centre[0] + r, centre[1]), (centre[0] - r, centre[1]), (centre[0], centre[1] + r),
               (centre[0], centre[1] - r)]
    else:
        pts = arc_extreme_points(start, end, centre, cw)
    return all(area.contains(x, y) for x, y in pts)


def _drawn_line(item: Item) -> bool:
    return isinstance(item, Move) and item.kind == "line" and not item.rapid and item.pen == PEN_DOWN


def _fit_chain(chain: List[Move], config: FitConfig) -> List[Move]:
    """One chain of joined drawn lines of one feed, with every run that fits as an arc."""
    out: List[Move] = []
    i = 0
    while i < len(chain):
        best = None
        j = i + config.min_moves - 1
        while j < len(chain) and j - i < config.max_moves:
            pts = [(chain[i].sx, chain[i].sy)] + [(m.x, m.y) for m in chain[i:j + 1]]
            fit = fit_run(pts, config)
            if fit is None:
                break
            if _arc_inside(pts[0], pts[-1], fit[0], fit[1], config.area):
                best = (j, fit)
            j += 1
        if best is None:
            out.append(chain[i])
            i += 1
            continue
        j, (centre, cw) = best
        first, last = chain[i], chain[j]
        closed = math.dist((first.sx, first.sy), (last.x, last.y)) <= 1e-9
        end = (first.sx, first.sy) if closed else (last.x, last.y)     # a full circle ends where it starts
        out.append(replace(first, kind="arc", x=end[0], y=end[1], cx=centre[0], cy=centre[1], cw=cw))
        i = j + 1
    return out


def fit_arcs(items: Sequence[Item], config: FitConfig = FitConfig()) -> List[Item]:
    """The items with each run of drawn chords that lies on a circle as one arc.  An arc keeps the
    line number of its first chord; everything else passes unchanged and in order."""
    out: List[Item] = []
    chain: List[Move] = []

    def flush() -> None:
        out.extend(_fit_chain(chain, config) if len(chain) >= config.min_moves else chain)
        chain.clear()

    for item in items:
        if _drawn_line(item):
            prev = chain[-1] if chain else None
            joined = prev is None or math.dist((prev.x, prev.y), (item.sx, item.sy)) <= 1e-9
            if prev is not None and (item.feed != prev.feed or not joined):
                flush()
            chain.append(item)
            continue
        flush()
        out.append(item)
    flush()
    return out
