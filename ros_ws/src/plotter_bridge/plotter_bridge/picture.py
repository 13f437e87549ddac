"""An SVG picture of what the plotter drew, from the mock board's step trace.

The trace has no pen column, so a step counts as drawn when it lies within
a tolerance of the programmed path (the figures), and as pen-up travel
otherwise; the programmed path is drawn underneath in another colour.
"""
from __future__ import annotations

import math
from typing import Iterable, List, Sequence, Tuple

Point = Tuple[float, float]


def _arc_points(seg, n: int = 96) -> List[Point]:
    a0 = math.atan2(seg.y0 - seg.cy, seg.x0 - seg.cx)
    a1 = math.atan2(seg.y1 - seg.cy, seg.x1 - seg.cx)
    r = math.hypot(seg.x0 - seg.cx, seg.y0 - seg.cy)
    sweep = ((a0 - a1) if seg.cw else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
    sign = -1 if seg.cw else 1
    return [(seg.cx + r * math.cos(a0 + sign * sweep * k / n),
             seg.cy + r * math.sin(a0 + sign * sweep * k / n)) for k in range(n + 1)]


def segment_points(seg) -> List[Point]:
    """A plotter_shapes Line or Arc as a polyline (mm)."""
    if hasattr(seg, "cx"):
        return _arc_points(seg)
    return [(seg.x0, seg.y0), (seg.x1, seg.y1)]


class _SegmentGrid:
    """Programmed segments bucketed by cell, for fast nearest checks."""

    def __init__(self, polylines: Sequence[List[Point]], cell: float = 5.0) -> None:
        self.cell = cell
        self.cells: dict = {}
        for line in polylines:
            for a, b in zip(line, line[1:]):
                for i in range(int(min(a[0], b[0]) // cell) - 1, int(max(a[0], b[0]) // cell) + 2):
                    for j in range(int(min(a[1], b[1]) // cell) - 1, int(max(a[1], b[1]) // cell) + 2):
                        self.cells.setdefault((i, j), []).append((a, b))

    def near(self, p: Point, tol: float) -> bool:
        px, py = p
        for (x0, y0), (x1, y1) in self.cells.get((int(px // self.cell), int(py // self.cell)), ()):
            dx, dy = x1 - x0, y1 - y0
            l2 = dx * dx + dy * dy
            t = 0.0 if l2 == 0 else max(0.0, min(1.0, ((px - x0) * dx + (py - y0) * dy) / l2))
            if math.hypot(px - x0 - t * dx, py - y0 - t * dy) <= tol:
                return True
        return False


def svg(trace_mm: Iterable[Point], programmed: Sequence[List[Point]], width_mm: float = 200.0,
        height_mm: float = 200.0, title: str = "plotter", tol_mm: float = 0.05) -> str:
    """SVG text: axes in mm, programmed path light blue, drawn path black, travel dashed grey."""
    scale, margin = 4.0, 40.0
    W, H = width_mm * scale + 2 * margin, height_mm * scale + 2 * margin

    def xy(p: Point) -> str:
        return f"{margin + p[0] * scale:.2f},{margin + (height_mm - p[1]) * scale:.2f}"

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W:.0f}" height="{H:.0f}" '
           f'viewBox="0 0 {W:.0f} {H:.0f}" font-family="sans-serif" font-size="12">',
           f'<title>{title}</title>', f'<rect width="{W:.0f}" height="{H:.0f}" fill="white"/>']
    for v in range(0, int(width_mm) + 1, 20):
        out.append(f'<line x1="{margin + v * scale}" y1="{margin}" x2="{margin + v * scale}" '
                   f'y2="{margin + height_mm * scale}" stroke="#eee"/>')
        out.append(f'<text x="{margin + v * scale}" y="{H - 20}" text-anchor="middle">{v}</text>')
    for v in range(0, int(height_mm) + 1, 20):
        y = margin + (height_mm - v) * scale
        out.append(f'<line x1="{margin}" y1="{y}" x2="{margin + width_mm * scale}" y2="{y}" stroke="#eee"/>')
        out.append(f'<text x="{margin - 6}" y="{y + 4}" text-anchor="end">{v}</text>')
    out.append(f'<text x="{W / 2}" y="{H - 4}" text-anchor="middle">X (mm)</text>')
    out.append(f'<text x="12" y="{H / 2}" transform="rotate(-90 12 {H / 2})" text-anchor="middle">Y (mm)</text>')
    for line in programmed:
        out.append('<polyline fill="none" stroke="#8ec5ff" stroke-width="6" stroke-linejoin="round" '
                   f'points="{" ".join(xy(p) for p in line)}"/>')
    grid = _SegmentGrid(programmed)
    runs: List[Tuple[bool, List[Point]]] = []
    last = None
    for p in trace_mm:
        if last is not None and abs(p[0] - last[0]) + abs(p[1] - last[1]) < 0.2:
            continue                      # a point every 0.2 mm is plenty for a picture
        last = p
        drawn = grid.near(p, tol_mm)
        if runs and runs[-1][0] == drawn:
            runs[-1][1].append(p)
        else:
            start = [runs[-1][1][-1]] if runs else []
            runs.append((drawn, start + [p]))
    for drawn, pts in runs:
        style = 'stroke="black" stroke-width="1.5"' if drawn else 'stroke="#999" stroke-width="1" stroke-dasharray="4 3"'
        out.append(f'<polyline fill="none" {style} points="{" ".join(xy(p) for p in pts)}"/>')
    out.append("</svg>")
    return "\n".join(out) + "\n"
