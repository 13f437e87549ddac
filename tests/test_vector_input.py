"""SVG drawings and Hershey text to programs (plotter_shapes.svg_input, text_input; `plotter svg`, `plotter text`)."""
import math

import pytest

from gcode_testlib import move_points
from plotter_bridge.gcode.parser import moves_of, parse
from plotter_shapes.svg_input import Placement, VectorError, svg_program
from plotter_shapes.text_input import text_program

# 100 x 60 mm (viewBox units are mm): a line, a circle, a cubic curve, and a path with a line, an arc, a line.
SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="60mm" viewBox="0 0 100 60">
<line x1="5" y1="5" x2="45" y2="5" stroke="black"/>
<circle cx="70" cy="30" r="15" stroke="black" fill="none"/>
<path d="M 5 55 C 20 20, 35 60, 50 30" stroke="black" fill="none"/>
<g transform="translate(0 2)"><path d="M 10 20 L 20 20 A 5 5 0 0 1 30 20 L 30 30" stroke="black" fill="none"/></g>
</svg>
"""
CENTRE = (100.0, 100.0)


def to_plotter(x, y, width=100.0):
    """An SVG point (mm, y down) where `plotter svg --width` puts it: centred on CENTRE, y up."""
    s = width / 80.0             # the drawing's bounding box is x 5..85, y 5..55 (the circle reaches 85)
    return CENTRE[0] + (x - 45.0) * s, CENTRE[1] - (y - 30.0) * s


def cubic(t):
    p = [(5, 55), (20, 20), (35, 60), (50, 30)]
    b = [(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t * t * (1 - t), t ** 3]
    return sum(w * q[0] for w, q in zip(b, p)), sum(w * q[1] for w, q in zip(b, p))


def reference_points(width=100.0, n=400):
    """Points on every figure of SVG, in plotter mm."""
    pts = [to_plotter(5 + 40 * k / n, 5, width) for k in range(n + 1)]
    pts += [to_plotter(70 + 15 * math.cos(2 * math.pi * k / n), 30 + 15 * math.sin(2 * math.pi * k / n), width)
            for k in range(n)]
    pts += [to_plotter(*cubic(k / n), width) for k in range(n + 1)]
    pts += [to_plotter(10 + 10 * k / n, 22, width) for k in range(n + 1)]
    pts += [to_plotter(25 - 5 * math.cos(math.pi * k / n), 22 - 5 * math.sin(math.pi * k / n), width)
            for k in range(n + 1)]
    pts += [to_plotter(30, 22 + 10 * k / n, width) for k in range(n + 1)]
    return pts


def near(points, targets, tol):
    """Every target within tol of some point."""
    from scipy.spatial import cKDTree
    dist, _ = cKDTree(points).query(targets)
    assert dist.max() <= tol, f"{dist.max():.4f} mm off"


@pytest.fixture
def drawing(tmp_path):
    path = tmp_path / "drawing.svg"
    path.write_text(SVG)
    return str(path)


def test_circles_and_arcs_stay_arcs_curves_become_arcs_too(drawing):
    program = svg_program(drawing, Placement(width=100.0, centre=CENTRE))
    moves = [m for m in moves_of(parse("\n".join(program))) if not m.rapid and m.pen == "down"]
    arcs = [m for m in moves if m.kind == "arc"]
    circles = [m for m in arcs if m.is_full_circle]
    assert len(circles) == 1
    circle = circles[0]
    assert (circle.cx, circle.cy) == pytest.approx(to_plotter(70, 30), abs=1e-4)
    assert math.hypot(circle.sx - circle.cx, circle.sy - circle.cy) == pytest.approx(15.0 * 1.25, abs=1e-4)
    half = [m for m in arcs if not m.is_full_circle and math.dist((m.cx, m.cy), to_plotter(25, 22)) < 1e-3][0]
    assert (half.cx, half.cy) == pytest.approx(to_plotter(25, 22), abs=1e-4)
    assert (half.sx, half.sy) == pytest.approx(to_plotter(20, 22), abs=1e-4)
    assert (half.x, half.y) == pytest.approx(to_plotter(30, 22), abs=1e-4)
    assert half.cw                                # over the top, left to right
    on_cubic = [m for m in moves if m not in (circle, half) and m.sy < to_plotter(0, 29)[1]]
    assert 4 <= len(on_cubic) <= 30                # the cubic: a few arcs (and lines), not hundreds of chords
    assert sum(m.kind == "arc" for m in on_cubic) >= len(on_cubic) // 2
    drawn = [p for m in moves for p in move_points(m)]
    near(drawn, reference_points(), 0.01)         # every figure is drawn ...
    near(reference_points(n=20000), drawn, 0.01)  # ... and nothing else


def test_width_scales_and_optimize_shortens_travel(tmp_path, drawing):
    small = svg_program(drawing, Placement(width=50.0, centre=CENTRE))
    moves = [m for m in moves_of(parse("\n".join(small))) if not m.rapid and m.pen == "down"]
    near([p for m in moves for p in move_points(m)], reference_points(width=50.0), 0.01)
    scattered = tmp_path / "scattered.svg"
    scattered.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">'
                         + "".join(f'<line x1="{x}" y1="10" x2="{x}" y2="{y}" stroke="black"/>'
                                   for x, y in [(10, 50), (90, 50), (20, 60), (80, 60), (30, 70), (70, 70)])
                         + '<line x1="50" y1="80" x2="50" y2="90"/><line x1="50" y1="90" x2="60" y2="90"/></svg>')

    def travel(program):
        ms = moves_of(parse("\n".join(program)))
        return sum(math.hypot(m.x - m.sx, m.y - m.sy) for m in ms if m.rapid), \
            sum(1 for line in program if line == "M3")
    plain, opt = (travel(svg_program(str(scattered), optimize_paths=o)) for o in (False, True))
    assert opt[0] < 0.7 * plain[0]
    assert opt[1] == plain[1] - 1                  # the two touching lines became one stroke


def test_text_in_a_hershey_font():
    program = text_program("HELLO", size_mm=20.0, placement=Placement(centre=(60.0, 40.0)))
    moves = [m for m in moves_of(parse("\n".join(program))) if not m.rapid and m.pen == "down"]
    xs = [v for m in moves for v in (m.sx, m.x)]
    ys = [v for m in moves for v in (m.sy, m.y)]
    assert (min(xs) + max(xs)) / 2 == pytest.approx(60.0, abs=1e-3)
    assert (min(ys) + max(ys)) / 2 == pytest.approx(40.0, abs=1e-3)
    assert 40 < max(xs) - min(xs) < 80 and 10 < max(ys) - min(ys) < 20
    assert sum(1 for line in program if line == "M3") >= 9      # H 3, E 4, L 2 x 2, O 1 strokes, about
    assert text_program("HELLO", size_mm=20.0) != text_program("HELLO", "scripts", size_mm=20.0)
    with pytest.raises(VectorError):
        text_program("HELLO", font="nosuchfont")
    with pytest.raises(VectorError):
        text_program("   ")


def test_not_an_svg(tmp_path):
    bad = tmp_path / "bad.svg"
    bad.write_text("this is not xml")
    with pytest.raises(VectorError):
        svg_program(str(bad))


@pytest.mark.ros
def test_plotter_svg_and_text_draw_on_the_mock_board(tmp_path, drawing):
    from ros_graph import read_trace
    from test_plotter_cli import plotter
    trace = tmp_path / "trace.csv"
    r = plotter("svg", drawing, "--width", "100", "--feed", "4000", "--optimize", "--mock", "--quiet",
                "--trace", trace, "--gcode", tmp_path / "out.gcode")
    assert r.returncode == 0, r.stderr
    steps = [(x / 80.0, y / 80.0) for _, x, y in read_trace(trace)]
    near(steps, reference_points(), 0.03)          # every figure was drawn, to within a few steps
    program = (tmp_path / "out.gcode").read_text()
    arcs = sum(1 for line in program.splitlines() if line.startswith(("G2 ", "G3 ")))
    lines = sum(1 for line in program.splitlines() if line.startswith("G1 "))
    assert arcs >= 10 and lines <= 4, (arcs, lines)     # the circle, the half circle, the cubic's arcs
    r = plotter("text", "HI", "--size", "15", "--feed", "4000", "--mock", "--quiet", "--trace", trace,
                "--gcode", tmp_path / "hi.gcode")
    assert r.returncode == 0, r.stderr
    xs = [x for _, x, _ in read_trace(trace)]
    assert len(xs) > 1000
    # The board stepped the text's program, all of it, as the firmware core steps it from the origin.
    from plotter_bridge.motion.compiler import StreamerConfig
    from plotter_bridge.sim.expected import drawn_whole, program_steps
    expected = program_steps((tmp_path / "hi.gcode").read_text(), StreamerConfig())
    assert drawn_whole([(x, y) for _, x, y in read_trace(trace)], expected, (0, 0), 80.0) == ""
    r = plotter("svg", tmp_path / "missing.svg", "--mock")
    assert r.returncode == 2
