"""The `plotter` command as a user runs it (installed in .venv/bin by setup.sh)."""
import json
import math
import os
import random
import subprocess
from pathlib import Path

import pytest

from ros_graph import read_trace

REPO = Path(__file__).resolve().parent.parent
PLOTTER = REPO / ".venv" / "bin" / "plotter"

pytestmark = pytest.mark.ros


def plotter(*args, timeout=600):
    if not PLOTTER.exists():
        pytest.fail("the plotter command is missing: run scripts/setup.sh")
    env = dict(os.environ, ROS_DOMAIN_ID=str(random.SystemRandom().randint(110, 200)))
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
