"""The `plotter` command as a user runs it (installed in .venv/bin by setup.sh)."""
import json
import math
import os
import subprocess
from pathlib import Path

import pytest

from node_processes import new_domain
from ros_graph import read_trace

REPO = Path(__file__).resolve().parent.parent
PLOTTER = REPO / ".venv" / "bin" / "plotter"

pytestmark = pytest.mark.ros


def plotter(*args, timeout=600):
    if not PLOTTER.exists():
        pytest.fail("the plotter command is missing: run scripts/setup.sh")
    env = dict(os.environ, ROS_DOMAIN_ID=str(new_domain()))
    return subprocess.run([str(PLOTTER), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env)


def test_stream_2000_lines_on_the_mock_board_ends_exact_to_the_step(tmp_path):
    lines, x, y = ["G21 G90", "G0 X20 Y20", "M3"], 20.0, 20.0
    for k in range(1997):
        a = k * 0.61
        x = min(180.0, max(20.0, x + 0.6 * math.cos(a)))
        y = min(180.0, max(20.0, y + 0.6 * math.sin(a) + 0.03))
        lines.append(f"G1 X{x:.3f} Y{y:.3f} F6000")
    lines += ["M5", "M2"]
    program = tmp_path / "walk.gcode"
    program.write_text("\n".join(lines) + "\n")
    assert len(lines) == 2002
    trace = tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--trace", trace)
    assert r.returncode == 0, r.stderr
    assert "done" in r.stdout
    last = read_trace(trace)[-1]
    assert last[1:] == (round(x * 80), round(y * 80))
    check = plotter("check", program, "--json")
    final = json.loads(check.stdout.splitlines()[-1])
    assert (round(final["x"] * 80), round(final["y"] * 80)) == last[1:]


def test_draw_a_shape_on_the_mock_board(tmp_path):
    trace = tmp_path / "trace.csv"
    r = plotter("draw", "circle", "--size", "20", "--x", "50", "--y", "50", "--ccw", "--mock",
                "--trace", trace, "--quiet")
    assert r.returncode == 0, r.stderr
    steps = read_trace(trace)
    start = [k for k, row in enumerate(steps) if row[1:] == (5600, 4000)][0]   # pen-up travel ends here
    radii = [math.hypot(sx - 4000, sy - 4000) for _, sx, sy in steps[start:]]
    assert len(radii) > 8 * 1600
    assert max(abs(rr - 1600) for rr in radii) <= 1.0
    assert steps[-1][1:] == (5600, 4000)


def test_bad_program_exits_non_zero_and_starts_nothing(tmp_path):
    program = tmp_path / "bad.gcode"
    program.write_text("G21\nG1 X10 F100\nG7 X3\n")
    trace = tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--trace", trace)
    assert r.returncode == 2
    assert "line 3" in r.stderr
    assert not trace.exists()


def test_out_of_area_program_is_refused_before_motion(tmp_path):
    program = tmp_path / "far.gcode"
    program.write_text("G21 G90\nG1 X10 Y10 F3000\nG1 X250 Y10\nM2\n")
    trace = tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--trace", trace, "--quiet")
    assert r.returncode == 1
    assert "line 3" in r.stderr and "work area" in r.stderr
    assert read_trace(trace) == []


def test_stream_on_the_hanging_machine(tmp_path):
    program = tmp_path / "hang.gcode"
    program.write_text("G21 G90\nG0 X300 Y300\nM3\nG1 X500 Y300 F6000\nG3 X500 Y300 I-100 J0\nM5\nM2\n")
    trace = tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--machine", "hanging", "--trace", trace, "--quiet")
    assert r.returncode == 0, r.stderr
    rows = trace.read_text().splitlines()[1:]
    x, y = (float(v) / 80 for v in rows[-1].split(",")[1:])   # pen mm times steps_per_mm
    assert math.hypot(x - 500, y - 300) < 0.05
    # The circle drawn from the line's end all the way round, not only ended where it starts.
    from test_hanging_graph import largest_gap_deg
    pen = [tuple(float(v) / 80 for v in row.split(",")[1:]) for row in rows]
    start = next(k for k, (px, py) in enumerate(pen) if math.hypot(px - 500, py - 300) < 0.05)
    assert max(abs(math.hypot(px - 400, py - 300) - 100) for px, py in pen[start:]) <= 0.1
    assert largest_gap_deg(pen[start:], (400, 300)) < 0.5


def test_stream_with_a_z_axis_on_the_mock_board(tmp_path):
    from firmware_build import host_library
    host_library(ZAXIS="1")                     # the mock board's core with a Z axis
    program = tmp_path / "engrave.gcode"
    program.write_text("G21 G90\nG0 X10 Y10 Z2\nG1 Z-0.5 F300\nG1 X30 Y20 F1200\nG2 X50 Y20 I10 J0\n"
                       "G0 Z2\nG0 X60 Y60 Z-1\nG1 X70\nG0 Z5\nM2\n")
    trace = tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--z-axis", "--trace", trace, "--quiet")
    assert r.returncode == 0, r.stderr
    assert "X70.000 Y60.000 Z5.000 mm" in r.stdout
    rows = read_trace(trace, z=True)
    assert rows[-1][1:] == (70 * 80, 60 * 80, 5 * 400)
    # X and Y move only with Z at rest where the program puts it: up for the
    # travel, down for the cuts; the first cut, line and arc, on its path.
    moved = [(x, y, z) for (_, px, py, _), (_, x, y, z) in zip(rows, rows[1:]) if (x, y) != (px, py)]
    assert {z for _, _, z in moved} == {2 * 400, -200, -400}
    cut = [(x, y) for x, y, z in moved if z == -200]
    assert cut[-1] == (50 * 80, 20 * 80)
    for x, y in cut:
        on_line = abs((x - 800) * 800 - (y - 800) * 1600) / math.hypot(1600, 800) <= 1.0 and x <= 2400
        on_arc = abs(math.hypot(x - 3200, y - 1600) - 800) <= 1.0
        assert on_line or on_arc, (x, y)
    assert sum(1 for x, y in cut if y > 1600) > 1000         # the arc, clockwise over the top


def test_helix_with_a_z_axis_is_refused_before_anything_starts(tmp_path):
    program = tmp_path / "helix.gcode"
    program.write_text("G21 G90\nG0 X50 Y50\nG1 Z-1 F300\nG2 X60 Y50 I5 J0 Z-2\n")
    trace = tmp_path / "trace.csv"
    r = plotter("stream", program, "--mock", "--z-axis", "--trace", trace, "--quiet")
    assert r.returncode == 2
    assert "line 4" in r.stderr and "helical arc" in r.stderr
    assert not trace.exists()
