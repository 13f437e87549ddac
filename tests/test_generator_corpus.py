"""Programs made by real generators (tests/generator_corpus.py) from our own
SVGs: ``plotter check`` accepts each with the dialect it needs, its pen-down
moves follow the drawing within the generator's tolerance, and ``plotter
stream --mock`` draws it; generator settings the plotter cannot follow are
refused with the line and the reason.
"""
from __future__ import annotations

import contextlib
import io
import math
import os
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)
from generator_corpus import CASES, CORPUS, Case, program, reference_polylines  # noqa: E402
from node_processes import new_domain  # noqa: E402

from plotter_bridge.cli import main as cli  # noqa: E402
from plotter_bridge.gcode.dialect import GCodeOptions  # noqa: E402
from plotter_bridge.gcode.parser import decode_program, moves_of, parse_program  # noqa: E402
from plotter_bridge.gcode.types import Move  # noqa: E402

ACCEPTED = [c for c in CASES if c.refused is None]
REFUSED = [c for c in CASES if c.refused is not None]
SPACING = 0.01          # mm between the points the two paths are compared at
SLACK = 0.012           # mm: that spacing and the reference's own quantization
REPO = Path(__file__).resolve().parent.parent
PLOTTER = REPO / ".venv" / "bin" / "plotter"


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("corpus")


def options(case: Case) -> GCodeOptions:
    return GCodeOptions(case.dialect, case.pen_up_z, *case.marlin_pen)


def run_check(path: Path, *extra: str) -> Tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", str(path), *extra])
    return code, out.getvalue(), err.getvalue()


def move_points(m: Move) -> List[Tuple[float, float]]:
    return gcode_testlib.move_points(m, SPACING)


def polyline_points(line: List[Tuple[float, float]]) -> List[Tuple[float, float]]:
    pts = [line[0]]
    for (x0, y0), (x1, y1) in zip(line, line[1:]):
        n = max(1, math.ceil(math.hypot(x1 - x0, y1 - y0) / SPACING))
        pts += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(1, n + 1)]
    return pts


_REFERENCE: Dict[str, np.ndarray] = {}


def reference(drawing: str) -> np.ndarray:
    if drawing not in _REFERENCE:
        _REFERENCE[drawing] = np.array([p for line in reference_polylines(drawing) for p in polyline_points(line)])
    return _REFERENCE[drawing]


def farthest(points: np.ndarray, targets: np.ndarray) -> Tuple[float, tuple]:
    """The largest distance from a target to the nearest point, and that target."""
    from scipy.spatial import cKDTree
    dist, _ = cKDTree(points).query(targets)
    k = int(np.argmax(dist))
    return float(dist[k]), tuple(np.round(targets[k], 3))


def drawn_points(case: Case, path: Path) -> np.ndarray:
    items = parse_program(decode_program(path.read_bytes()), options=options(case)).items
    drawn = [m for m in moves_of(items) if m.pen == "down" and not m.rapid]
    assert drawn, f"{case.name}: nothing drawn"
    return np.array([p for m in drawn for p in move_points(m)])


def test_the_corpus_covers_every_generator_and_dialect():
    assert {c.generator for c in ACCEPTED} == {"vpype-gcode", "svg-to-gcode", "svg2gcode", "gcodetools"}
    assert {c.dialect for c in ACCEPTED} == {"linuxcnc", "grbl", "marlin"}
    assert {c.drawing for c in ACCEPTED} == {"shapes", "curves", "text"}
    for case in CASES:
        if case.committed:
            assert (CORPUS / "generated" / case.name).is_file(), f"{case.name}: run tests/generator_corpus.py"


@pytest.mark.parametrize("case", ACCEPTED, ids=lambda c: c.name)
def test_check_accepts_and_the_moves_follow_the_drawing(case, workdir):
    path = program(case, workdir)
    code, out, err = run_check(path, *case.check_args())
    assert code == 0, f"{case.name}: {err}"
    assert "OK" in out
    drawn = drawn_points(case, path)
    ref = reference(case.drawing)
    off, where = farthest(ref, drawn)
    assert off <= case.tolerance + SLACK, f"{case.name}: drawn {off:.4f} mm off the drawing at {where}"
    missed, where = farthest(drawn, ref)
    assert missed <= case.tolerance + SLACK, f"{case.name}: the drawing at {where} is {missed:.4f} mm from the pen"


@pytest.mark.parametrize("case", ACCEPTED, ids=lambda c: c.name)
def test_in_another_dialect_it_is_refused_or_the_same(case, workdir):
    """The dialect matters: a program in Marlin's forms is refused in the other dialects
    with its line and the reason, grbl's are refused or read the same (S is the spindle's
    speed in LinuxCNC, the laser's power in grbl: at 0 neither draws); LinuxCNC's forms
    read the same in all."""
    path = program(case, workdir)
    ours = drawn_points(case, path)
    for dialect in sorted({"linuxcnc", "grbl", "marlin"} - {case.dialect}):
        other = replace(case, dialect=dialect)
        code, out, err = run_check(path, *other.check_args())
        if code == 0:
            assert np.array_equal(drawn_points(other, path), ours), f"{case.name} as {dialect}: drawn otherwise"
        else:
            assert code == 2 and re.match(rf"{re.escape(str(path))}:line \d+: \S", err), f"{case.name} as {dialect}"
        if case.dialect == "marlin":      # a servo angle means nothing to the others
            assert code == 2, f"{case.name} as {dialect}"
        elif case.dialect == "linuxcnc":  # LinuxCNC's forms read the same everywhere
            assert code == 0, f"{case.name} as {dialect}: {err}"


@pytest.mark.parametrize("case", [c for c in ACCEPTED if c.pen_up_z != 0.0], ids=lambda c: c.name)
def test_pen_on_z_needs_its_threshold(case, workdir):
    path = program(case, workdir)
    code, _, err = run_check(path, "--dialect", case.dialect)
    items = parse_program(path.read_text(), options=GCodeOptions(case.dialect)).items
    assert code == 0 and not any(m.pen == "down" and not m.rapid for m in moves_of(items)), err


@pytest.mark.parametrize("case", REFUSED, ids=lambda c: c.name)
def test_settings_the_plotter_cannot_follow_are_refused(case, workdir):
    path = program(case, workdir)
    line, reason = case.refused
    code, out, err = run_check(path, *case.check_args())
    assert code == 2 and out == ""
    assert err.startswith(f"{path}:line {line}: ") and reason in err, err


def test_handwritten_forms(tmp_path):
    """The forms of the issue as users' generators write them, line for line."""
    grbl = "G21 G90\nG0 X10 Y10\nM3 S1000\nG1 X30 Y10 F3000\nG2 X30 Y30 I0 J10\nM5\nG0 X0 Y0\nM2\n"
    # As the MakerBot Unicorn extension writes it: servo angles, 150 ms dwells, motors off and on.
    marlin = ("G21\nG90\nG92 X0 Y0 Z0\nM300 S50\nG4 P150\nM18\nM17\nG1 X10 Y10 F3500\nM300 S30.00\n"
              "G4 P150\nG1 X30 Y10 F3500\nG1 X30 Y30 F3500\nM300 S50.00\nG4 P150\nG1 X0 Y0 F3500\nM18\n")
    for name, text, dialect, noted, kinds in (("grbl.gcode", grbl, "grbl", [], ["line", "arc"]),
                                              ("marlin.gcode", marlin, "marlin", [3, 6, 7], ["line", "line"])):
        path = tmp_path / name
        path.write_text(text)
        code, out, err = run_check(path, "--dialect", dialect)
        assert code == 0, err
        assert [int(line.split(":")[1].split()[1]) for line in err.splitlines()] == noted
        parsed = parse_program(text, options=GCodeOptions(dialect))
        drawn = [m for m in moves_of(parsed.items) if m.pen == "down"]
        assert [(m.kind, round(m.x, 6), round(m.y, 6)) for m in drawn] == list(zip(kinds, (30, 30), (10, 30)))
        dwells = [i.seconds for i in parsed.items if type(i).__name__ == "Dwell"]
        assert dwells == ([] if dialect == "grbl" else [0.15, 0.15, 0.15])
        code, _, err = run_check(path)
        if dialect == "grbl":            # M3 S1000 / M5 read as LinuxCNC reads them: the same drawing
            default = parse_program(text).items
            assert code == 0 and moves_of(default) == moves_of(parsed.items), err
        else:
            assert code == 2, f"{name} in the default dialect"


def test_vpype_ninja_profile_goes_home_and_raises_z_to_draw(workdir):
    """vpype-gcode's "ninja" profile homes with G28 (here: to the origin, pen up) and lowers its
    pen by raising Z (Z6 down, Z3 up), the opposite of this plotter's rule (Z at or below pen_up_z
    is down), which no --pen-up-z can turn round: accepted, and only its last move, Z0 then home,
    is drawn."""
    case = Case("shapes.vpype-ninja.gcode", "shapes", "vpype-gcode", "ninja", "grbl")
    path = program(case, workdir)
    code, out, err = run_check(path, *case.check_args())
    assert code == 0, err
    assert "line 4: note: G28 go home" in err
    drawn = [m for m in moves_of(parse_program(path.read_text(), options=options(case)).items)
             if m.pen == "down" and not m.rapid]
    assert [(round(m.sx, 3), round(m.sy, 3), m.x, m.y) for m in drawn] == [(30.0, 38.0, 0.0, 0.0)]


# --------------------------------------------------------------- on the mock board

STREAMS_AT_ONCE = 3      # the mock board runs in real time and mostly waits: three share two cores


def plotter(*args, domain: int, timeout=600):
    if not PLOTTER.exists():
        pytest.fail("the plotter command is missing: run scripts/setup.sh")
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    return subprocess.run([str(PLOTTER), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env)


@pytest.fixture(scope="module")
def streams(workdir):
    """`plotter stream --mock` of every accepted case, a few at a time, each on a ROS
    domain of its own: the case's name -> a future of (the run, its step trace)."""
    import queue
    from concurrent.futures import ThreadPoolExecutor
    domains: "queue.Queue[int]" = queue.Queue()
    for _ in range(STREAMS_AT_ONCE):
        domains.put(new_domain())

    def stream(case: Case):
        path = program(case, workdir)
        trace = workdir / f"{case.name}.trace.csv"
        domain = domains.get()
        try:
            return plotter("stream", path, "--mock", "--trace", trace, "--quiet", *case.check_args(),
                           domain=domain), trace
        finally:
            domains.put(domain)

    for case in ACCEPTED:
        program(case, workdir)   # made here, not in the threads
    with ThreadPoolExecutor(STREAMS_AT_ONCE) as pool:
        yield {case.name: pool.submit(stream, case) for case in ACCEPTED}


@pytest.mark.ros
@pytest.mark.parametrize("case", ACCEPTED, ids=lambda c: c.name)
def test_stream_on_the_mock_board_draws_it(case, workdir, streams):
    from ros_graph import read_trace
    r, trace = streams[case.name].result()
    assert r.returncode == 0, r.stderr
    path = program(case, workdir)
    steps = np.array([(x / 80.0, y / 80.0) for _, x, y in read_trace(trace)])
    moves = moves_of(parse_program(path.read_text(), options=options(case)).items)
    programmed = np.array([p for m in moves for p in move_points(m)])
    # Every step on the programmed path (within the rounding to steps and the arcs'
    # integer centres), every drawn point stepped over, and the pen where it ends.
    off, where = farthest(programmed, steps)
    assert off <= 0.05, f"{case.name}: the board stepped {off:.3f} mm off the program at {where}"
    missed, where = farthest(steps, drawn_points(case, path))
    assert missed <= 0.05, f"{case.name}: the board never came within {missed:.3f} mm of {where}"
    assert math.dist(steps[-1], (moves[-1].x, moves[-1].y)) <= 1 / 80.0


@pytest.mark.ros
def test_the_plotter_options_reach_the_streamer(tmp_path):
    """--dialect, --pen-up-z and --marlin-pen become gcode_streamer's parameters and its config."""
    from plotter_bridge.cli.main import build_parser
    from plotter_bridge.cli.run import _graph_options
    from plotter_bridge.nodes.local_graph import LocalGraph
    args = build_parser().parse_args(["stream", "x.gcode", "--mock", "--journal", str(tmp_path), "--dialect", "marlin",
                                      "--pen-up-z", "2.5", "--marlin-pen", "90", "10"])
    with LocalGraph(_graph_options(args)) as graph:
        config = graph.streamer.config
        assert (config.dialect, config.pen_up_z, config.marlin_pen_down, config.marlin_pen_up) == \
            ("marlin", 2.5, 90.0, 10.0)
        assert graph.streamer.get_parameter("dialect").value == "marlin"


@pytest.mark.ros
@pytest.mark.parametrize("name, dialect, line", [("shapes.svg2gcode-marlin.gcode", "linuxcnc", 3),
                                                 ("shapes.svg2gcode-marlin.gcode", "grbl", 3)])
def test_stream_in_the_wrong_dialect_moves_nothing(name, dialect, line, tmp_path):
    trace = tmp_path / "trace.csv"
    r = plotter("stream", CORPUS / "generated" / name, "--mock", "--trace", trace, "--dialect", dialect,
                domain=new_domain())
    assert r.returncode == 2 and f"line {line}: " in r.stderr, r.stderr
    assert not trace.exists()
