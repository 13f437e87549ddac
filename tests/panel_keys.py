"""What the tests of the front panel share (firmware/README.md, *Front panel*):
the key codes, the digit keys, and the check of a drawn figure against its
commands (firmware/tools/gen_figures.py)."""
from __future__ import annotations

import math
from typing import Iterable, Optional

JOG = 800                       # steps per jog press, core/panel.c JOG_STEPS

# Key codes, row * 4 + column (core/panel.h, seed 000 figure 3.2).
K_RESET, K_XP, K_CONE, K_CIRCLE = 0, 1, 2, 3
K_DIAG, K_XN, K_DIAMOND, K_STAR = 4, 5, 6, 7
K_FASTER, K_YP, K_NO_FUNCTION, K_CAR = 8, 9, 10, 11
K_SLOWER, K_YN, K_PAUSE, K_CAR_REV = 12, 13, 14, 15
NO_KEY = 0xFF                   # no key down


def digit_key(d: int) -> int:
    """The key of digit d (seed 000 figure 3.3): row d % 4, column d // 4."""
    return (d % 4) * 4 + d // 4


Segment = tuple  # (pen down, start, end, centre or None)


def figure_segments(commands, start=(0, 0)) -> list[Segment]:
    """The lines and arcs of gen_figures' commands, from `start`."""
    x, y = start
    pen = False
    segs = []
    for kind, *a in commands:
        if kind in ("up", "down"):
            pen = kind == "down"
            continue
        if kind == "end":
            break
        end = (x + a[0], y + a[1])
        centre: Optional[tuple] = (x + a[2], y + a[3]) if kind in ("cw", "ccw") else None
        segs.append((pen, (x, y), end, centre))
        x, y = end
    return segs


def distance(p, seg: Segment) -> float:
    """From point p to a line segment, or to an arc's circle."""
    _, a, b, c = seg
    if c is not None:
        return abs(math.dist(p, c) - math.dist(a, c))
    L2 = (b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2
    t = 0.0 if L2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * (b[0] - a[0]) + (p[1] - a[1]) * (b[1] - a[1])) / L2))
    return math.dist(p, (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])))


def assert_on_figure(trace: Iterable[tuple[int, int, bool]], commands, start=(0, 0)) -> None:
    """Every (x, y, pen down) within one step of a segment of the figure with
    the same pen state, and the last back at the start."""
    segs = figure_segments(commands, start)
    last = None
    for x, y, pen in trace:
        worst = min(distance((x, y), s) for s in segs if s[0] == pen)
        assert worst <= 1.0, (x, y, pen, worst)
        last = (x, y)
    assert last == start
