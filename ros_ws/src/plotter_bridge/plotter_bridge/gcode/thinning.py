"""Polylines kept within a budget of points, as the eye sees them: a million-segment drawing's
plan (motion/preview.py) and the ink of a day-long job (link/telemetry.py) drawn with as many
points as a page can show, the whole drawing alike, however long it is.  Pure, no ROS.
"""
from __future__ import annotations

import math
from typing import List, Optional, Tuple

from .polylines import Polyline


class Thinning:
    """Polylines kept within a budget of points, as the eye sees them.

    Every point is kept until the budget is spent.  Then the drawing is looked at on a grid of
    cells `tolerance` wide (mm: first a 2000th of the drawing's extent, a pixel of a large view,
    doubled as often as the budget needs):
    - in a path, a point nearer than `tolerance` to the one kept before it goes; each path keeps
      its first and last point;
    - a path goes whose every cell is inked already by the paths of its group before it (a
      stippling's dots, a hatching's hundredth pass over the same spot): it adds nothing to see.
      A path with a segment longer than SAMPLES cells stays (its cells are not all looked at),
      and so does the last path of a group (it may go on).
    No point of the drawing is then further than three tolerances from a kept path of its group."""

    SAMPLES = 64                  # cells of a segment looked at, at most

    def __init__(self, budget: int) -> None:
        self.budget = budget
        self.tolerance = 0.0
        self.count = 0
        self.groups: List[List[Polyline]] = []
        self._inked: List[Optional[bytearray]] = []   # each group's inked cells of the grid
        self._grid = (0.0, 0.0, 0, 0)      # the grid's lowest X, Y (mm) and its cells across, up
        self._judged: List[int] = []       # each group's paths before this have been looked at
        self._lo = [math.inf, math.inf]
        self._hi = [-math.inf, -math.inf]

    def group(self) -> List[Polyline]:
        """A new list of paths (a pen's, the travel's) under this budget."""
        self.groups.append([])
        self._inked.append(None)
        self._judged.append(0)
        return self.groups[-1]

    def add(self, group: List[Polyline], path: Polyline, join: bool) -> None:
        """`path` drawn in `group`: continuing its last path if `join` and that ends where `path`
        begins, else as a new one."""
        for x, y in path:
            self._lo[0], self._lo[1] = min(self._lo[0], x), min(self._lo[1], y)
            self._hi[0], self._hi[1] = max(self._hi[0], x), max(self._hi[1], y)
        if join and group and group[-1][-1] == path[0]:
            line = group[-1]
            before = len(line)
            for p in path[1:]:
                self._extend(line, p)
            self.count += len(line) - before
        else:
            line = [path[0]]
            for p in path[1:]:
                self._extend(line, p)
            group.append(line)
            self.count += len(line)
        if self.count > self.budget:
            self._thin()

    def _extend(self, line: Polyline, p: Tuple[float, float]) -> None:
        # the last point is the path's end so far: it moves on while it is too near the one before
        if len(line) >= 2 and self.tolerance and \
                abs(line[-1][0] - line[-2][0]) + abs(line[-1][1] - line[-2][1]) < self.tolerance:
            line[-1] = p
        else:
            line.append(p)

    def _cells(self, line: Polyline) -> Optional[List[int]]:
        """The cells of the grid the path inks (at points no more than a cell apart), None if it
        has a longer segment than SAMPLES cells or leaves the grid (drawn since it was laid)."""
        t, (x_lo, y_lo, nx, ny) = self.tolerance, self._grid
        cells = []
        for k, ((x0, y0), (x1, y1)) in enumerate(zip(line[:1] + line, line)):
            n = int((abs(x1 - x0) + abs(y1 - y0)) / t) + 1 if k else 1
            if n > self.SAMPLES:
                return None
            for j in range(1, n + 1):
                ix = math.floor((x0 + (x1 - x0) * j / n - x_lo) / t)
                iy = math.floor((y0 + (y1 - y0) * j / n - y_lo) / t)
                if not (0 <= ix < nx and 0 <= iy < ny):
                    return None
                cells.append(iy * nx + ix)
        return cells

    def _thin(self) -> None:
        extent = math.hypot(self._hi[0] - self._lo[0], self._hi[1] - self._lo[1]) or 1.0
        if self.tolerance:
            self._look(again=False)        # what came since the last time, on the grid it has
        while self.count > self.budget * 3 // 4:
            self.tolerance = max(2 * self.tolerance, extent / 2000.0)
            self._look(again=True)

    def _look(self, again: bool) -> None:
        if again:
            # a byte a cell over what is drawn so far: at most 2000 x 2000 for a group
            t = self.tolerance
            nx = int((self._hi[0] - self._lo[0]) / t) + 1
            ny = int((self._hi[1] - self._lo[1]) / t) + 1
            self._grid = (self._lo[0], self._lo[1], nx, ny)
        for g, group in enumerate(self.groups):
            if again:
                self._inked[g], self._judged[g] = None, 0
            first = self._judged[g]
            kept = group[:first]
            for k in range(first, len(group)):
                path = group[k]
                if again:
                    line = [path[0]]
                    for p in path[1:]:
                        self._extend(line, p)
                else:
                    line = path
                if k == len(group) - 1:
                    kept.append(line)          # it may go on: looked at next time
                    continue
                cells = self._cells(line)
                if cells is None:
                    kept.append(line)
                    continue
                inked = self._inked[g]
                if inked is None:
                    inked = self._inked[g] = bytearray(self._grid[2] * self._grid[3])
                if not all(inked[c] for c in cells):
                    for c in cells:
                        inked[c] = 1
                    kept.append(line)
            group[:] = kept
            self._judged[g] = max(0, len(group) - 1)
        self.count = sum(len(line) for group in self.groups for line in group)
