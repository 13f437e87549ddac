"""Runs of chords as arcs (gcode/arcfit.py): the fitted path keeps the chords'
ends and stays within the tolerance of them both ways, on circles, on
random curves and on the generators' own output; the awkward runs stay as
they were."""
from __future__ import annotations

import math
import random
import sys
from pathlib import Path
from typing import List, Tuple

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib as lib  # noqa: E402  (puts plotter_bridge on the path)

from plotter_bridge.gcode.arcfit import FitConfig, fit_arcs  # noqa: E402
from plotter_bridge.gcode.dialect import GCodeOptions  # noqa: E402
from plotter_bridge.gcode.geometry import arc_extreme_points  # noqa: E402
from plotter_bridge.gcode.limits import WorkArea  # noqa: E402
from plotter_bridge.gcode.parser import decode_program, moves_of, parse_program  # noqa: E402
from plotter_bridge.gcode.types import Move  # noqa: E402

TOL = 0.02
DATA = Path(__file__).resolve().parent / "data"


def chords(points: List[Tuple[float, float]], feed: float = 1000.0) -> List[Move]:
    return [Move(k + 1, "line", a[0], a[1], b[0], b[1], feed, "down")
            for k, (a, b) in enumerate(zip(points, points[1:]))]


def arc_points(cx, cy, r, a0, a1, n):
    return [(cx + r * math.cos(a0 + (a1 - a0) * k / n), cy + r * math.sin(a0 + (a1 - a0) * k / n))
            for k in range(n + 1)]


def within(fitted: List[Move], original: List[Move], tol: float) -> float:
    """The farthest either path strays from the other (sampled every 0.01 mm)."""
    worst = 0.0
    for a, b in ((fitted, original), (original, fitted)):
        index = lib.MoveIndex(b, reach=1.0)
        for m in a:
            for p in lib.move_points(m, 0.01):
                worst = max(worst, index.distance(p))
    return worst


def ends(moves: List[Move]) -> List[Tuple[float, float]]:
    return [(moves[0].sx, moves[0].sy)] + [(m.x, m.y) for m in moves]


@pytest.mark.parametrize("r, chord, sweep, direction", [
    (5.0, 0.5, 90, 1), (40.0, 1.0, 200, -1), (120.0, 2.0, 60, 1), (0.8, 0.1, 300, -1)])
def test_chords_of_a_circle_become_one_arc(r, chord, sweep, direction):
    n = max(3, math.ceil(r * math.radians(sweep) / chord))
    pts = arc_points(10.0, 20.0, r, 0.3, 0.3 + direction * math.radians(sweep), n)
    original = chords(pts)
    fitted = fit_arcs(original, FitConfig(tolerance=TOL))
    assert len(fitted) == 1 and fitted[0].kind == "arc" and fitted[0].cw == (direction < 0)
    assert (fitted[0].sx, fitted[0].sy, fitted[0].x, fitted[0].y) == (*pts[0], *pts[-1])
    assert within(fitted, original, TOL) <= TOL + 1e-6


def test_a_closed_run_is_a_full_circle():
    pts = arc_points(50.0, 50.0, 10.0, 0.0, 2 * math.pi, 72)
    pts[-1] = pts[0]
    fitted = fit_arcs(chords(pts), FitConfig(tolerance=TOL))
    assert len(fitted) == 1 and fitted[0].is_full_circle


def test_chords_of_uneven_length_on_a_circle():
    rng = random.Random(3)
    angles = sorted(rng.uniform(0, 2.5) for _ in range(40))
    pts = [(5 * math.cos(a), 5 * math.sin(a)) for a in angles]
    original = chords(pts)
    fitted = fit_arcs(original, FitConfig(tolerance=TOL))
    assert len(fitted) == 1 and within(fitted, original, TOL) <= TOL + 1e-6


def test_what_stays_lines():
    straight = chords([(k * 1.0, 0.0005 * (k % 2)) for k in range(20)])        # nearly straight: one line
    fitted = fit_arcs(straight, FitConfig(tolerance=TOL))
    assert len(fitted) == 1 and fitted[0].kind == "line" and ends(fitted) == [ends(straight)[0], ends(straight)[-1]]
    zigzag = chords([(k * 1.0, 0.05 * (k % 2)) for k in range(20)])          # beyond the tolerance: as it was
    assert fit_arcs(zigzag, FitConfig(tolerance=TOL)) == zigzag
    back = chords([(0, 0), (5, 0), (3, 0.001), (8, 0)])                        # on a line, but going back
    assert all(m.kind == "line" for m in fit_arcs(back)) and len(fit_arcs(back)) >= 3
    tiny = chords(arc_points(0, 0, 0.02, 0, 3, 12))                          # tighter than min_radius
    assert all(m.kind == "line" for m in fit_arcs(tiny))
    two = chords([(0, 0), (1, 1), (2, 0)])                                    # fewer chords than min_moves
    assert fit_arcs(two) == two


def test_an_inflection_is_never_one_arc():
    first = arc_points(0, 10, 10, -math.pi / 2, 0, 20)                       # counter-clockwise up to (10, 10)
    second = arc_points(20, 10, 10, math.pi, math.pi / 2, 20)[1:]            # then clockwise
    original = chords(first + second)
    fitted = fit_arcs(original, FitConfig(tolerance=TOL))
    arcs = [m for m in fitted if m.kind == "arc"]
    assert [m.cw for m in arcs] == [False, True]
    assert ends(fitted)[0] == ends(original)[0] and ends(fitted)[-1] == ends(original)[-1]
    assert within(fitted, original, TOL) <= TOL + 1e-6


def test_an_arc_that_would_leave_the_work_area_stays_chords():
    # A half circle of 31 chords, no vertex at its top: the chords reach Y 4.9936, the arc Y 5.
    original = chords(arc_points(100.0, 0.0, 5.0, 0.0, math.pi, 31))
    assert len(fit_arcs(original, FitConfig(tolerance=TOL, area=WorkArea(0, 200, -10, 200)))) == 1
    edge = WorkArea(0, 200, -10, 4.997)
    assert all(edge.contains(m.x, m.y) for m in original)
    fitted = fit_arcs(original, FitConfig(tolerance=TOL, area=edge))
    assert len(fitted) > 1 and within(fitted, original, TOL) <= TOL + 1e-6       # arcs up to the top, no further
    for m in fitted:
        if m.kind == "arc":
            assert all(edge.contains(x, y) for x, y in arc_extreme_points((m.sx, m.sy), (m.x, m.y), (m.cx, m.cy), m.cw))


def test_travel_pen_changes_and_feeds_end_a_run():
    a = chords(arc_points(0, 0, 10, 0, 1, 10), feed=1000.0)
    b = chords(arc_points(0, 0, 10, 1, 2, 10), feed=2000.0)
    fitted = fit_arcs(a + b)
    assert [m.feed for m in fitted if m.kind == "arc"] == [1000.0, 2000.0]
    up = [Move(99, "line", m.sx, m.sy, m.x, m.y, m.feed, "up") for m in a]
    assert fit_arcs(up) == up


@pytest.mark.parametrize("seed", range(12))
def test_random_curves_stay_within_the_tolerance(seed):
    rng = random.Random(seed)
    p = [(rng.uniform(0, 100), rng.uniform(0, 100)) for _ in range(4)]
    n = rng.randint(40, 300)
    pts = []
    for k in range(n + 1):                                                  # a cubic Bezier as n chords
        t = k / n
        u = 1 - t
        pts.append(tuple(u ** 3 * a + 3 * u * u * t * b + 3 * u * t * t * c + t ** 3 * d
                         for a, b, c, d in zip(*p)))
    original = chords(pts)
    fitted = fit_arcs(original, FitConfig(tolerance=TOL))
    assert ends(fitted)[0] == ends(original)[0] and ends(fitted)[-1] == ends(original)[-1]
    assert within(fitted, original, TOL) <= TOL + 1e-6


@pytest.mark.parametrize("name, fewer", [("corpus/generated/curves.svg2gcode-grbl.gcode", False),
                                         ("real/lightburn/example_2_circle.gcode", False),   # box joints
                                         ("real/grbl-plotter/lastProcessed.nc", True),
                                         ("real/jscut/jscut-outside.gcode", False)])
def test_programs_of_the_tools_fewer_moves_same_drawing(name, fewer):
    path = DATA / name
    items = parse_program(decode_program(path.read_bytes()), options=GCodeOptions("grbl")).items
    original = moves_of(items)
    fitted = moves_of(fit_arcs(items, FitConfig(tolerance=TOL)))
    assert len(fitted) < len(original) if fewer else len(fitted) <= len(original)
    drawn = [m for m in original if m.pen == "down" and not m.rapid]
    assert within([m for m in fitted if m.pen == "down" and not m.rapid], drawn, TOL) <= TOL + 1e-6
    assert [(m.x, m.y) for m in fitted if m.rapid] == [(m.x, m.y) for m in original if m.rapid]


def test_plotter_check_shows_the_fitted_moves():
    import contextlib
    import io
    from plotter_bridge.cli import main as cli
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert cli.main(["check", str(DATA / "real" / "grbl-plotter" / "lastProcessed.nc"), "--dialect", "grbl",
                         "--fit-arcs", "0.02"]) == 0
    summary = out.getvalue().splitlines()[-1]
    assert "arcs fitted within 0.02 mm, 363 moves became 75" in summary and "12 arcs" in summary
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert cli.main(["check", str(DATA / "real" / "grbl-plotter" / "lastProcessed.nc"), "--dialect", "grbl",
                         "--fit-arcs", "-1"]) == 2


def circle_program(chord: float = 0.5, r: float = 15.0, feed: float = 3000.0) -> str:
    n = math.ceil(2 * math.pi * r / chord)
    pts = arc_points(100.0, 100.0, r, 0.0, 2 * math.pi, n)
    lines = [f"G1 X{x:.4f} Y{y:.4f}" for x, y in pts[1:]]
    return f"G21 G90\nG0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}\nM3\nF{feed:g}\n" + "\n".join(lines) + "\nM5\nM2\n"


def test_the_streamer_sends_fewer_commands_and_the_core_steps_along_the_chords():
    """compile_program with fit_arcs: the board commands of a circle of 189 chords are a handful, and
    every step the firmware core takes for them is on the chords' path (within the tolerance and a step)."""
    from plotter_bridge.motion.compiler import StreamerConfig, compile_program
    from plotter_bridge.sim.expected import program_steps
    text = circle_program()
    plain, fitted = StreamerConfig(fit_arcs=False), StreamerConfig()
    assert fitted.fit_arcs and fitted.arc_tolerance == TOL                   # on by default, as the streamer
    drawn = lambda cmds: [c for c in cmds if c.verb in ("L", "C", "A")]  # noqa: E731
    assert len(drawn(compile_program(text, fitted))) * 20 < len(drawn(compile_program(text, plain)))
    index = lib.MoveIndex(moves_of(parse_program(text).items), reach=1.0)    # the chords and the travel to them
    steps = set(program_steps(text, fitted))
    worst = max(index.distance((x / 80.0, y / 80.0)) for x, y in steps)
    assert worst <= TOL + 0.5 / 80.0 * math.sqrt(2) + 1e-9, worst


@pytest.mark.ros
def test_plotter_stream_fits_arcs_unless_told_not_to(tmp_path):
    import os
    import subprocess
    from node_processes import new_domain
    from ros_graph import read_trace
    plotter = Path(__file__).resolve().parent.parent / ".venv" / "bin" / "plotter"
    program = tmp_path / "circle.gcode"
    program.write_text(circle_program())
    started = {}
    for fit in ("--no-fit-arcs", ""):
        trace, seq = tmp_path / f"trace{fit}.csv", tmp_path / f"seq{fit}.csv"
        r = subprocess.run([str(plotter), "stream", str(program), "--mock", "--quiet", "--trace", str(trace),
                            "--seq-log", str(seq), *([fit] if fit else [])], capture_output=True,
                           text=True, timeout=600, env=dict(os.environ, ROS_DOMAIN_ID=str(new_domain())))
        assert r.returncode == 0, r.stderr
        started[fit] = seq.read_text().count("\n") - 1
        index = lib.MoveIndex(moves_of(parse_program(program.read_text()).items), reach=1.0)
        worst = max(index.distance((x / 80.0, y / 80.0)) for _, x, y in read_trace(trace))
        assert worst <= TOL + 0.5 / 80.0 * math.sqrt(2) + 1e-9, worst
    assert started[""] * 20 < started["--no-fit-arcs"], started


def _drawn_chains(moves: List[Move]) -> List[List[Move]]:
    """The drawn moves in runs that join end to start."""
    out: List[List[Move]] = []
    for m in moves:
        if m.pen != "down" or m.rapid:
            continue
        if out and math.dist((out[-1][-1].x, out[-1][-1].y), (m.sx, m.sy)) <= 1e-9:
            out[-1].append(m)
        else:
            out.append([m])
    return out


def _corpus():
    from real_programs import ACCEPTED
    out = [pytest.param(p.path, p.options(), id=p.name) for p in ACCEPTED]
    out += [pytest.param(path, GCodeOptions("grbl" if "grbl" in path.name else "marlin" if "marlin" in path.name
                                            else "linuxcnc"), id=path.name)
            for path in sorted((DATA / "corpus" / "generated").glob("*.*")) if path.suffix in (".ngc", ".gcode")]
    return out


@pytest.mark.parametrize("path, options", _corpus())
def test_every_file_of_the_corpus_keeps_its_drawing(path, options):
    """Every real and generated program: the fitted drawing is the chords' within the tolerance both
    ways, each drawn stroke starts and ends where it did, travel is untouched."""
    items = parse_program(decode_program(path.read_bytes()), options=options).items
    original = moves_of(items)
    fitted = moves_of(fit_arcs(items, FitConfig(tolerance=TOL)))
    assert len(fitted) <= len(original)
    before, after = _drawn_chains(original), _drawn_chains(fitted)
    assert [(c[0].sx, c[0].sy, c[-1].x, c[-1].y) for c in after] == \
        [(c[0].sx, c[0].sy, c[-1].x, c[-1].y) for c in before]
    for a, b in zip(after, before):
        k = 0
        for f in a:                  # each fitted move against the chords it stands for
            end = next(n for n in range(k, len(b)) if (b[n].x, b[n].y) == (f.x, f.y))
            if f != b[k] or end != k:
                assert within([f], b[k:end + 1], TOL) <= TOL + 1e-6, (f, b[k:end + 1])
            k = end + 1
        assert k == len(b)
    assert [(m.x, m.y) for m in fitted if m.rapid] == [(m.x, m.y) for m in original if m.rapid]


def test_an_arc_too_large_for_the_board_goes_as_chords_within_a_step():
    """G2 R1000 over 140 mm: its centre is 79804 steps away, beyond the board's 32767.  It goes as
    lines the board takes, and every step the firmware core takes for them is on the arc."""
    from plotter_bridge.link.protocol import MAX_DELTA
    from plotter_bridge.motion.compiler import StreamerConfig, compile_program
    from plotter_bridge.sim.expected import step_positions
    commands = compile_program("G0 X10 Y10\nM3\nG2 X150 Y10 R1000 F1000\n", StreamerConfig())
    drawn = commands[commands.index(next(c for c in commands if c.text == "P 1")) + 1:]
    assert drawn and all(c.verb == "L" for c in drawn)
    assert all(abs(a) <= MAX_DELTA for c in commands for a in c.args)
    cx, cy = 80.0, 10.0 - math.sqrt(1000.0 ** 2 - 70.0 ** 2)
    steps = step_positions([c.text for c in commands])
    on_arc = steps[steps.index((800, 800)) + 1:]
    assert on_arc[-1] == (12000, 800)
    assert max(abs(math.hypot(x / 80.0 - cx, y / 80.0 - cy) - 1000.0) for x, y in on_arc) <= 2 / 80.0


def test_the_step_layer_and_the_link_agree_on_the_board_range():
    """gcode/ may not import link/, so gcode/steps.py keeps its own copy of the board's range."""
    from plotter_bridge.gcode import steps
    from plotter_bridge.link.protocol import MAX_DELTA
    assert steps.MAX_DELTA == MAX_DELTA


def _chord_circle(feed: float, chord: float = 1.0, r: float = 30.0) -> str:
    n = int(2 * math.pi * r / chord)
    pts = [(100 + r * math.cos(2 * math.pi * k / n), 100 + r * math.sin(2 * math.pi * k / n)) for k in range(n + 1)]
    return "\n".join(["G21 G90", f"G0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}", "M3"]
                     + [f"G1 X{x:.4f} Y{y:.4f} F{feed:g}" for x, y in pts[1:]] + ["M5"]) + "\n"


@pytest.mark.parametrize("feed, baud, cpu, arcs", [
    (6000, 9600, True, True),       # 1 mm chords wait for the link: 27 bytes at 960 bytes/s, 0.029 s a mm
    (6000, 0, True, True),          # the link unknown: the board's default, 9600
    (6000, 115200, True, True),     # the link keeps up, the board's CPU does not: 20 ms a command
    (6000, 115200, False, False),   # a board planning in no time: chords at 100 mm/s beat arcs at 5000
    (2400, 115200, False, True),    # a feed an arc keeps: the arc, and fewer bytes
    (300, 115200, True, True),
])
def test_chords_become_an_arc_only_where_the_arc_draws_no_slower(feed, baud, cpu, arcs):
    """The board steps arcs at most MAX_ARC_RATE (firmware/README.md): a run of chords becomes an
    arc where that is no slower than the chords at their feed, on the link and in the board's CPU."""
    from plotter_bridge.motion.compiler import StreamerConfig, compile_program
    from plotter_bridge.sim.expected import step_positions
    program = _chord_circle(feed)
    fitted = compile_program(program, StreamerConfig(link_baud=baud, board_cpu=cpu))
    chords = compile_program(program, StreamerConfig(link_baud=baud, fit_arcs=False, board_cpu=cpu))
    assert any(c.verb in "AC" for c in fitted) == arcs
    if not arcs:
        assert [c.text for c in fitted] == [c.text for c in chords]
    assert step_positions([c.text for c in fitted])[-1] == step_positions([c.text for c in chords])[-1]


def test_arc_pays_weighs_the_arcs_top_feed_against_the_chords_and_their_link():
    from plotter_bridge.gcode.types import Move
    from plotter_bridge.link.protocol import MAX_ARC_RATE
    from plotter_bridge.motion.compiler import arc_pays
    # a quarter circle of r 10 mm as 16 chords; its steps at 80 steps/mm: 1600
    pts = [(10 * math.cos(k * math.pi / 32), 10 * math.sin(k * math.pi / 32)) for k in range(17)]

    def chords_at(feed):
        return [Move(1, "line", a[0], a[1], b[0], b[1], feed, "down") for a, b in zip(pts, pts[1:])]
    for feed, baud in ((6000, 115200), (6000, 9600), (1000, 115200)):
        chords = chords_at(feed)
        arc = Move(1, "arc", 10, 0, 0, 10, feed, "down", cx=0, cy=0, cw=False)
        steps = 80 * sum(abs(b[0] - a[0]) + abs(b[1] - a[1]) for a, b in zip(pts, pts[1:]))
        length = sum(math.dist(a, b) for a, b in zip(pts, pts[1:]))
        as_arc = max(length / (feed / 60), steps / MAX_ARC_RATE)
        as_chords = max(length / (feed / 60), 16 * 27 / (baud / 10 * 0.97))
        assert arc_pays(80.0, baud, cpu=None)(chords, arc) == (as_arc <= as_chords), (feed, baud)
    assert [arc_pays(80.0, b, cpu=None)(chords_at(f), Move(1, "arc", 10, 0, 0, 10, f, "down", cx=0, cy=0,
                                                           cw=False))
            for f, b in ((6000, 115200), (6000, 9600), (1000, 115200))] \
        == [False, True, True]


def test_arc_pays_counts_the_boards_cpu_per_chord():
    """16 chords cost the board 16 commands' main-loop work (BoardCpu), the arc one: at 115200 baud,
    where the link keeps up with 1 mm chords at F6000, the CPU does not, and the arc pays."""
    from plotter_bridge.gcode.types import Move
    from plotter_bridge.motion.compiler import arc_pays
    from plotter_bridge.motion.planner import BoardCpu
    pts = [(10 * math.cos(k * math.pi / 32), 10 * math.sin(k * math.pi / 32)) for k in range(17)]
    chords = [Move(1, "line", a[0], a[1], b[0], b[1], 6000, "down") for a, b in zip(pts, pts[1:])]
    arc = Move(1, "arc", 10, 0, 0, 10, 6000, "down", cx=0, cy=0, cw=False)
    assert arc_pays(80.0, 115200)(chords, arc)
    assert not arc_pays(80.0, 115200, cpu=BoardCpu(command_cycles=100.0))(chords, arc)   # a fast CPU: chords
