"""The hanging plotter holds its tolerance everywhere in its work area: circles
and lines over a grid of places (corners and edges included), compiled as
gcode_streamer compiles them and stepped by the firmware core, every drawn
step measured against the programmed path; and where the tolerance cannot
be held, a drawn move is refused before anything moves, naming the point."""
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from firmware_build import host_library
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.motion import hanging
from plotter_bridge.motion.compiler import compile_program
from plotter_bridge.motion.hanging import ArcPath, LinePath, cut, holds, largest_pen_step, round_nearest
from plotter_bridge.motion.kinematics import HangingGeometry
from plotter_bridge.sim.firmware_core import FirmwareCore

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from hanging_sweep import (HANGING_AREA, Case, draw_cases, hanging_config, pen_positions, summary,  # noqa: E402
                           sweep_cases)

TOLERANCE = 0.1
GEOMETRY = HangingGeometry()
TALL = WorkArea(0.0, 800.0, 0.0, 1130.0)      # up to 20 mm below the pulleys


@pytest.fixture
def core():
    c = FirmwareCore(host_library())
    yield c
    c.close()


def test_the_sweep_covers_the_work_area_in_sizes_and_directions():
    cases = sweep_cases()
    a = HANGING_AREA
    corners = [(a.x_min, a.y_min), (a.x_max, a.y_min), (a.x_min, a.y_max), (a.x_max, a.y_max)]
    circles = [c for c in cases if c.kind == "circle"]
    lines = [c for c in cases if c.kind == "line"]
    for corner in corners:
        assert any(corner in (c.start, c.end) for c in lines), corner
        # ...and circles that touch both edges there.
        assert any(abs(abs(c.a[0] - corner[0]) - c.b[0]) < 1e-9 and abs(abs(c.a[1] - corner[1]) - c.b[0]) < 1e-9
                   for c in circles), corner
    for k in range(4):
        edge = (corners[k], corners[(k + 1) % 4] if k % 2 == 0 else corners[(k + 2) % 4])
        assert any({c.start, c.end} == set(edge) for c in lines), edge
    assert len({c.b[0] for c in circles}) >= 3
    assert {c.cw for c in circles} == {True, False}
    directions = {round(math.degrees(math.atan2(c.b[1] - c.a[1], c.b[0] - c.a[0]))) % 360 for c in lines}
    assert len(directions) >= 24
    for c in cases:
        assert a.contains(*c.start) and a.contains(*c.end)


@pytest.mark.parametrize("geometry,tolerance", [
    (GEOMETRY, TOLERANCE),
    (GEOMETRY, 0.25),
    (HangingGeometry(pulses_per_rev=6400.0), 0.05),        # a finer motor holds a finer tolerance
], ids=["seed-003-0.1mm", "seed-003-0.25mm", "6400-pulses-0.05mm"])
def test_every_drawn_step_within_the_tolerance_over_the_work_area(core, geometry, tolerance):
    config = hanging_config(tolerance=tolerance, geometry=geometry)
    drawn = draw_cases(sweep_cases(), config, core)
    worst, case, per_metre = summary(drawn)
    assert worst <= tolerance, f"{case.case.name}: {worst:.4f} mm at {case.where}"
    # The budget is spent, not wasted: the cut draws close to the tolerance,
    # with board lines as long as it allows.
    assert worst > 0.8 * tolerance
    assert per_metre < 150 * math.sqrt(TOLERANCE / tolerance), per_metre
    assert all(d.steps > 0 for d in drawn)


def accurate_top(geometry, x, tolerance):
    lo, hi = 0.0, geometry.left[1] - 1.0
    while hi - lo > 0.01:
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if holds(geometry, (x, mid), tolerance) else (lo, mid)
    return lo


def test_the_tolerance_holds_up_to_the_edge_of_the_accurate_area(core):
    """Just inside the edge the board takes nearly all the tolerance in the
    worst direction: strokes in 16 directions and circles still hold it."""
    cases = []
    for x in (30.0, 200.0, 400.0, 600.0, 770.0):
        top = accurate_top(GEOMETRY, x, TOLERANCE)
        centre = (x, top - 25.0)
        for k in range(16):
            a = math.radians(22.5 * k + 5.0)
            d = (15.0 * math.cos(a), 15.0 * math.sin(a))
            cases.append(Case("line", (centre[0] - d[0], centre[1] - d[1]), (centre[0] + d[0], centre[1] + d[1])))
        cases += [Case("circle", (x, top - 12.0), (10.0, 90.0)), Case("circle", (x, top - 4.0), (2.0, 0.0), cw=True)]
    drawn = draw_cases(cases, hanging_config(area=TALL), core)
    worst, case, _ = summary(drawn)
    assert worst <= TOLERANCE, f"{case.case.name}: {worst:.4f} mm at {case.where}"


def test_the_sweep_finds_a_cut_that_leaves_out_the_staircase(core, monkeypatch):
    """The measurement can fail: without the board's staircase in the budget
    the drawn path leaves the tolerance somewhere on the grid."""
    monkeypatch.setattr(hanging, "staircase", lambda geometry, p, normal: 0.0)
    worst, case, _ = summary(draw_cases(sweep_cases(), hanging_config(tolerance=TOLERANCE), core))
    assert worst > TOLERANCE * 1.2, (case.case.name, worst)


def test_pen_positions_of_the_sweep_are_the_machines():
    rng = np.random.default_rng(3)
    mx, my = rng.uniform(-40000, 40000, 50), rng.uniform(-40000, 40000, 50)
    xs, ys = pen_positions(GEOMETRY, mx, my)
    for x, y, a, b in zip(xs, ys, mx, my):
        assert (x, y) == pytest.approx(GEOMETRY.forward((a, b)), abs=1e-9)


def test_the_default_work_area_lies_in_the_accurate_area():
    a = HANGING_AREA
    for x in np.linspace(a.x_min, a.x_max, 41):
        for y in np.linspace(a.y_min, a.y_max, 51):
            assert holds(GEOMETRY, (x, y), TOLERANCE), (x, y)
    # ...but not by much: its top edge is 150 mm below the pulleys.
    assert not holds(GEOMETRY, (400.0, 1050.0), TOLERANCE)
    assert largest_pen_step(TOLERANCE) == pytest.approx(0.95 * 0.1 / 1.5)


def test_a_finer_machine_holds_more():
    fine = HangingGeometry(pulses_per_rev=6400.0)
    assert holds(fine, (400.0, 1050.0), TOLERANCE) and not holds(GEOMETRY, (400.0, 1050.0), TOLERANCE)


@pytest.mark.parametrize("program,line,path", [
    ("G0 X100 Y1000\nM3\nG1 X700 Y1100 F3000\nM5\n", 3, LinePath((100.0, 1000.0), (700.0, 1100.0))),
    ("G0 X300 Y900\nM3\nG1 X300 Y950 F3000\nG2 X500 Y950 I100 J0\nM5\n", 4,
     ArcPath.through((300.0, 950.0), (500.0, 950.0), (400.0, 950.0), cw=True)),
])
def test_a_drawn_move_outside_the_accurate_area_is_refused_naming_line_and_point(program, line, path):
    with pytest.raises(GCodeError) as info:
        compile_program(program, hanging_config(area=TALL))
    assert info.value.line == line
    message = info.value.message
    assert "cannot be held within 0.1 mm" in message and "steps per mm" in message, message
    x, y = (float(v) for v in re.search(r"at X(-?[\d.]+) Y(-?[\d.]+)", message).groups())
    # The first point of the move outside the accurate area, to the check's millimetre.
    ts = np.linspace(0.0, 1.0, 20001)
    points = [path.point(t) for t in ts]
    first = next(k for k, p in enumerate(points) if not holds(GEOMETRY, p, TOLERANCE))
    assert math.dist((x, y), points[first]) < 1.1, (message, points[first])


def test_pen_up_travel_outside_the_accurate_area_is_allowed():
    config = hanging_config(area=TALL)
    commands = compile_program("G0 X400 Y1120\nG0 X700 Y900\nM3\nG1 X700 Y800 F3000\nM5\n", config)
    assert [c.args[0] for c in commands if c.verb == "P"] == [0, 1, 0]


def test_long_travel_is_cut_into_board_lines_the_board_takes():
    pieces = cut(LinePath((0.0, 0.0), (800.0, 1000.0)), GEOMETRY, 10.0, (0, 0), drawn=False)
    assert len(pieces) >= 2           # the right string shortens by 53,000 steps
    here = (0, 0)
    for _, m in pieces:
        assert max(abs(m[0] - here[0]), abs(m[1] - here[1])) <= 32767
        here = m
    assert here == round_nearest(GEOMETRY, (800.0, 1000.0))


def test_a_full_circle_is_cut_all_the_way_round():
    circle = ArcPath.through((650.0, 500.0), (650.0, 500.0), (400.0, 500.0), cw=True)
    start = tuple(round(v) for v in GEOMETRY.inverse((650.0, 500.0)))
    pieces = cut(circle, GEOMETRY, TOLERANCE, start)
    assert len(pieces) > 16 and pieces[-1] == (1.0, start)
    ts = [t for t, _ in pieces]
    assert ts == sorted(ts)


def test_a_circle_drawn_twice_ends_where_it_started(core):
    """Cut points are chosen from the path alone: drawing the same circle
    again takes the same board lines, so nothing drifts."""
    config = hanging_config()
    case = Case("circle", (400.0, 500.0), (100.0, 0.0))
    first, second = draw_cases([case, case], config, core)
    assert first.commands == second.commands and first.steps == second.steps
    assert core.position == round_nearest(GEOMETRY, (500.0, 500.0))
