"""Runs of short straight moves as circular arcs, within a tolerance.

Most tools write curves as chords; the board draws an arc as one command,
so a run of chords that lies on a circle is sent as that arc (the idea of
ArcWelder for 3D printers on slow serial links).  An arc replaces a run only
when every chord of the run is within `tolerance` of it, both ways: each
vertex within the tolerance of the circle, and each chord's bulge (the
circle's distance from the chord) within it too; the run's two ends are the
arc's ends, exactly.  A run turning both ways (an inflection), flatter than
`max_radius` or tighter than `min_radius`, whose arc would leave the work
area, or that `arc_pays` (the caller's judgement: a machine may draw arcs
slower than lines) turns down, stays as it was.  A run that one straight line holds within the
tolerance, passing its points in order, becomes that line; from each point
the longer of the two is taken.  Only drawn moves (pen down, not rapid) of
one feed are joined: travel and pen changes end a run.  Pure functions on
the parsed items; nothing here knows the board.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from .geometry import arc_extreme_points
from .limits import WorkArea
from .types import PEN_DOWN, Item, Move

Point = Tuple[float, float]
TWO_PI = 2.0 * math.pi
LOOK_PAST = 2        # runs that do not fit, in a row, before a longer one is no longer tried


@dataclass(frozen=True)
class FitConfig:
    tolerance: float = 0.02        # mm: the arc's greatest distance from the chords it replaces
    min_moves: int = 3             # chords a run needs before it is worth an arc
    max_moves: int = 400           # the longest run one arc is tried over
    min_radius: float = 0.1        # mm
    max_radius: float = 2000.0     # mm: flatter than this is a straight line to the board
    area: Optional[WorkArea] = None
    arc_pays: Optional[Callable[[Sequence[Move], Move], bool]] = None   # (chords, their arc): take the arc?

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
    (cx, cy), r = circle
    if not config.min_radius <= r <= config.max_radius:
        return None
    tol = config.tolerance
    p = np.asarray(points, dtype=float)
    dx, dy = p[:, 0] - cx, p[:, 1] - cy
    if np.any(np.abs(np.hypot(dx, dy) - r) > tol):
        return None
    # One way round, never back, less than a turn (or exactly one for a closed run).
    angles = np.arctan2(dy, dx)
    steps = (np.diff(angles) + math.pi) % TWO_PI - math.pi
    if np.any(steps == 0.0) or not (np.all(steps > 0) or np.all(steps < 0)):
        return None
    sweep = float(np.sum(steps))
    # How far the circle strays from each chord: r less the centre's distance from the chord, where
    # the perpendicular foot lies on it (else the ends, checked above, say it all).
    ux, uy = np.diff(p[:, 0]), np.diff(p[:, 1])
    length2 = ux * ux + uy * uy
    t = (-dx[:-1] * ux - dy[:-1] * uy) / np.where(length2 > 0, length2, 1.0)
    inner = (t > 0.0) & (t < 1.0)
    fx, fy = dx[:-1] + t * ux, dy[:-1] + t * uy
    if np.any(inner & (np.abs(r - np.hypot(fx, fy)) > tol)):
        return None
    if closed:
        if abs(abs(sweep) - TWO_PI) > 1e-6:
            return None
    elif abs(sweep) >= TWO_PI - 1e-9:
        return None
    return (cx, cy), sweep < 0


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


def _longest_fit(points: Sequence[Point], i: int, config: FitConfig) -> Optional[Tuple[int, Point, bool]]:
    """The longest run of points from i that one arc holds, (last index, centre, clockwise), or
    None.  The run grows a point at a time; a run that does not fit ends the search only when the
    next few do not either, since the circle through the run's ends and middle moves as it grows."""
    last = min(len(points) - 1, i + config.max_moves)
    best, misses = None, 0
    for j in range(i + config.min_moves, last + 1):
        fit = fit_run(points[i:j + 1], config)
        if fit is not None and _arc_inside(points[i], points[j], fit[0], fit[1], config.area):
            best, misses = (j, *fit), 0
        else:
            misses += 1
            if best is None or misses > LOOK_PAST:
                break
    return best


def line_run(points: Sequence[Point], tolerance: float) -> bool:
    """Whether one straight line from the first point to the last holds all the points within the
    tolerance, passing them in order (never back)."""
    p = np.asarray(points, dtype=float)
    ux, uy = p[-1, 0] - p[0, 0], p[-1, 1] - p[0, 1]
    length = math.hypot(ux, uy)
    if length <= tolerance:
        return False
    dx, dy = p[:, 0] - p[0, 0], p[:, 1] - p[0, 1]
    along = (dx * ux + dy * uy) / length
    across = (dy * ux - dx * uy) / length
    return bool(np.all(np.abs(across) <= tolerance) and np.all(np.diff(along) > 0.0))


def _longest_line(points: Sequence[Point], i: int, config: FitConfig) -> int:
    """The last index of the longest run of points from i that one line holds (i + 1 at least)."""
    last = min(len(points) - 1, i + config.max_moves)
    best = i + 1
    for j in range(i + 2, last + 1):
        if not line_run(points[i:j + 1], config.tolerance):
            break
        best = j
    return best


Piece = Tuple[int, int, Optional[Point], Optional[bool]]   # first, last point index; centre and cw of an arc


def fit_polyline(points: Sequence[Point], config: FitConfig = FitConfig(), final: bool = True) -> List[Piece]:
    """A polyline as pieces: arcs (first, last, centre, cw) over each run of its points that one arc
    holds within the tolerance, lines (first, last, None, None) over each run that one line holds,
    whichever is the longer from where the last piece ended.

    Not `final`: the points are the start of a longer polyline, and only the pieces that its
    further points cannot change are given (those from a point with max_moves more after it)."""
    out: List[Piece] = []
    i = 0
    while i < len(points) - 1 and (final or i + config.max_moves < len(points) - 1):
        arc = _longest_fit(points, i, config) if len(points) - 1 - i >= config.min_moves else None
        line = _longest_line(points, i, config)
        if arc is not None and arc[0] > line:
            out.append((i, arc[0], arc[1], arc[2]))
            i = arc[0]
        else:
            out.append((i, line, None, None))
            i = line
    return out


def _fit_chain(chain: List[Move], config: FitConfig, final: bool = True) -> Tuple[List[Move], int]:
    """One chain of joined drawn lines of one feed, with every run that fits as an arc, and how many
    of the chain's moves that covers (all if `final`; see fit_polyline)."""
    points = [(chain[0].sx, chain[0].sy)] + [(m.x, m.y) for m in chain]
    out: List[Move] = []
    covered = 0
    for first, last, centre, cw in fit_polyline(points, config, final):
        covered = last
        start = points[first]
        if centre is None:
            out.append(chain[first] if last == first + 1 else
                       replace(chain[first], sx=start[0], sy=start[1], x=points[last][0], y=points[last][1]))
            continue
        closed = math.dist(start, points[last]) <= 1e-9
        end = start if closed else points[last]     # a full circle ends where it starts
        arc = replace(chain[first], kind="arc", sx=start[0], sy=start[1], x=end[0], y=end[1],
                      cx=centre[0], cy=centre[1], cw=cw)
        if config.arc_pays is None or config.arc_pays(chain[first:last], arc):
            out.append(arc)
        else:
            out.extend(chain[first:last])
    return out, covered


def fit_arcs(items: Sequence[Item], config: FitConfig = FitConfig()) -> List[Item]:
    """The items with each run of drawn chords that lies on a circle as one arc.  An arc keeps the
    line number of its first chord; everything else passes unchanged and in order."""
    return list(iter_fit_arcs(items, config))


def iter_fit_arcs(items: Iterable[Item], config: FitConfig = FitConfig()) -> Iterator[Item]:
    """fit_arcs one item at a time, holding a chain of chords no longer than decides its next pieces
    (a few times max_moves): the pieces are the same as the whole chain's."""
    chain: List[Move] = []
    hold = 4 * (config.max_moves + 1)

    def flush(final: bool) -> List[Move]:
        if final and len(chain) < config.min_moves:
            out = list(chain)
            chain.clear()
            return out
        out, covered = _fit_chain(chain, config, final)
        del chain[:covered]
        return out

    for item in items:
        if _drawn_line(item):
            prev = chain[-1] if chain else None
            joined = prev is None or math.dist((prev.x, prev.y), (item.sx, item.sy)) <= 1e-9
            if prev is not None and (item.feed != prev.feed or not joined):
                yield from flush(True)
            chain.append(item)
            if len(chain) >= hold:
                yield from flush(False)
            continue
        yield from flush(True)
        yield item
    yield from flush(True)
