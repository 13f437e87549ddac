"""The pen-down moves of a G-code program as polylines, and a grid of
segments for quick "is this point near the path" questions.  Pure: the
pictures (cli/picture.py), the web page's preview and the line-following
sheet (sim/sheet.py) all use them.
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

Point = Tuple[float, float]
Polyline = List[Point]


def arc_points(x0: float, y0: float, x1: float, y1: float, cx: float, cy: float, cw: bool,
               max_step_mm: float = 0.25) -> Polyline:
    """An arc (start == end: a full circle) as a polyline, points at most max_step_mm apart."""
    a0 = math.atan2(y0 - cy, x0 - cx)
    a1 = math.atan2(y1 - cy, x1 - cx)
    r = math.hypot(x0 - cx, y0 - cy)
    sweep = ((a0 - a1) if cw else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
    n = max(8, int(math.ceil(r * sweep / max_step_mm)))
    sign = -1 if cw else 1
    pts = [(cx + r * math.cos(a0 + sign * sweep * k / n), cy + r * math.sin(a0 + sign * sweep * k / n))
           for k in range(n)]
    return pts + [(x1, y1)]


def program_polylines(text: str, start: Point = (0.0, 0.0), options=None) -> List[Polyline]:
    """The pen-down moves of a G-code program, as continuous polylines (mm);
    `options` is its dialect (gcode.dialect.GCodeOptions, default linuxcnc)."""
    from .dialect import GCodeOptions
    from .parser import parse, moves_of
    out: List[Polyline] = []
    end: Optional[Point] = None
    for m in moves_of(parse(text, start=start, options=options or GCodeOptions())):
        if m.rapid or m.pen != "down":
            end = None
            continue
        if m.kind == "arc":
            pts = arc_points(m.sx, m.sy, m.x, m.y, m.cx, m.cy, bool(m.cw))
        else:
            pts = [(m.sx, m.sy), (m.x, m.y)]
        if end is not None and math.dist(end, pts[0]) < 1e-6:
            out[-1].extend(pts[1:])
        else:
            out.append(pts)
        end = pts[-1]
    return out


class SegmentGrid:
    """Segments bucketed by cell, for fast nearest checks: near(p, tol) is
    exact for tol up to the cell size.  A cell keeps each segment as its
    start, direction and 1/length², so that a question costs a few
    multiplications per segment near it (the line-following sheet asks three
    a step)."""

    def __init__(self, polylines: Sequence[Polyline], cell: float = 5.0) -> None:
        self.cell = cell
        self.cells: dict = {}
        for line in polylines:
            for a, b in zip(line, line[1:]):
                dx, dy = b[0] - a[0], b[1] - a[1]
                l2 = dx * dx + dy * dy
                seg = (a[0], a[1], dx, dy, 1.0 / l2 if l2 else 0.0)
                for i in range(int(min(a[0], b[0]) // cell) - 1, int(max(a[0], b[0]) // cell) + 2):
                    for j in range(int(min(a[1], b[1]) // cell) - 1, int(max(a[1], b[1]) // cell) + 2):
                        self.cells.setdefault((i, j), []).append(seg)

    def near(self, p: Point, tol: float) -> bool:
        px, py = p
        tol2 = tol * tol
        for x0, y0, dx, dy, inv_l2 in self.cells.get((int(px // self.cell), int(py // self.cell)), ()):
            ex, ey = px - x0, py - y0
            t = (ex * dx + ey * dy) * inv_l2
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
            ex, ey = ex - t * dx, ey - t * dy
            if ex * ex + ey * ey <= tol2:
                return True
        return False
