"""Tests of plotter_shapes.geometry: figures, reversal, validation and G-code.

Pure Python, no ROS. The G-code is read back with a small regex reader
defined here, independent of the plotter_bridge parser.
"""

import math
import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "ros_ws", "src", "plotter_shapes"))

import pytest  # noqa: E402

from plotter_shapes.geometry import (  # noqa: E402
    DEFAULT_CENTRE_MM,
    DEFAULT_SIZE_MM,
    SHAPE_NAMES,
    STAR_WIDTH_PER_EDGE,
    Arc,
    Figure,
    Line,
    ShapeError,
    Stroke,
    arc,
    bounding_box,
    build_shape,
    car,
    circle,
    cone,
    diamond,
    figure_to_gcode,
    goal_program,
    line,
    resolve_placement,
    reverse,
    star,
    star_tips,
    translate,
)

SIN18 = math.sin(math.radians(18))
COS18 = math.cos(math.radians(18))
COS36 = math.cos(math.radians(36))
COT18 = 1 / math.tan(math.radians(18))
PHI = (1 + math.sqrt(5)) / 2


def all_figures():
    """One figure of every kind, in both directions where that applies."""
    figures = {
        "diamond": diamond(50, 60, 30),
        "star": star(100, 100, 40),
        "circle_ccw": circle(30, 40, 12, clockwise=False),
        "circle_cw": circle(30, 40, 12, clockwise=True),
        "cone_cw": cone(100, 100, 40, clockwise=True),
        "cone_ccw": cone(100, 100, 40, clockwise=False),
        "car": car(100, 100, 80),
        "line": line(10, 20, 70, -5),
        "arc_ccw": arc(100, 100, 25, 30, 200, clockwise=False),
        "arc_cw": arc(100, 100, 25, 30, 200, clockwise=True),
        "arc_full": arc(100, 100, 25, 45, 405, clockwise=False),
    }
    figures.update({name + "_reversed": reverse(f) for name, f in list(figures.items())})
    return figures


FIGURES = all_figures()


# --- a tiny G-code reader ---------------------------------------------------

WORD = re.compile(r"([A-Z])(-?\d+(?:\.\d+)?)")
LINE_FORMAT = re.compile(r"^(?:\([^()]*\)|(?:[A-Z]-?\d+(?:\.\d+)? ?)+)$")


def read_gcode(lines):
    """Replay the program: returns the list of pen-down moves as
    ("line", x0, y0, x1, y1) / ("arc", x0, y0, x1, y1, cx, cy, cw) and the
    pen state at the end. Fails on anything outside the expected subset."""
    assert lines[-1] == "M2", "program must end with M2"
    x = y = None
    pen_down = False
    units = absolute = False
    moves = []
    for text in lines:
        assert LINE_FORMAT.match(text), f"not a plain G-code line: {text!r}"
        if text.startswith("("):
            continue
        words = WORD.findall(text)
        assert "".join(l + n + " " for l, n in words).strip() == text
        codes = [l + n for l, n in words if l in "GM"]
        params = {l: float(n) for l, n in words if l not in "GM"}
        assert set(params) <= set("XYIJF"), text
        if "G21" in codes:
            units = True
        if "G90" in codes:
            absolute = True
        if "M3" in codes:
            pen_down = True
        if "M5" in codes:
            pen_down = False
        motion = [c for c in codes if c in ("G0", "G1", "G2", "G3")]
        if not motion:
            continue
        assert units and absolute, "G21 G90 must come before any move"
        code = motion[0]
        nx, ny = params.get("X", x), params.get("Y", y)
        if code == "G0":
            assert not pen_down, "travel with the pen down"
            assert "F" not in params
        else:
            assert pen_down, f"{code} with the pen up"
            assert x is not None, "draw move before any position is known"
            assert params.get("F", 0) > 0, f"{code} without a feed"
            if code == "G1":
                moves.append(("line", x, y, nx, ny))
            else:
                assert "I" in params or "J" in params, "arc without I/J"
                cx, cy = x + params.get("I", 0.0), y + params.get("J", 0.0)
                r0 = math.hypot(x - cx, y - cy)
                r1 = math.hypot(nx - cx, ny - cy)
                # LinuxCNC's metric centre-format tolerance.
                assert abs(r0 - r1) <= 2 * 0.01 * math.sqrt(2), text
                moves.append(("arc", x, y, nx, ny, cx, cy, code == "G2"))
        x, y = nx, ny
    return moves, pen_down


def segment_tuple(seg):
    if isinstance(seg, Line):
        return ("line", seg.x0, seg.y0, seg.x1, seg.y1)
    return ("arc", seg.x0, seg.y0, seg.x1, seg.y1, seg.cx, seg.cy, seg.cw)


# --- star -------------------------------------------------------------------


def test_star_tips_follow_the_corrected_seed_formulas():
    a = 10.0
    tips = star_tips(a)
    assert tips["A"] == pytest.approx((a + a * SIN18, 0.0))
    assert tips["D"] == pytest.approx((-a - a * SIN18, 0.0))
    assert tips["E"] == pytest.approx((0.0, a * COS18))
    bottom_y = -COS36 * COT18 * a + COS18 * a
    assert tips["B"] == pytest.approx((a * COS36, bottom_y))
    assert tips["C"] == pytest.approx((-a * COS36, bottom_y))
    # The sin 18 / cos 36 relations behind the construction.
    assert 2 * SIN18 == pytest.approx(1 / PHI)  # inner pentagon side / edge
    assert 2 * COS36 == pytest.approx(PHI)  # outer pentagon side / edge
    assert 1 + SIN18 == pytest.approx(PHI**2 / 2)
    assert bottom_y / a == pytest.approx(-1.538841768587627)


def pentagram_tips(figure):
    (stroke,) = figure.strokes
    assert len(stroke.segments) == 5
    assert all(isinstance(s, Line) for s in stroke.segments)
    return [s.start for s in stroke.segments]


@pytest.mark.parametrize("size", [1.0, 40.0, 123.4, 1000.0])
def test_star_is_a_regular_pentagram(size):
    figure = star(70, 80, size)
    tips = pentagram_tips(figure)
    (stroke,) = figure.strokes
    assert stroke.start == stroke.end
    # All five lines have the same length, equal to the star's width.
    lengths = [s.length for s in stroke.segments]
    for length in lengths:
        assert length == pytest.approx(size, rel=1e-12)
    # Tips on one circle, 72 degrees apart.
    cx = sum(p[0] for p in tips) / 5
    cy = sum(p[1] for p in tips) / 5
    radii = [math.hypot(px - cx, py - cy) for px, py in tips]
    for r in radii:
        assert r == pytest.approx(radii[0], rel=1e-12)
    angles = sorted(math.degrees(math.atan2(py - cy, px - cx)) % 360 for px, py in tips)
    gaps = [(angles[(i + 1) % 5] - angles[i]) % 360 for i in range(5)]
    assert gaps == pytest.approx([72.0] * 5)
    # First tip is the top one, straight above the centre.
    assert tips[0][0] == pytest.approx(cx)
    assert tips[0][1] > cy
    # Each line skips one tip: consecutive tips are 144 degrees apart.
    for (x0, y0), (x1, y1) in zip(tips, tips[1:] + tips[:1]):
        a0 = math.atan2(y0 - cy, x0 - cx)
        a1 = math.atan2(y1 - cy, x1 - cx)
        assert abs(math.degrees(a1 - a0)) % 360 in (pytest.approx(144.0), pytest.approx(216.0))


def test_star_matches_the_seed_tips_and_fits_its_box():
    size = 40.0
    figure = star(100, 100, size)
    a = size / STAR_WIDTH_PER_EDGE
    seed = star_tips(a)
    box = bounding_box(figure)
    assert box.width == pytest.approx(size)
    assert box.height == pytest.approx(a * COS36 * COT18)
    assert box.centre == pytest.approx((100.0, 100.0))
    # Same tips as the seed's frame, moved so that the box is centred.
    dx = 100.0
    dy = 100.0 - (seed["E"][1] + seed["B"][1]) / 2
    expected = [seed[k] for k in ("E", "C", "A", "D", "B")]
    for got, (ex, ey) in zip(pentagram_tips(figure), expected):
        assert got == pytest.approx((ex + dx, ey + dy), abs=1e-12)


# --- circle and arc -----------------------------------------------------------


@pytest.mark.parametrize("clockwise,code", [(True, "G2"), (False, "G3")])
def test_circle_is_one_full_arc_from_the_rightmost_point(clockwise, code):
    figure = circle(50, 60, 15, clockwise=clockwise)
    (stroke,) = figure.strokes
    (seg,) = stroke.segments
    assert isinstance(seg, Arc)
    assert seg.cw is clockwise
    assert seg.start == seg.end == (65.0, 60.0)
    assert seg.is_full_circle
    assert seg.sweep == pytest.approx(-2 * math.pi if clockwise else 2 * math.pi)
    gcode = figure_to_gcode(figure, 1200, "circle")
    arcs = [g for g in gcode if g.startswith(("G2 ", "G3 "))]
    assert arcs == [f"{code} X65.0000 Y60.0000 I-15.0000 J0.0000 F1200.0000"]
    assert "G0 X65.0000 Y60.0000" in gcode
    box = bounding_box(figure)
    assert (box.xmin, box.ymin, box.xmax, box.ymax) == (35.0, 45.0, 65.0, 75.0)


def test_arc_direction_and_end_points():
    ccw = arc(0, 0, 10, 0, 90, clockwise=False)
    (seg,) = ccw.segments
    assert seg.start == (10.0, 0.0) and seg.end == (0.0, 10.0)
    assert seg.sweep == pytest.approx(math.pi / 2)
    cw = arc(0, 0, 10, 0, 90, clockwise=True)
    (seg,) = cw.segments
    assert seg.sweep == pytest.approx(-3 * math.pi / 2)
    box = bounding_box(cw)
    assert (box.xmin, box.ymin, box.xmax, box.ymax) == (-10.0, -10.0, 10.0, 10.0)
    box = bounding_box(ccw)
    assert (box.xmin, box.ymin, box.xmax, box.ymax) == (0.0, 0.0, 10.0, 10.0)
    full = arc(5, 5, 2, 90, 450)
    (seg,) = full.segments
    assert seg.is_full_circle and seg.start == (5.0, 7.0)


# --- reverse -------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_reverse_is_an_involution_and_reverses_everything(name):
    figure = FIGURES[name]
    back = reverse(figure)
    assert reverse(back) == figure
    assert back.start == figure.end
    assert back.end == figure.start
    forward_segments = figure.segments
    backward_segments = back.segments
    assert len(forward_segments) == len(backward_segments)
    for fwd, bwd in zip(forward_segments, reversed(backward_segments)):
        assert type(fwd) is type(bwd)
        assert fwd.start == bwd.end and fwd.end == bwd.start
        if isinstance(fwd, Arc):
            assert bwd.cw is (not fwd.cw)
            assert bwd.centre == fwd.centre
            assert bwd.sweep == pytest.approx(-fwd.sweep)
    assert bounding_box(back) == bounding_box(figure)


def test_car_forward_and_reversed():
    forward = build_shape("car", 100, 100, 80)
    backward = build_shape("car", 100, 100, 80, reverse=True)
    assert backward == reverse(forward)
    assert backward.end == forward.start
    assert len(forward.strokes) == 3  # body, rear wheel, front wheel
    # Forward: every arc counter-clockwise; reversed: every arc clockwise.
    assert {s.cw for s in forward.segments if isinstance(s, Arc)} == {False}
    assert {s.cw for s in backward.segments if isinstance(s, Arc)} == {True}
    # The reversed car starts with the front wheel.
    assert backward.strokes[0] == forward.strokes[2].reversed()
    assert backward.strokes[0].start[0] > forward.strokes[1].start[0]
    # Forward G-code and reversed G-code draw the same arcs in opposite directions.
    fwd = figure_to_gcode(forward, 1500, "car")
    bwd = figure_to_gcode(backward, 1500, "car reversed")
    assert sum(g.startswith("G3 ") for g in fwd) == sum(g.startswith("G2 ") for g in bwd) == 3
    assert not any(g.startswith("G2 ") for g in fwd)
    assert not any(g.startswith("G3 ") for g in bwd)


def test_car_shape():
    size = 80.0
    figure = car(100, 100, size)
    body, rear, front = figure.strokes
    box = bounding_box(figure)
    assert box.width == pytest.approx(size)
    assert box.height == pytest.approx(0.58 * size)
    assert box.centre == pytest.approx((100.0, 100.0))
    assert body.start == body.end
    assert [type(s).__name__ for s in body.segments] == ["Line", "Line", "Line", "Arc", "Line", "Line"]
    for wheel in (rear, front):
        (seg,) = wheel.segments
        assert seg.is_full_circle
        assert seg.radius == pytest.approx(0.11 * size)
        assert seg.cy - seg.radius == pytest.approx(box.ymin)  # touches the ground
        assert seg.start == (seg.cx + seg.radius, seg.cy)
    assert rear.segments[0].cx < front.segments[0].cx


def test_cone_shape_and_direction():
    size = 40.0
    cw = cone(100, 100, size, clockwise=True)
    ccw = cone(100, 100, size, clockwise=False)
    for figure, want_cw in ((cw, True), (ccw, False)):
        (stroke,) = figure.strokes
        kinds = [type(s).__name__ for s in stroke.segments]
        assert kinds == ["Line", "Line", "Arc", "Arc"]
        assert all(s.cw is want_cw for s in stroke.segments if isinstance(s, Arc))
        box = bounding_box(figure)
        assert box.width == pytest.approx(size)
        assert box.height == pytest.approx(1.35 * size)
        assert box.centre == pytest.approx((100.0, 100.0))
        apex = stroke.segments[0].end
        assert apex == pytest.approx((100.0, box.ymax))
        # Isosceles: both slant sides equally long.
        assert stroke.segments[0].length == pytest.approx(stroke.segments[1].length)
        front, back = stroke.segments[2], stroke.segments[3]
        assert front.cy > front.y0 and back.cy < back.y0  # front bulges down, back up
    # Clockwise starts at the left base corner, counter-clockwise at the right one.
    assert cw.start[0] < 100 < ccw.start[0]


def test_diamond_shape():
    figure = diamond(50, 60, 30)
    (stroke,) = figure.strokes
    lengths = [s.length for s in stroke.segments]
    assert lengths == pytest.approx([lengths[0]] * 4)
    box = bounding_box(figure)
    assert (box.width, box.height) == pytest.approx((30.0, 45.0))
    assert box.centre == pytest.approx((50.0, 60.0))
    # One line in each quadrant of the seed's line interpolation.
    quadrants = {(s.x1 - s.x0 > 0, s.y1 - s.y0 > 0) for s in stroke.segments}
    assert len(quadrants) == 4


# --- continuity and arc consistency ----------------------------------------------


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_strokes_are_continuous_and_arcs_consistent(name):
    figure = FIGURES[name]
    assert figure.strokes
    for stroke in figure.strokes:
        for prev, seg in zip(stroke.segments, stroke.segments[1:]):
            assert seg.start == pytest.approx(prev.end, abs=1e-9)
        for seg in stroke.segments:
            if isinstance(seg, Arc):
                r0 = math.hypot(seg.x0 - seg.cx, seg.y0 - seg.cy)
                r1 = math.hypot(seg.x1 - seg.cx, seg.y1 - seg.cy)
                assert abs(r0 - r1) <= 1e-9
                assert r0 > 0


@pytest.mark.parametrize("name", ["diamond", "star", "cone", "car"])
def test_figures_are_centred_on_the_anchor_with_the_given_width(name):
    figure = build_shape(name, 37.5, 142.25, 55.0)
    box = bounding_box(figure)
    assert box.centre == pytest.approx((37.5, 142.25))
    assert box.width == pytest.approx(55.0)


def test_stroke_rejects_gaps_and_arc_rejects_unequal_radii():
    with pytest.raises(ValueError):
        Stroke((Line(0, 0, 1, 0), Line(2, 0, 3, 0)))
    with pytest.raises(ValueError):
        Arc(10, 0, 0, 11, 0, 0, False)
    with pytest.raises(ValueError):
        Stroke(())


def test_translate_moves_everything():
    figure = translate(car(0, 0, 50), 10, -5)
    assert bounding_box(figure).centre == pytest.approx((10.0, -5.0))


# --- G-code -------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(FIGURES))
def test_gcode_reads_back_as_the_figure(name):
    figure = FIGURES[name]
    gcode = figure_to_gcode(figure, 1500, name)
    assert gcode[0] == f"({name})"
    assert gcode[1] == "G21 G90"
    assert gcode[-2:] == ["M5", "M2"]
    assert gcode.count("M3") == len(figure.strokes)
    assert sum(g.startswith("G0 ") for g in gcode) == len(figure.strokes)
    moves, pen_down = read_gcode(gcode)
    assert not pen_down
    expected = [segment_tuple(s) for s in figure.segments]
    assert len(moves) == len(expected)
    for got, want in zip(moves, expected):
        assert got[0] == want[0]
        assert got[1:7 if got[0] == "arc" else 5] == pytest.approx(want[1:7 if want[0] == "arc" else 5], abs=1e-4)
        if got[0] == "arc":
            assert got[7] is want[7]
    for text in gcode:
        # 4 decimals on every number, no "-0.0000".
        for _, number in WORD.findall(text):
            if "." in number:
                assert len(number.split(".")[1]) == 4
            assert number != "-0.0000"


@pytest.mark.parametrize("name", ["car", "cone"])
def test_car_and_cone_use_native_arcs(name):
    for clockwise in (False, True):
        gcode = figure_to_gcode(build_shape(name, clockwise=clockwise), 1500, name)
        assert any(re.match(r"^G[23] ", g) for g in gcode)
        assert any(g.startswith("G1 ") for g in gcode)


def test_gcode_layout_of_a_diamond():
    gcode = figure_to_gcode(diamond(0, 0, 20), 900, "diamond")
    assert gcode == [
        "(diamond)",
        "G21 G90",
        "M5",
        "G0 X10.0000 Y0.0000",
        "M3",
        "G1 X0.0000 Y15.0000 F900.0000",
        "G1 X-10.0000 Y0.0000 F900.0000",
        "G1 X0.0000 Y-15.0000 F900.0000",
        "G1 X10.0000 Y0.0000 F900.0000",
        "M5",
        "M2",
    ]


def test_gcode_name_is_sanitised_and_optional():
    figure = circle(0, 0, 5)
    assert figure_to_gcode(figure, 100, "a(b)c;d\n")[0] == "(abcd)"
    assert figure_to_gcode(figure, 100, "")[0] == "G21 G90"


@pytest.mark.parametrize("feed", [0, -1, float("nan"), float("inf"), 1e9])
def test_gcode_rejects_bad_feeds(feed):
    with pytest.raises(ShapeError) as err:
        figure_to_gcode(circle(0, 0, 5), feed, "x")
    assert err.value.field == "feed"
    assert str(err.value).startswith("feed:")


# --- dispatcher and validation -----------------------------------------------------


def test_build_shape_dispatches_every_name():
    for name in SHAPE_NAMES:
        figure = build_shape(name, 100, 100, 30, x2=150, y2=150, start_angle=0, end_angle=90)
        assert figure.name == name
    assert build_shape(" Star ", 100, 100, 30) == star(100, 100, 30)
    assert build_shape("circle", 10, 20, 5, clockwise=True) == circle(10, 20, 5, True)
    assert build_shape("arc", 10, 20, 5, True, False, 0, 0, 0, 30, 60) == arc(10, 20, 5, 30, 60, True)
    assert build_shape("line", 1, 2, 0, x2=3, y2=4) == line(1, 2, 3, 4)
    assert build_shape("cone", 1, 2, 30, clockwise=True, reverse=True) == reverse(cone(1, 2, 30, True))


def test_build_shape_defaults():
    figure = build_shape("star")
    box = bounding_box(figure)
    assert box.centre == pytest.approx(DEFAULT_CENTRE_MM)
    assert box.width == pytest.approx(DEFAULT_SIZE_MM)
    assert DEFAULT_CENTRE_MM == (100.0, 100.0)
    # Zero size means "not given"; x = y = 0 given explicitly stays at the origin.
    figure = build_shape("diamond", 0, 0, 0)
    assert bounding_box(figure).centre == pytest.approx((0.0, 0.0))
    assert bounding_box(figure).width == pytest.approx(DEFAULT_SIZE_MM)


def test_resolve_placement_rule():
    assert resolve_placement("star", 0, 0, 0) == (100.0, 100.0, 40.0)
    assert resolve_placement("star", 0, 0, 0, default_size=25, default_centre=(5, 6)) == (5, 6, 25)
    assert resolve_placement("star", 0, 0, 30) == (100.0, 100.0, 30)
    assert resolve_placement("star", 10, 0, 0) == (10, 0, 40.0)
    assert resolve_placement("line", 0, 0, 0)[:2] == (0, 0)
    x, y, size = resolve_placement("star", 0, 0, float("nan"))
    assert math.isnan(size)


@pytest.mark.parametrize(
    "kwargs,field",
    [
        ({"name": "hexagon"}, "shape"),
        ({"name": ""}, "shape"),
        ({"name": 3}, "shape"),
        ({"name": "star", "size": float("nan")}, "size"),
        ({"name": "star", "size": float("inf")}, "size"),
        ({"name": "star", "size": -5}, "size"),
        ({"name": "star", "size": 0.2}, "size"),
        ({"name": "circle", "size": 1000.5}, "size"),
        ({"name": "star", "size": 20, "x": float("nan")}, "x"),
        ({"name": "star", "size": 20, "y": float("-inf")}, "y"),
        ({"name": "star", "size": 20, "x": 1e7}, "x"),
        ({"name": "star", "size": 20, "feed": -100}, "feed"),
        ({"name": "star", "size": 20, "feed": float("nan")}, "feed"),
        ({"name": "line", "x": 1, "y": 1, "x2": float("nan")}, "x2"),
        ({"name": "line", "x": 1, "y": 1, "x2": 1, "y2": 1}, "x2"),
        ({"name": "arc", "size": 10, "start_angle": float("inf")}, "start_angle"),
        ({"name": "arc", "size": 10, "end_angle": float("nan")}, "end_angle"),
        ({"name": "star", "size": "big"}, "size"),
    ],
)
def test_bad_inputs_raise_shape_error_naming_the_field(kwargs, field):
    with pytest.raises(ShapeError) as err:
        build_shape(**kwargs)
    assert err.value.field == field
    assert str(err.value).startswith(field + ":")


@pytest.mark.parametrize("builder", [diamond, star, car, lambda x, y, s: cone(x, y, s, True)])
@pytest.mark.parametrize("size", [0, -1, 2000, float("nan")])
def test_builders_reject_bad_sizes(builder, size):
    with pytest.raises(ShapeError) as err:
        builder(0, 0, size)
    assert err.value.field == "size"


def test_figure_is_immutable_and_comparable():
    figure = Figure([Stroke([Line(0, 0, 1, 1)])], "x")
    assert isinstance(figure.strokes, tuple)
    assert figure == Figure((Stroke((Line(0, 0, 1, 1),)),), "x")
    with pytest.raises(AttributeError):
        figure.name = "y"  # type: ignore[misc]


def test_goal_program_applies_the_message_defaults():
    name, gcode = goal_program("Star", 0.0, 0.0, 0.0)
    assert name == "star"
    assert gcode == figure_to_gcode(star(100, 100, 40), 1500, "star")
    name, gcode = goal_program(
        "car", 50.0, 60.0, 30.0, False, True, 900.0, default_feed=1200, default_size=10
    )
    assert name == "car reversed"
    assert gcode == figure_to_gcode(reverse(car(50, 60, 30)), 900, "car reversed")
    _, gcode = goal_program("circle", 0.0, 0.0, 0.0, default_size=25, default_centre=(70, 80))
    assert "G0 X95.0000 Y80.0000" in gcode
    with pytest.raises(ShapeError) as err:
        goal_program("hexagon", 0.0, 0.0, 0.0)
    assert err.value.field == "shape"
    with pytest.raises(ShapeError) as err:
        goal_program("star", 0.0, 0.0, float("nan"))
    assert err.value.field == "size"
