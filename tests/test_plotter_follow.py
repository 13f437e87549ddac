"""`plotter follow` as a user runs it (installed in .venv/bin by setup.sh):
on a mock board with a sheet, the pen goes up to the start, follows the
line, and the command says why it stopped and whether the pen stayed on
the black; bad goals are refused with every reason before anything runs."""
import math

import pytest

from follow_lines import distances, path_length
from plotter_bridge.cli.main import main
from ros_graph import read_trace
from test_plotter_cli import plotter

SPM = 80.0
CIRCLE = "G21 G90\nG0 X112 Y100\nM3\nG3 X112 Y100 I-12 J0 F600\nM5\n"   # r12 round (100, 100)
LINE_END = "G21 G90\nG0 X40 Y60\nM3\nG1 X70 Y60 F600\nM5\n"
# A ring 24 mm across drawn in Inkscape's way, 40 mm square: placed as `plotter svg` places a
# drawing (its own size, centred on 100, 100), its paths are the r12 circle round (100, 100).
CIRCLE_SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">
  <circle cx="20" cy="20" r="12" fill="none" stroke="black" stroke-width="7"/>
</svg>
"""


def circle_points(n: int = 720):
    return [(100.0 + 12.0 * math.cos(2 * math.pi * k / n), 100.0 + 12.0 * math.sin(2 * math.pi * k / n))
            for k in range(n + 1)]


@pytest.mark.ros
@pytest.mark.parametrize("name, text", [("circle.svg", CIRCLE_SVG), ("circle.gcode", CIRCLE)], ids=["svg", "gcode"])
def test_follow_on_the_mock_goes_once_round_the_sheets_circle(tmp_path, name, text):
    sheet = tmp_path / name
    sheet.write_text(text)
    trace = tmp_path / "trace.csv"
    r = plotter("follow", "--mock", "--sheet", sheet, "--start", 112, 100, "--heading", 90, "--trace", trace)
    assert r.returncode == 0, r.stderr
    assert "follow: home after" in r.stdout and "stayed on the line all the way" in r.stdout, r.stdout
    steps = [(x / SPM, y / SPM) for _, x, y in read_trace(trace)]
    start = next(k for k, p in enumerate(steps) if p == (112.0, 100.0))     # the pen-up move ends there
    followed = steps[start:]
    assert 0.98 <= path_length(followed) / (2 * math.pi * 12.0) <= 1.15
    assert distances(followed[::4], [circle_points()]).max() < 3.5
    assert math.dist(followed[-1], (112.0, 100.0)) <= 4.5


@pytest.mark.ros
def test_follow_says_where_a_line_was_lost_and_fails(tmp_path):
    sheet = tmp_path / "line.gcode"
    sheet.write_text(LINE_END)
    r = plotter("follow", "--mock", "--sheet", sheet, "--start", 40, 60, "--lost", 1)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "follow: lost after" in r.stderr, r.stderr
    x = float(r.stderr.split("pen at X")[1].split()[0])
    assert abs(x - 70.0) <= 3.0 + 1.0                 # the line's end, within the sensors' reach and the lost mm


@pytest.mark.parametrize("args, why", [
    (["--mock", "--start", "1", "2"], "needs --sheet"),
    (["--start", "1", "2", "--steps-per-mm", "100"], "--steps-per-mm: only with --port or --mock"),
    (["--port", "/dev/null", "--sheet", "x.gcode", "--start", "1", "2"], "--sheet goes with --mock"),
    (["--mock", "--sheet", "x.gcode", "--start", "1", "2", "--machine", "hanging"], "XY table only"),
    (["--mock", "--sheet", "/nonexistent.gcode", "--start", "1", "2"], "No such file"),
    (["--mock", "--sheet", "x.gcode", "--start", "1", "2", "--width", "5"], "wider than 6 mm"),
    (["--mock", "--sheet", "x.gcode", "--start", "1", "2", "--feed", "9", "--lost", "-1", "--gate", "900"],
     "feed 9 mm/s is 720 steps/s"),
])
def test_bad_follows_are_refused_before_anything_starts(tmp_path, capsys, args, why):
    (tmp_path / "x.gcode").write_text(CIRCLE)
    args = [str(tmp_path / a) if a == "x.gcode" else a for a in args]
    assert main(["follow", *args]) == 2
    err = capsys.readouterr().err
    assert why in err, err
    if "feed" in why:
        assert "lost distance" in err and "gate 900 mm" in err
