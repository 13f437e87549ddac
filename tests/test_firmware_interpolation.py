"""Every step of the firmware core's interpolation, checked against geometry.

The reference here is independent of the C code: the textbook rules of each
interpolation method for lines (point-by-point comparison, seed 002; the
digital differential analyser, seed 001 1.2 and seed 004 5.3.2;
comparison-integration, seed 004 5.3.3.2), the worked examples of
shared/acceptance/README.md, and for arcs the geometric properties a correct
interpolator must have - one step at a time on each axis; never more than
about one step from the ideal curve; sweeping in the commanded direction
through the right angle; ending exactly on the programmed point.

Each test runs against the host library of each interpolation build option
(firmware/Makefile INTERP): point-by-point comparison (the default) moves one
axis per step; the DDA and comparison-integration may move both at once (a
diagonal step), and their deviation bounds are their own.
"""
import math
import random

import pytest

from firmware_build import host_library
from plotter_bridge.sim.firmware_core import FirmwareCore

METHODS = ["pbp", "dda", "compare"]

# Largest distance of a point of the path from the ideal line / circle, in
# steps.  Point-by-point comparison and comparison-integration (seed 004:
# "less than one pulse") stay within a step; the DDA's lines within half a
# step on each axis (0.5 (|dx| + |dy|) / length <= 0.707), its arcs within
# 1.23 over radii 1..8190 (measured; the updates in turn make the staircase
# an ellipse a little off the circle, plus the rounding of each axis).
LINE_BOUND = {"pbp": 1.0, "dda": 0.5 * math.sqrt(2), "compare": 1.0}
ARC_BOUND = {"pbp": 1.0, "dda": 1.5, "compare": 1.0}


@pytest.fixture(scope="module", params=METHODS)
def core(request):
    c = FirmwareCore(host_library(INTERP=request.param))
    c.method = request.param
    yield c
    c.close()


def run(core, plan):
    core.reset()
    assert plan(core) == 0
    start = core.position
    steps = core.run_steps(capacity=600_000)
    pts = [start]
    for s in steps:
        if core.method == "pbp":
            assert (abs(s.dx), abs(s.dy)) in ((1, 0), (0, 1)), "one axis, one step at a time"
        else:
            assert abs(s.dx) <= 1 and abs(s.dy) <= 1 and (s.dx, s.dy) != (0, 0), \
                "at most one step per axis, and a step"
        x, y = pts[-1]
        pts.append((x + s.dx, y + s.dy))
    assert pts[-1] == core.position
    return pts, steps


def textbook_line(dx, dy):
    """Seed 002 / 000 section 2.1: F >= 0 steps along X, F < 0 along Y; n = |dx| + |dy|."""
    ax, ay = abs(dx), abs(dy)
    sx, sy = (1 if dx >= 0 else -1), (1 if dy >= 0 else -1)
    f, out = 0, []
    if ax == 0:
        return [(0, sy)] * ay
    for _ in range(ax + ay):
        if f >= 0:
            out.append((sx, 0))
            f -= ay
        else:
            out.append((0, sy))
            f += ax
    return out


def textbook_dda_line(dx, dy):
    """Seed 004 5.3.2 / seed 001 1.2: two integrators of capacity 2^n, n the
    bit length of the larger of |dx| and |dy| (the registers normalised by
    left shifts until its top bit is set), remainders preloaded with half of
    it; each of the 2^n iterations adds |dx| and |dy|, an overflow is a step
    on that axis."""
    ax, ay = abs(dx), abs(dy)
    sx, sy = (1 if dx >= 0 else -1), (1 if dy >= 0 else -1)
    cap = 2 ** max(ax, ay).bit_length()
    jx = jy = cap // 2
    out = []
    for _ in range(cap):
        jx += ax
        jy += ay
        step = (sx if jx >= cap else 0, sy if jy >= cap else 0)
        jx %= cap
        jy %= cap
        if step != (0, 0):
            out.append(step)
    return out


def textbook_compare_line(dx, dy):
    """Seed 004 5.3.3.2, table 5-3: the longer axis is the base and steps
    every time; F >= 0 steps the other axis too and takes the base count off
    F; every iteration adds the other count.  F starts at 0 (at -1 along an
    axis, where the other axis must not step)."""
    ax, ay = abs(dx), abs(dy)
    sx, sy = (1 if dx >= 0 else -1), (1 if dy >= 0 else -1)
    base, other = (ax, ay) if ax >= ay else (ay, ax)
    f = 0 if other else -1
    out = []
    for _ in range(base):
        both = f >= 0
        if both:
            f -= base
        f += other
        if ax >= ay:
            out.append((sx, sy if both else 0))
        else:
            out.append((sx if both else 0, sy))
    return out


TEXTBOOK_LINE = {"pbp": textbook_line, "dda": textbook_dda_line, "compare": textbook_compare_line}


def check_line(core, dx, dy):
    if (dx, dy) == (0, 0):
        return
    pts, steps = run(core, lambda c: c.plan_line(dx, dy))
    assert pts[-1] == (dx, dy)
    assert [(s.dx, s.dy) for s in steps] == TEXTBOOK_LINE[core.method](dx, dy)
    length = math.hypot(dx, dy)
    for x, y in pts:
        # distance from the ideal segment, in steps
        assert abs(x * dy - y * dx) / length <= LINE_BOUND[core.method] + 1e-9


def check_arc(core, x0, y0, x1, y1, cx, cy, cw):
    """Arc from (x0,y0) to (x1,y1) around (cx,cy); start is the origin of the move."""
    dx, dy, i, j = x1 - x0, y1 - y0, cx - x0, cy - y0
    pts, steps = run(core, lambda c: c.plan_arc(dx, dy, i, j, cw))
    r = math.hypot(x0 - cx, y0 - cy)
    assert pts[-1] == (dx, dy), "end point exact"
    swept = 0.0
    prev = math.atan2(y0 - cy, x0 - cx)
    for x, y in pts:
        px, py = x + x0 - cx, y + y0 - cy
        assert abs(math.hypot(px, py) - r) <= ARC_BOUND[core.method] + 1e-9, "near the circle"
        if (px, py) == (0, 0):
            continue          # radius 1: the staircase may pass through the centre
        a = math.atan2(py, px)
        d = (a - prev + math.pi) % (2 * math.pi) - math.pi
        assert (d <= 1e-12) if cw else (d >= -1e-12), "never sweeps backwards"
        swept += d
        prev = a
    a0 = math.atan2(y0 - cy, x0 - cx)
    a1 = math.atan2(y1 - cy, x1 - cx)
    want = ((a0 - a1) if cw else (a1 - a0)) % (2 * math.pi)
    if (x0, y0) == (x1, y1):
        want = 2 * math.pi
    assert abs(abs(swept) - want) < 1e-6 or (want < 1e-9 and abs(swept) < 1e-9)
    return pts, steps


@pytest.fixture(scope="module")
def pbp_core():
    """The default build's core: the worked examples are point-by-point comparison's."""
    c = FirmwareCore(host_library())
    c.method = "pbp"
    yield c
    c.close()


def test_worked_examples_from_acceptance_readme(pbp_core):
    core = pbp_core
    pts, steps = run(core, lambda c: c.plan_line(6, 4))
    assert "".join("X" if s.dx else "Y" for s in steps) == "XYXYXXYXYX"
    # counter-clockwise (4,0) -> (0,4) about (0,0)
    pts, steps = run(core, lambda c: c.plan_arc(-4, 4, -4, 0, False))
    assert [(s.dx, s.dy) for s in steps] == [(-1, 0), (0, 1), (0, 1), (0, 1), (-1, 0), (0, 1), (-1, 0), (-1, 0)]
    # clockwise (0,6) -> (6,0) about (0,0)
    pts, steps = run(core, lambda c: c.plan_arc(6, -6, 0, -6, True))
    moves = "".join(("+" if s.dx + s.dy > 0 else "-") + ("X" if s.dx else "Y") for s in steps)
    assert moves == "-Y+X+X+X+X-Y+X-Y+X-Y-Y-Y"


def test_worked_line_examples_of_the_other_methods(core):
    """(6, 4) worked by hand from the seeds' tables."""
    pts, steps = run(core, lambda c: c.plan_line(6, 4))
    moves = " ".join(("X" if s.dx else "") + ("Y" if s.dy else "") for s in steps)
    want = {
        "pbp": "X Y X Y X X Y X Y X",
        # capacity 8, remainders from 4: X +6, Y +4 per iteration
        "dda": "XY X Y X XY X Y X",
        # base X; F = 0: XY (F -2), X (2), XY (0), XY (-2), X (2), XY (0)
        "compare": "XY X XY XY X XY",
    }[core.method]
    assert moves == want


@pytest.mark.parametrize("dx,dy", [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1), (5, 0), (0, -7),
                                   (1, 1), (-1, -1), (3, -3), (32767, 0), (0, -32767),
                                   (32767, 32767), (-32767, 1), (1, -32767), (100, 1), (-1, 100)])
def test_line_edge_cases(core, dx, dy):
    if (dx, dy) == (0, 0):
        pts, steps = run(core, lambda c: c.plan_line(0, 0))
        assert steps == []
        return
    check_line(core, dx, dy)


def test_random_lines_all_quadrants(core):
    rng = random.Random(2)
    for _ in range(1500):
        scale = rng.choice((3, 30, 300, 3000))
        check_line(core, rng.randint(-scale, scale), rng.randint(-scale, scale))


def on_circle(rng, cx, cy, r):
    """An integer point within half a step of the circle."""
    while True:
        a = rng.uniform(0, 2 * math.pi)
        x, y = round(cx + r * math.cos(a)), round(cy + r * math.sin(a))
        if abs(math.hypot(x - cx, y - cy) - r) <= 0.5:
            return x, y


def test_random_arcs_both_directions(core):
    rng = random.Random(3)
    for _ in range(1200):
        r = rng.choice((1, 2, 3, 5, 10, 40, 200, 1000))
        cx, cy = rng.randint(-50, 50), rng.randint(-50, 50)
        x0, y0 = on_circle(rng, cx, cy, r)
        r0 = math.hypot(x0 - cx, y0 - cy)
        if r0 == 0:
            continue
        x1, y1 = on_circle(rng, cx, cy, r0)
        check_arc(core, x0, y0, x1, y1, cx, cy, rng.random() < 0.5)


@pytest.mark.parametrize("cw", [False, True])
@pytest.mark.parametrize("r", [1, 2, 7, 100, 2500])
def test_full_circles_close_exactly(core, cw, r):
    for x0, y0 in ((r, 0), (0, r), (-r, 0), (0, -r)):
        pts, steps = check_arc(core, x0, y0, x0, y0, 0, 0, cw)
        if core.method == "pbp":
            assert len(steps) == 8 * r if r > 1 else len(steps) >= 4
        else:
            assert len(steps) >= 4 * r        # each axis travels 4r


@pytest.mark.parametrize("cw", [False, True])
def test_quarter_half_and_three_quarter_arcs_start_and_end_on_axes(core, cw):
    r = 60
    axis = [(r, 0), (0, r), (-r, 0), (0, -r)]
    for a in range(4):
        for k in (1, 2, 3):
            b = (a - k) % 4 if cw else (a + k) % 4
            check_arc(core, *axis[a], *axis[b], 0, 0, cw)


@pytest.mark.parametrize("cw", [False, True])
def test_large_radius_arcs(core, cw):
    rng = random.Random(5)
    for r in (30000, 32000):
        x0, y0 = on_circle(rng, 0, 0, r)
        x1, y1 = on_circle(rng, 0, 0, math.hypot(x0, y0))
        check_arc(core, x0, y0, x1, y1, 0, 0, cw)
    check_arc(core, 30000, 0, 30000, 0, 0, 0, cw)    # 240,000 steps, closes exactly


def test_bad_arcs_are_refused_and_nothing_moves(core):
    core.reset()
    assert core.plan_arc(10, 0, 0, 0, False) == 8         # centre on the start
    assert core.plan_arc(50, 0, 10, 0, True) == 8         # end far off the circle
    assert core.plan_arc(0, 0, 32767, 32767, True) == 11  # radius beyond 16-bit coordinates
    assert core.run_steps() == []
    assert core.position == (0, 0)


@pytest.mark.parametrize("cw", [False, True])
def test_arcs_brake_to_their_exit_rate_before_the_end(core, cw):
    """The ramp counts interrupts (iterations), and an arc's count is an
    estimate: for the DDA and comparison-integration a lower bound, so that
    braking comes early rather than late.  The last step of an arc that
    stops comes at the lowest rates of the ramp (the ramp arrives at its
    exit level with the last step: the period before it is level 1's,
    921600 / 450 cycles), never in the middle of braking."""
    rng = random.Random(11 + cw)
    level1_period = 921_600 // 450
    for _ in range(60):
        r = rng.choice((20, 100, 300, 520, 1000, 3000))
        x0, y0 = on_circle(rng, 0, 0, r)
        r0 = math.hypot(x0, y0)
        x1, y1 = on_circle(rng, 0, 0, r0)
        pts, steps = run(core, lambda c: c.plan_arc(x1 - x0, y1 - y0, -x0, -y0, cw, 8000, 0))
        assert pts[-1] == (x1 - x0, y1 - y0)
        if len(steps) >= 20:
            assert steps[-1].cycles >= 0.99 * level1_period, (x0, y0, x1, y1, steps[-1].cycles)
