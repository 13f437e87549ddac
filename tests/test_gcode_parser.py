"""The G-code parser: every word of the subset, modes, units, pen, limits, steps."""

from __future__ import annotations

import contextlib
import io
import json
import math
import random
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)

from plotter_bridge.cli import main as cli  # noqa: E402
from plotter_bridge.gcode.parser import (Dwell, GCodeError, Move, Pause, PenChange,  # noqa: E402
                                  StepMove, WorkArea, check_limits, moves_of, parse,
                                  to_steps)
from plotter_bridge.gcode.geometry import arc_sweep  # noqa: E402
from plotter_bridge.gcode.steps import round_step  # noqa: E402


def moves(text: str, **kw) -> list:
    return moves_of(parse(text, **kw))


def approx(value, tol=1e-9):
    return pytest.approx(value, abs=tol)


def end(move: Move):
    return (round(move.x, 9), round(move.y, 9))


# ------------------------------------------------------------------ lines, modes

def test_single_line_move():
    (m,) = moves("G21 G90 F600\nG1 X10 Y20\n")
    assert (m.line, m.kind, m.sx, m.sy, m.x, m.y) == (2, "line", 0.0, 0.0, 10.0, 20.0)
    assert m.feed == 600.0 and not m.rapid and m.pen == "up" and m.cx is None


def test_modal_g1_and_modal_feed():
    ms = moves("F100\nG1 X1\nX2\nY3 F200\nX0 Y0\n")
    assert [end(m) for m in ms] == [(1, 0), (2, 0), (2, 3), (0, 0)]
    assert [m.feed for m in ms] == [100, 100, 200, 200]
    assert [m.line for m in ms] == [2, 3, 4, 5]


def test_motion_word_alone_sets_the_mode():
    ms = moves("F100\nG1\nX5\nG0\nY5\n")
    assert [(end(m), m.rapid) for m in ms] == [((5, 0), False), ((5, 5), True)]


def test_g90_g91_switching():
    ms = moves("F100\nG1 X10 Y10\nG91\nX5 Y-2\nX5\nG90\nX1 Y1\nG91 X1\n")
    assert [end(m) for m in ms] == [(10, 10), (15, 8), (20, 8), (1, 1), (2, 1)]


def test_incremental_from_start():
    ms = moves("G91 F100 G1 X3 Y4\nX3 Y4\n")
    assert [end(m) for m in ms] == [(3, 4), (6, 8)]


def test_inches_convert_coordinates_and_feed():
    ms = moves("G20 F10\nG1 X1 Y2\nG21 G1 X30\n")
    assert end(ms[0]) == (25.4, 50.8)
    assert ms[0].feed == approx(254.0)
    assert end(ms[1]) == (30, 50.8)
    assert ms[1].feed == approx(254.0)  # a feed keeps its speed when units change


def test_inch_incremental():
    ms = moves("G20 G91 F10\nG1 X0.5\nX0.5\n")
    assert [m.x for m in ms] == [approx(12.7), approx(25.4)]


def test_f_on_a_g20_line_is_in_inches():
    (m,) = moves("G20 F10 G1 X1\n")
    assert m.feed == approx(254.0)


def test_zero_length_moves_are_dropped():
    ms = moves("F100\nG1 X5\nX5\nG91 X0\nG90 X6\n")
    assert [end(m) for m in ms] == [(5, 0), (6, 0)]


def test_g0_rapid_uses_rapid_rate():
    (m,) = moves("G0 X10 Y5\n", rapid_rate=1234.0)
    assert m.rapid and m.feed == 1234.0 and m.pen == "up"


def test_rapid_rate_must_be_positive():
    with pytest.raises(ValueError):
        parse("G0 X1\n", rapid_rate=0.0)


def test_leading_zeros_and_decimal_g_codes():
    ms = moves("G01 F100 X1\nG1.0 X2\nG00 X3\ng0 x4\n")
    assert [(m.x, m.rapid) for m in ms] == [(1, False), (2, False), (3, True), (4, True)]


def test_accepted_modes_without_effect():
    a = moves("G17 G61 G94 G21 G90 F100\nG64 G1 X1\nG64 P0.01\nG1 X2\n")
    b = moves("G21 G90 F100\nG1 X1\nG1 X2\n")
    assert [end(m) for m in a] == [end(m) for m in b]


# ------------------------------------------------------------------ G92

def test_g92_offsets_later_moves():
    ms = moves("G21 F100\nG0 X10 Y10\nG92 X0 Y0\nG1 X5 Y5\n")
    assert end(ms[-1]) == (15, 15)


def test_g92_partial_axes():
    ms = moves("F100\nG0 X10 Y10\nG92 X2\nG1 X3 Y3\n")
    assert end(ms[-1]) == (11, 3)


def test_g92_then_incremental_moves():
    ms = moves("F100\nG0 X10 Y10\nG92 X100 Y100\nG91 G1 X1 Y2\nX1\nG90 X100 Y100\n")
    assert [end(m) for m in ms[1:]] == [(11, 12), (12, 12), (10, 10)]


def test_g92_values_are_absolute_in_g91():
    ms = moves("F100 G91\nG1 X10\nG92 X5\nG90 G1 X6\n")
    assert end(ms[-1]) == (11, 0)


def test_g92_in_inches():
    ms = moves("G20 F10\nG0 X1\nG92 X0\nG1 X1\n")
    assert ms[-1].x == approx(50.8)


def test_g92_z_has_no_effect():
    ms = moves("F100\nG0 X10\nG92 X0 Y0 Z0\nG1 X1\n")
    assert end(ms[-1]) == (11, 0) and ms[-1].pen == "up"


# ------------------------------------------------------------------ arcs

def test_ij_arc_centre_is_relative_to_start():
    (_, m) = moves("G21 F100\nG0 X10 Y10\nG3 X20 Y20 I10\n")
    assert (m.kind, m.cx, m.cy, m.cw) == ("arc", 20.0, 10.0, False)
    assert end(m) == (20, 20)


def test_ij_is_incremental_even_in_g90_and_g91():
    a = moves("F100\nG0 X10 Y10\nG90 G2 X20 Y10 I5 J0\n")[-1]
    b = moves("F100\nG0 X10 Y10\nG91 G2 X10 Y0 I5 J0\n")[-1]
    assert (a.cx, a.cy, a.x, a.y) == (b.cx, b.cy, b.x, b.y) == (15, 10, 20, 10)
    assert a.cw and b.cw


def test_r_arc_semicircle():
    (m,) = moves("F100\nG2 X10 R5\n")
    assert (m.cx, m.cy) == (approx(5.0), approx(0.0))


@pytest.mark.parametrize("word,r,expected_cy", [
    ("G2", 10, -5 * math.sqrt(3)),   # clockwise, short arc: centre to the right
    ("G2", -10, 5 * math.sqrt(3)),   # clockwise, long arc
    ("G3", 10, 5 * math.sqrt(3)),    # counter-clockwise, short arc: centre to the left
    ("G3", -10, -5 * math.sqrt(3)),  # counter-clockwise, long arc
])
def test_r_arc_sign_convention(word, r, expected_cy):
    (m,) = moves(f"F100\n{word} X10 Y0 R{r}\n")
    assert m.cx == approx(5.0) and m.cy == approx(expected_cy)
    assert math.hypot(m.cx, m.cy) == approx(10.0)
    sweep = arc_sweep((m.sx, m.sy), (m.x, m.y), (m.cx, m.cy), m.cw)
    assert (sweep <= math.pi) == (r > 0)
    assert sweep == approx(math.pi / 3 if r > 0 else 5 * math.pi / 3)


def test_r_arc_in_inches_and_incremental():
    (_, m) = moves("G20 F10\nG0 X1\nG91 G3 X1 Y1 R1\n")
    assert end(m) == (50.8, 25.4)
    assert (m.cx, m.cy) == (approx(25.4), approx(25.4))  # short CCW: centre to the left


def test_r_just_too_small_within_tolerance_is_a_half_circle():
    (m,) = moves("F100\nG2 X10 R4.999\n")
    assert (m.cx, m.cy) == (approx(5.0), approx(0.0))


def test_full_circle_with_ij():
    (m,) = moves("F100\nG2 I5 J0\n")
    assert m.is_full_circle and (m.cx, m.cy) == (5.0, 0.0) and m.cw
    (m,) = moves("F100\nG0 X10 Y10\nG3 X10 Y10 J-5\n")[1:]
    assert m.is_full_circle and (m.cx, m.cy) == (10.0, 5.0) and not m.cw


def test_modal_arc_with_only_ij_is_a_full_circle():
    ms = moves("F100\nG2 X10 I5\nJ-3\n")
    assert ms[-1].is_full_circle and (ms[-1].cx, ms[-1].cy) == (10.0, -3.0)


def test_arc_radius_tolerance_boundaries_metric():
    # 0.02 mm difference (threshold 0.0283 mm): accepted; 0.06 mm and 1.2 %: rejected.
    moves("G21 F100\nG2 X10 I4.99\n")
    with pytest.raises(GCodeError, match="radius to end of arc differs"):
        moves("G21 F100\nG2 X10 I4.97\n")


def test_arc_radius_tolerance_is_larger_in_inches():
    # The inch threshold is 2*0.001*sqrt(2) = 0.00283 inch: 0.002 inch passes.
    moves("G20 F10\nG2 X1 I0.499\n")
    with pytest.raises(GCodeError, match="radius to end of arc differs"):
        moves("G20 F10\nG2 X1 I0.497\n")
    # The same geometry in mm (0.0508 mm difference) is rejected in a metric program.
    with pytest.raises(GCodeError, match="radius to end of arc differs"):
        moves("G21 F100\nG2 X25.4 I12.6746\n")


def test_large_arc_relative_rule():
    # r about 1000 mm: 0.5 mm difference is 0.05 %: accepted (below 0.1 % and below 2.83 mm)
    moves("G21 F100\nG2 X2000 I999.75\n")
    with pytest.raises(GCodeError, match="radius to end of arc differs"):
        moves("G21 F100\nG2 X2000 I998.5\n")  # 3 mm, 0.3 %


# ------------------------------------------------------------------ pen

def test_pen_m3_m5():
    items = parse("F100\nM3\nG1 X1\nM5\nG1 X2\n")
    assert [type(i).__name__ for i in items] == ["PenChange", "Move", "PenChange", "Move"]
    assert [m.pen for m in moves_of(items)] == ["down", "up"]
    assert items[0] == PenChange(2, "down") and items[2] == PenChange(4, "up")


def test_pen_starts_up():
    (m,) = moves("F100 G1 X1\n")
    assert m.pen == "up"


def test_pen_from_z():
    items = parse("F100\nG1 Z-1\nG1 X1\nG1 Z0.5\nG1 X2\nG1 Z0\nG1 X3\n")
    assert [m.pen for m in moves_of(items)] == ["down", "up", "down"]
    # Z-only lines change the pen and do not move.
    assert [type(i).__name__ for i in items] == ["PenChange", "Move", "PenChange", "Move",
                                                 "PenChange", "Move"]


def test_z_with_xy_changes_pen_first():
    items = parse("F100\nG1 X5 Z-1\n")
    assert items == [PenChange(2, "down"),
                     Move(2, "line", 0.0, 0.0, 5.0, 0.0, 100.0, "down")]


def test_z_incremental():
    ms = moves("F100 G91\nG1 Z-1\nX1\nZ2\nX1\nZ-1.5\nX1\n")
    assert [m.pen for m in ms] == ["down", "up", "down"]


def test_repeated_pen_state_gives_no_pen_change():
    items = parse("F100\nM3\nG1 Z-1 X1\nM3\nG1 X2\n")
    assert sum(isinstance(i, PenChange) for i in items) == 1


def test_g0_lifts_the_pen():
    items = parse("F100\nM3\nG1 X10\nG0 X20\nG1 X30\n")
    ms = moves_of(items)
    assert [(m.pen, m.rapid) for m in ms] == [("down", False), ("up", True),
                                              ("down", False)]


def test_g0_with_z_down_lowers_the_pen_after_travel():
    items = parse("F100\nG0 X10 Z-1\nG1 X20\n")
    assert [type(i).__name__ for i in items] == ["Move", "PenChange", "Move"]
    assert items[0].pen == "up" and items[0].rapid and items[2].pen == "down"


def test_g0_with_z_up_lifts_before_travel():
    items = parse("F100\nM3\nG1 X1\nG0 X10 Z5\nG1 X20\n")
    names = [type(i).__name__ for i in items]
    assert names == ["PenChange", "Move", "PenChange", "Move", "Move"]
    assert items[-1].pen == "up"


def test_arc_with_z_is_drawn_after_the_pen_change():
    items = parse("F100\nG2 X10 I5 Z-1\n")
    assert isinstance(items[0], PenChange) and items[1].pen == "down"


# ------------------------------------------------------------------ other words

def test_dwell_and_pause():
    items = parse("F100\nG4 P1.5\nG1 X1\nM0\nG1 X2\n")
    assert items[0] == Dwell(2, 1.5) and items[2] == Pause(4)


def test_dwell_before_motion_on_the_same_line():
    items = parse("F100 G1\nG4 P2 X5\n")
    assert isinstance(items[0], Dwell) and isinstance(items[1], Move)


def test_m2_stops_parsing():
    ms = moves("F100\nG1 X1\nM2\nG1 X50\nthis is not G-code [#\n")
    assert [end(m) for m in ms] == [(1, 0)]


def test_m30_stops_parsing_after_its_line():
    ms = moves("F100\nG1 X1\nG1 X2 M30\nG1 X3\n")
    assert [end(m) for m in ms] == [(1, 0), (2, 0)]


def test_comments_blank_lines_and_percent():
    text = ("%\n(header comment)\n\nG21 (mm) G90 ; absolute\n; a full-line comment\n"
            "F100 (MSG, hello)\nG1 X1 (to x=1)\n%\n")
    ms = moves(text)
    assert [(m.line, end(m)) for m in ms] == [(7, (1, 0))]


def test_case_insensitive_and_spacing():
    a = moves("g21 g90 f100\ng1 x1.5 y-2.25\n")
    b = moves("G21G90F100\nG1X1.5Y-2.25\n")
    c = moves("G 21 G90 F 100\n\tG1  X 1.5   Y -2.25\t\n")
    assert [end(m) for m in a] == [end(m) for m in b] == [end(m) for m in c]


def test_number_forms():
    ms = moves("F100\nG1 X1.\nX.5\nX+2\nX-.25\nX007\n")
    assert [m.x for m in ms] == [1.0, 0.5, 2.0, -0.25, 7.0]


def test_n_words_are_reported():
    ms = moves("N10 F100\nN20 G1 X1\nG1 X2\n")
    assert [(m.line, m.n) for m in ms] == [(2, 20), (3, None)]


def test_crlf_line_endings():
    ms = moves("G21 F100\r\nG1 X1\r\nG1 X2 Y1\r\n")
    assert [(m.line, end(m)) for m in ms] == [(2, (1, 0)), (3, (2, 1))]


def test_line_numbers_are_physical_lines():
    with pytest.raises(GCodeError) as info:
        parse("\n(comment)\n\n%\nF100\nG1 X1\n\nG1 Q1\n")
    assert info.value.line == 8 and str(info.value).startswith("line 8: ")


def test_parse_has_no_state_between_calls():
    first = parse("G20 G91 F10\nG1 X1\nM3\n")
    second = parse("G1 F100 X1\n")
    assert first != second and moves_of(second)[0].x == 1.0
    assert moves_of(second)[0].pen == "up"


# ------------------------------------------------------------------ soft limits

def test_limits_accept_inside_and_on_the_border():
    check_limits(parse("G21 F100\nG0 X200 Y200\nG1 X0 Y0\nG2 X100 Y0 I50\n"))


def test_limits_reject_end_point_outside():
    with pytest.raises(GCodeError, match="outside the work area") as info:
        check_limits(parse("G21 F100\nG0 X10\nG1 X200.01\n"))
    assert info.value.line == 3


def test_limits_reject_arc_bulging_out_with_ends_inside():
    items = parse("G21 F100\nG0 X10 Y5\nG2 X30 Y5 I10\n")  # clockwise: over the top
    check_limits(items)
    items = parse("G21 F100\nG0 X10 Y5\nG3 X30 Y5 I10\n")  # counter-clockwise: below 0
    with pytest.raises(GCodeError, match="arc leaves the work area") as info:
        check_limits(items)
    assert info.value.line == 3 and "X20.0000 Y-5.0000" in str(info.value)


def test_limits_check_only_quadrants_the_arc_crosses():
    # Half circles near the right edge, centre (195, 100), radius 10, from the top
    # to the bottom: the left half stays inside, the right half reaches X 205.
    check_limits(parse("G21 F100\nG0 X195 Y110\nG3 X195 Y90 J-10\n"))
    with pytest.raises(GCodeError, match="X205.0000 Y100.0000"):
        check_limits(parse("G21 F100\nG0 X195 Y110\nG2 X195 Y90 J-10\n"))


def test_limits_full_circle():
    check_limits(parse("G21 F100\nG0 X10 Y100\nG2 I10\n"))
    with pytest.raises(GCodeError, match="arc leaves"):
        check_limits(parse("G21 F100\nG0 X10 Y100\nG2 I-5.5\n"))


def test_limits_custom_area():
    items = parse("G21 F100\nG1 X-50 Y300\n")
    check_limits(items, WorkArea(x_min=-100, x_max=100, y_min=0, y_max=300))
    with pytest.raises(GCodeError):
        check_limits(items, WorkArea(x_min=-100, x_max=100, y_min=0, y_max=299))


def test_rapid_moves_are_limited_too():
    with pytest.raises(GCodeError, match="outside"):
        check_limits(parse("G0 X300\n"))


# ------------------------------------------------------------------ steps

def test_steps_round_absolute_end_points():
    steps = to_steps(parse("G21 F100\nG1 X10.00625 Y0.0124\n"), 80)
    (s,) = steps
    assert isinstance(s, StepMove)
    assert (s.x, s.y, s.dx, s.dy) == (801, 1, 801, 1)


def test_no_drift_over_1000_small_incremental_moves():
    program = "G21 G91 F100\n" + "G1 X0.01 Y0.0033\n" * 1000
    steps = [s for s in to_steps(parse(program), 80) if isinstance(s, StepMove)]
    assert len(steps) == 1000
    assert sum(s.dx for s in steps) == 800 == steps[-1].x   # 10 mm
    assert sum(s.dy for s in steps) == round_step(3.3 * 80) == steps[-1].y
    assert all(s.dx in (0, 1) for s in steps)
    # Each end is its own absolute position rounded, never an accumulated error.
    for k, (m, s) in enumerate(zip(moves(program), steps), start=1):
        assert s.x == round_step(m.x * 80)
        assert abs(s.x - k * 0.8) <= 0.5 + 1e-6


def test_steps_chain_start_to_previous_end():
    items = parse("G21 F100\nG1 X0.33\nX0.66\nX0.99\nG2 X1.99 I0.5\n")
    steps = [s for s in to_steps(items, 80) if isinstance(s, StepMove)]
    x = 0
    for s in steps:
        x += s.dx
        assert x == s.x


def test_steps_for_arc_centre_and_full_circle():
    steps = to_steps(parse("G21 F100\nG0 X10 Y10\nG2 X20 Y10 I5\nG3 I-5\n"), 80)
    arc, circle = steps[1], steps[2]
    assert (arc.kind, arc.i, arc.j, arc.cw, arc.x, arc.y) == ("arc", 400, 0, True, 1600, 800)
    assert arc.radius_error == 0.0
    assert (circle.kind, circle.dx, circle.dy, circle.i, circle.j, circle.cw) == (
        "arc", 0, 0, -400, 0, False)


def test_steps_pass_other_items_through():
    items = parse("G21 F100\nM3\nG4 P1\nG1 X1\nM0\nM5\n")
    steps = to_steps(items, 80)
    assert [type(s).__name__ for s in steps] == ["PenChange", "Dwell", "StepMove", "Pause",
                                                 "PenChange"]


def test_steps_per_mm_must_be_positive():
    with pytest.raises(ValueError):
        to_steps(parse("G0 X1\n"), 0)


def test_tiny_arc_within_one_step_becomes_a_line():
    items = parse("G21 F100\nG0 X10 Y10\nG2 X10.001 Y10 I0.0005 J-0.01\n")
    step = to_steps(items, 80)[-1]
    assert step.kind == "line" and (step.dx, step.dy) == (0, 0)


def test_nearly_full_circle_rounding_to_one_point_is_two_half_circles():
    # 359.996 degrees, both ends round to the same step: two halves, not nothing.
    a = math.radians(0.002)
    r = 10.0
    text = (f"G21 F100\nG0 X{100 + r * math.cos(a):.6f} Y{100 + r * math.sin(a):.6f}\n"
            f"G3 X{100 + r * math.cos(-a):.6f} Y{100 + r * math.sin(-a):.6f} "
            f"I{-r * math.cos(a):.6f} J{-r * math.sin(a):.6f}\n")
    first, second = to_steps(parse(text), 80)[1:]
    assert (first.kind, first.x, first.y, first.i, first.j) == ("arc", 7200, 8000, -800, 0)
    assert (second.kind, second.x, second.y, second.i, second.j) == ("arc", 8800, 8000, 800, 0)
    assert not first.cw and not second.cw


def test_long_arc_is_sent_as_two_halves():
    # 270 degrees clockwise around (50, 60), from -90 to 0 degrees; middle at 135.
    items = parse("G21 F100\nG0 X50 Y50\nG2 X60 Y60 R-10\n")
    first, second = to_steps(items, 80)[1:]
    assert (first.line, second.line) == (3, 3) and first.cw and second.cw
    assert (first.x, first.y) == (round_step((50 - 10 / math.sqrt(2)) * 80),
                                  round_step((60 + 10 / math.sqrt(2)) * 80))
    assert (first.x - first.dx + first.i, first.y - first.dy + first.j) == (4000, 4800)
    assert (second.x, second.y) == (4800, 4800)
    assert first.x - first.dx == 4000 and second.x - second.dx == first.x


def _random_arc_program(rng: random.Random) -> str:
    cx, cy = rng.uniform(50, 150), rng.uniform(50, 150)
    r = rng.choice([rng.uniform(0.1, 1.0), rng.uniform(1.0, 40.0)])
    a0 = rng.uniform(0, 2 * math.pi)
    sweep = rng.choice([rng.uniform(0.01, 0.5), rng.uniform(0.5, math.pi),
                        rng.uniform(math.pi, 2 * math.pi - 0.01)])
    cw = rng.random() < 0.5
    a1 = a0 - sweep if cw else a0 + sweep
    sx, sy = cx + r * math.cos(a0), cy + r * math.sin(a0)
    ex, ey = cx + r * math.cos(a1), cy + r * math.sin(a1)
    return (f"G21 F100\nG0 X{sx:.6f} Y{sy:.6f}\n{'G2' if cw else 'G3'} X{ex:.6f} "
            f"Y{ey:.6f} I{cx - sx:.6f} J{cy - sy:.6f}\n")


def _arc_midpoint(start, end, centre, cw):
    sweep = arc_sweep(start, end, centre, cw)
    a = math.atan2(start[1] - centre[1], start[0] - centre[0]) + (-sweep if cw else sweep) / 2
    r = math.hypot(start[0] - centre[0], start[1] - centre[1])
    return centre[0] + r * math.cos(a), centre[1] + r * math.sin(a)


def test_arc_steps_stay_on_a_circle_through_both_rounded_ends():
    rng = random.Random(1234)
    spm = 80
    worst = {"radius_error": 0.0, "off_circle": 0.0}
    splits = 0
    for _ in range(3000):
        move = moves(_random_arc_program(rng))[-1]
        pieces = to_steps([move], spm)
        centre = (move.cx * spm, move.cy * spm)
        radius = math.hypot(move.sx - move.cx, move.sy - move.cy) * spm
        sweep = arc_sweep((move.sx, move.sy), (move.x, move.y), (move.cx, move.cy), move.cw)
        assert len(pieces) == (2 if sweep > math.pi else 1)
        splits += len(pieces) == 2
        # the pieces chain from the rounded start to the rounded end
        x, y = round_step(move.sx * spm), round_step(move.sy * spm)
        for piece in pieces:
            assert (x + piece.dx, y + piece.dy) == (piece.x, piece.y)
            s = (x, y)
            x, y = piece.x, piece.y
            if piece.kind != "arc":
                assert (piece.dx, piece.dy) == (0, 0)
                continue
            assert piece.cw == move.cw
            assert abs(piece.radius_error) < 1.0
            worst["radius_error"] = max(worst["radius_error"], abs(piece.radius_error))
            # the middle of each drawn piece lies on the exact circle, within 1.5 steps
            c = (s[0] + piece.i, s[1] + piece.j)
            mid = _arc_midpoint(s, (piece.x, piece.y), c, piece.cw)
            off = abs(math.dist(mid, centre) - radius)
            worst["off_circle"] = max(worst["off_circle"], off)
        assert (x, y) == (round_step(move.x * spm), round_step(move.y * spm))
    assert splits > 500
    assert worst["radius_error"] < 1.0 and worst["off_circle"] < 1.5, worst


@pytest.mark.parametrize("chord", [1, 2, 3, 5, 45, 46, 399])
@pytest.mark.parametrize("axis", ["x", "y"])
def test_axis_aligned_half_circles_end_within_a_step(chord, axis):
    """The worst case for the centre rounding: the bisector between two lattice columns."""
    for cw in (True, False):
        d = chord / 80
        text = (f"G21 F100\nG0 X50 Y50\n{'G2' if cw else 'G3'} "
                + (f"X{50 + d} I{d / 2}\n" if axis == "x" else f"Y{50 + d} J{d / 2}\n"))
        (step,) = [s for s in to_steps(parse(text), 80) if isinstance(s, StepMove)][1:]
        assert step.kind == "arc" and abs(step.radius_error) < 1.0


# ------------------------------------------------------------------ plotter check

def run_cli(*argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(list(argv))
    return code, out.getvalue(), err.getvalue()


def test_check_json_records(tmp_path):
    path = tmp_path / "p.gcode"
    path.write_text("G20 F10\nG0 X1 Y1\nG92 X0 Y0\nM3\nG1 X1\nG2 X2 Y0 R0.5\n")
    code, out, err = run_cli("check", str(path), "--json")
    assert code == 0 and err == ""
    records = [json.loads(line) for line in out.splitlines()]
    assert records[0] == {"line": 2, "type": "line", "x": 25.4, "y": 25.4,
                          "feed": 3000.0, "pen": "up"}
    assert records[1] == {"line": 5, "type": "line", "x": 50.8, "y": 25.4,
                          "feed": 254.0, "pen": "down"}
    assert records[2] == {"line": 6, "type": "arc", "x": 76.2, "y": 25.4, "cx": 63.5,
                          "cy": 25.4, "cw": True, "feed": 254.0, "pen": "down"}


def test_check_table_and_summary(tmp_path):
    path = tmp_path / "p.gcode"
    path.write_text("G21 F600\nG0 X10 Y10\nM3\nN7 G1 X20\nG2 X30 I5\nG4 P1\nM5\n")
    code, out, err = run_cli("check", str(path), "--steps-per-mm", "100")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert "line" in lines[0] and "steps" in lines[0]
    assert any(" 7 " in line and "2000,1000" in line for line in lines)
    assert any("arc cw" in line and "c+500,+0" in line for line in lines)
    assert any("dwell 1 s" in line for line in lines)
    assert lines[-1].startswith(f"{path}: OK, 3 moves (1 rapid, 1 lines, 1 arcs)")


def test_check_bad_program_exit_code_and_message(tmp_path):
    path = tmp_path / "bad.gcode"
    path.write_text("G21 F100\nG1 X1\nG1 X2 Q3\n")
    code, out, err = run_cli("check", str(path))
    assert code == 2 and out == ""
    assert err == (f"{path}:line 3: unsupported word letter 'Q'\n"
                   f"{path}: refused: 1 line the plotter cannot do; nothing moved\n")


def test_check_limits_options(tmp_path):
    path = tmp_path / "big.gcode"
    path.write_text("G21\nG0 X250 Y-5\n")
    assert run_cli("check", str(path))[0] == 2
    assert run_cli("check", str(path), "--no-limits")[0] == 0
    assert run_cli("check", str(path), "--x-max", "300", "--y-min", "-10")[0] == 0


def test_check_missing_file(tmp_path):
    code, _, err = run_cli("check", str(tmp_path / "nope.gcode"))
    assert code == 2 and "cannot read" in err


def test_check_usage_errors():
    assert run_cli()[0] == 2
    assert run_cli("check")[0] == 2
    assert run_cli("no-such-command")[0] == 2


def test_subcommands_are_a_table():
    assert "check" in cli.COMMANDS
    calls = []
    extra = cli.Command("hello", "say hello", lambda p: p.add_argument("--name"),
                        lambda args: calls.append(args.name) or 0)
    parser = cli.build_parser({**cli.COMMANDS, "hello": extra})
    args = parser.parse_args(["hello", "--name", "pen"])
    assert args._run(args) == 0 and calls == ["pen"]
