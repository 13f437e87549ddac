"""Pictures of what was drawn (plotter_bridge.cli.picture, `plotter stream/draw --svg/--png`)."""
import math
import re
import xml.etree.ElementTree as ET

import pytest

from plotter_bridge.cli.picture import (Area, Run, draw, figure_polylines, mm_to_pixel, program_polylines,
                                    runs_by_pen, runs_near_path, write_picture)

SVG_NS = "{http://www.w3.org/2000/svg}"
PROGRAM = "G21 G90\nG0 X20 Y20\nM3\nG1 X60 Y20 F3000\nG2 X60 Y60 I0 J20\nG1 X20 Y20\nM5\nG0 X0 Y0\nM2\n"


def svg_group_points(path, gid):
    """Vertices (SVG user units) of the paths in the group with this id."""
    root = ET.parse(path).getroot()
    assert root.tag == SVG_NS + "svg"
    groups = [g for g in root.iter(SVG_NS + "g") if g.get("id") == gid]
    assert len(groups) == 1, f"one group {gid!r}"
    pts = []
    for p in groups[0].iter(SVG_NS + "path"):
        nums = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", p.get("d"))]
        pts += list(zip(nums[0::2], nums[1::2]))
    return pts


def test_program_polylines_follow_the_parsed_moves():
    lines = program_polylines(PROGRAM)
    assert len(lines) == 1                       # one pen-down stroke; travel left out
    pts = lines[0]
    assert pts[0] == (20.0, 20.0) and pts[-1] == (20.0, 20.0)
    on_arc = [p for p in pts if abs(math.hypot(p[0] - 60, p[1] - 40) - 20) < 1e-9]
    assert len(on_arc) > 100
    assert all(p[0] <= 60 + 1e-9 for p in on_arc)    # G2 from the bottom: the left half


def test_runs_split_drawn_from_travel():
    programmed = [[(10.0, 10.0), (50.0, 10.0)]]
    trace = [(0.0, 0.0), (5.0, 5.0), (10.0, 10.0), (30.0, 10.0), (50.0, 10.0), (60.0, 20.0)]
    runs = runs_near_path(trace, programmed, spacing_mm=0.0)
    assert [r.drawn for r in runs] == [False, True, False]
    assert runs[0].points[-1] == (10.0, 10.0) and runs[1].points == ((10.0, 10.0), (30.0, 10.0), (50.0, 10.0))
    assert runs_by_pen([(0, 0, False), (1, 0, True), (2, 0, True), (3, 0, False)]) == [
        Run(False, ((0, 0), (1, 0))), Run(True, ((1, 0), (2, 0))), Run(False, ((2, 0), (3, 0)))]


def test_area_grows_only_for_points_outside():
    assert Area().including([(10, 10), (190, 0)]) == Area()
    assert Area().including([(-3, 10), (250, 10)]) == Area(-8, 255, 0, 200)


def check_svg_matches(path, runs, fig, dpi=100.0):
    """The 'drawn' group's vertices are the drawn runs' points, where the axes put them."""
    got = svg_group_points(path, "drawn")
    want = [p for r in runs if r.drawn for p in r.points]
    assert len(got) == len(want) > 0
    for (sx, sy), p in zip(got, want):
        px, py = mm_to_pixel(fig, p)
        assert abs(sx * dpi / 72 - px) < 0.05 and abs(sy * dpi / 72 - py) < 0.05
    assert svg_group_points(path, "programmed")


def check_png_matches(path, runs, fig, size):
    from PIL import Image
    with Image.open(path) as im:
        im.verify()
    with Image.open(path) as im:
        assert im.format == "PNG" and im.size == size
        rgb = im.convert("RGB")
        drawn = [p for r in runs if r.drawn for p in r.points]
        for p in drawn[:: max(1, len(drawn) // 200)]:
            x, y = mm_to_pixel(fig, p)
            near = [rgb.getpixel((int(x) + dx, int(y) + dy)) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
            assert min(sum(c) for c in near) < 400, f"no dark pixel at {p} mm"   # blue is 594


def test_pictures_of_a_figure_show_the_trace(tmp_path):
    from plotter_shapes.geometry import build_shape
    programmed = figure_polylines(build_shape("star", 100, 100, 60, False, False))
    trace = [(0.0, 0.0), (50.0, 50.0)] + [p for line in programmed for p in line]
    runs = runs_near_path(trace, programmed)
    fig = draw(runs, programmed)
    svg, png = tmp_path / "a.svg", tmp_path / "a.png"
    write_picture(str(svg), runs, programmed)
    write_picture(str(png), runs, programmed)
    check_svg_matches(svg, runs, fig)
    check_png_matches(png, runs, fig, (int(fig.bbox.width), int(fig.bbox.height)))
    write_picture(str(tmp_path / "b.svg"), runs, programmed)
    assert svg.read_bytes() == (tmp_path / "b.svg").read_bytes()     # reproducible
    with pytest.raises(ValueError):
        write_picture(str(tmp_path / "a.jpg"), runs, programmed)


@pytest.mark.ros
def test_plotter_stream_writes_pictures_of_the_trace(tmp_path):
    from ros_graph import read_trace
    from test_plotter_cli import plotter
    program = tmp_path / "p.gcode"
    program.write_text(PROGRAM)
    svg, png, trace = tmp_path / "out.svg", tmp_path / "out.png", tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--quiet", "--trace", trace, "--svg", svg, "--png", png)
    assert r.returncode == 0, r.stderr
    steps = read_trace(trace)
    assert steps[-1][1:] == (0, 0)
    programmed = program_polylines(PROGRAM)
    runs = runs_near_path([(x / 80, y / 80) for _, x, y in steps], programmed)
    assert sum(len(r.points) for r in runs if r.drawn) > 300
    fig = draw(runs, programmed)
    check_svg_matches(svg, runs, fig)
    check_png_matches(png, runs, fig, (int(fig.bbox.width), int(fig.bbox.height)))
    r = plotter("stream", program, "--mock", "--quiet", "--png", tmp_path / "x.jpg")
    assert r.returncode == 2 and ".png" in r.stderr


def test_stream_pictures_frame_the_work_area_and_none_without_a_move(tmp_path, monkeypatch):
    """--area -150 150 -110 110: the frame is that area, not grown from 0..200; a board that did not
    move (a refused program) gets no picture at all."""
    import argparse
    import io
    from plotter_bridge.cli import picture, run
    frames = []
    monkeypatch.setattr(picture, "write_picture", lambda path, runs, programmed, area, title: frames.append(area))
    trace = tmp_path / "trace.csv"
    trace.write_text("t_s,x_steps,y_steps\n0.0,80,0\n0.1,160,0\n")
    args = argparse.Namespace(area=[-150.0, 150.0, -110.0, 110.0], machine="cartesian", steps_per_mm=80.0,
                              svg=str(tmp_path / "p.svg"), png="", dialect=None)
    err = io.StringIO()
    run.write_pictures(args, "G21 F100\nM3\nG1 X2\n", "p", (0.0, 0.0), str(trace), [], err)
    assert frames == [Area(-150.0, 150.0, -110.0, 110.0)] and "picture: " in err.getvalue()
    trace.write_text("t_s,x_steps,y_steps\n")
    err = io.StringIO()
    run.write_pictures(args, "G21 F100\nM3\nG1 X2\n", "p", (0.0, 0.0), str(trace), [], err)
    assert len(frames) == 1 and err.getvalue() == "no picture: the board did not move for p\n"
