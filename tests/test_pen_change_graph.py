"""Pen changes on the node graph: `plotter svg` of a two-colour drawing sent to
the running plotter stops at PEN_CHANGE with the pen up at the park position,
nothing moves while it waits, and `plotter resume` draws the second layer."""
from __future__ import annotations

import subprocess
import time
from pathlib import Path

import pytest

from node_processes import read_trace, wait_until
from ros_graph import last_state, watched_graph

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parent.parent
PLOTTER = str(REPO / ".venv" / "bin" / "plotter")
SPM = 80.0
PARK = (20.0, 10.0)
# Two colours, 60 x 40 mm: a black square, then a red cross.
TWO_COLOURS = """<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" viewBox="0 0 60 40">
<rect x="5" y="5" width="30" height="30" stroke="black" fill="none"/>
<path d="M 40 10 L 55 25 M 40 25 L 55 10" stroke="red" fill="none"/>
</svg>
"""


@pytest.fixture
def graph(tmp_path):
    with watched_graph(tmp_path, streamer_args=("-p", f"park_x:={PARK[0]}", "-p", f"park_y:={PARK[1]}")) as g:
        yield g


def trace_mm(graph):
    return [(x / SPM, y / SPM) for _, x, y in read_trace(graph.trace)]


def drawn_points(program_lines):
    """Points every 0.5 mm along the program's drawn moves (lines only: the drawing has no curves)."""
    import math
    from plotter_bridge.gcode.parser import parse_program
    from plotter_bridge.gcode.types import Move
    out = []
    for m in parse_program("\n".join(program_lines) + "\n").items:
        if isinstance(m, Move) and m.pen == "down" and not m.rapid:
            n = max(1, int(math.dist((m.sx, m.sy), (m.x, m.y)) / 0.5))
            out += [(m.sx + (m.x - m.sx) * k / n, m.sy + (m.y - m.sy) * k / n) for k in range(n + 1)]
    return out


def test_a_two_colour_drawing_waits_for_the_pen_and_plotter_resume_draws_the_second(graph, tmp_path):
    from scipy.spatial import cKDTree
    from plotter_interfaces.msg import BoardState
    from plotter_shapes.svg_input import svg_program
    svg = tmp_path / "two.svg"
    svg.write_text(TWO_COLOURS)
    # stdin closed: the command says the job waits for plotter resume, from anywhere
    job = subprocess.Popen([PLOTTER, "svg", str(svg), "--quiet"], stdin=subprocess.DEVNULL,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=graph.env)
    try:
        wait_until(lambda: last_state(graph).state == BoardState.PEN_CHANGE, 240, "PEN_CHANGE")
        at = last_state(graph)
        assert (at.state_name, at.next_pen, at.next_pen_colour) == ("PEN_CHANGE", 'layer 2 "red" #ff0000', "#ff0000")
        assert not at.pen_down and (round(at.x_mm, 3), round(at.y_mm, 3)) == PARK
        first = trace_mm(graph)
        time.sleep(2.0)
        assert trace_mm(graph) == first, "nothing moves while the pen is changed"
        assert job.poll() is None, "the job waits"
        r = subprocess.run([PLOTTER, "resume"], capture_output=True, text=True, env=graph.env, timeout=60)
        assert r.returncode == 0 and "pen change 1 done" in r.stdout, r.stdout + r.stderr
        out, err = job.communicate(timeout=240)
    finally:
        if job.poll() is None:
            job.kill()
    assert job.returncode == 0, err
    assert "the job waits for plotter resume" in err
    program = svg_program(str(svg))
    whole = trace_mm(graph)
    # the first layer was all drawn before the change, the second after, and both as the file has them
    black, red = (drawn_points(part) for part in _split_at_change(program))
    tree_before, tree_after = cKDTree(first), cKDTree(whole[len(first):])
    assert tree_before.query(black)[0].max() < 0.02 and tree_after.query(red)[0].max() < 0.02
    assert tree_before.query(red)[0].min() > 1.0, "the red cross was not drawn before the pen change"
    assert max(abs(a - b) for a, b in zip(whole[-1], red[-1])) <= 0.5 / SPM, "it ends where the file does"


def _split_at_change(program):
    k = next(i for i, line in enumerate(program) if line.startswith("T2 M6"))
    return program[:k], program[:2] + program[k + 1:]
