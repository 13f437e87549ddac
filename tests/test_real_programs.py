"""Programs as the tools people use wrote them (tests/real_programs.py): each
is read as its tool's firmware reads it, the same as LinuxCNC's rs274 where
LinuxCNC reads it too, stepped by the firmware core along its path, and
drawn on the mock board; a refused one has every reason listed in one run,
naming the feature, before anything moves.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import List, Tuple

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib as lib  # noqa: E402  (puts plotter_bridge on the path)
from real_programs import ACCEPTED, PROGRAMS, REAL, REFUSED, RealProgram  # noqa: E402
from test_gcode_oracle import compare, rs274  # noqa: E402,F401  (rs274: the oracle's fixture)

from plotter_bridge.cli import main as cli  # noqa: E402
from plotter_bridge.gcode.dialect import GCodeOptions  # noqa: E402
from plotter_bridge.gcode.limits import WorkArea  # noqa: E402
from plotter_bridge.gcode.parser import decode_program, moves_of, parse_program  # noqa: E402
from plotter_bridge.motion.compiler import StreamerConfig  # noqa: E402
from plotter_bridge.sim.expected import drawn_whole, program_steps  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
PLOTTER = REPO / ".venv" / "bin" / "plotter"
STEPS_PER_MM = 80.0
ON_PATH = 0.05            # mm: a step's distance from the programmed path (rounding to steps and centres)
CORE_STEP_LIMIT = 2_000_000   # steps the firmware core is run for in the test; past it, the first so many
MOCK_SECONDS = 40.0       # programs the mock board draws in about this board time or less are streamed


def run_check(*args: str) -> Tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", *map(str, args)])
    return code, out.getvalue(), err.getvalue()


def options(p: RealProgram) -> GCodeOptions:
    return p.options()


def text_of(p: RealProgram) -> str:
    return decode_program(p.path.read_bytes())


def test_sources_name_every_file_with_its_licence():
    rows = {}
    for line in (REAL / "SOURCES.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0] not in ("file", "---"):
            rows[cells[0]] = cells
    files = {str(f.relative_to(REAL)) for f in REAL.glob("*/*")}
    assert set(rows) == files
    assert files == {p.file for p in PROGRAMS}
    for name, (_, tool, repo, path, commit, licence) in rows.items():
        assert tool and "/" in repo and path and re.fullmatch(r"[0-9a-f]{40}", commit) and licence, name


def test_every_named_tool_has_a_program():
    tools = {p.file.split("/")[0] for p in ACCEPTED}
    assert tools >= {"lightburn", "cambam", "freecad", "fusion360", "sketchucam", "jscut", "openbuilds-cam",
                     "pcb-gcode", "grbl-plotter", "lasertools", "gcodetools", "unicorn", "makelangelo",
                     "gcodeplot", "text2gcode", "svg2gcode"}
    assert {p.file.split("/")[0] for p in REFUSED} >= {"mrbeam"}


@pytest.mark.parametrize("program", ACCEPTED, ids=lambda p: p.name)
def test_read_as_its_tool_expects(program):
    code, out, err = run_check(program.path, *program.args())
    assert code == 0, err
    assert "OK" in out.splitlines()[-1]
    for words in program.notes:
        assert f": note: {words}" in err or any(words in line for line in err.splitlines()), (words, err)
    drawn = [m for m in moves_of(parse_program(text_of(program), options=options(program)).items)
             if m.pen == "down" and not m.rapid]
    assert bool(drawn) == program.draws


@pytest.mark.parametrize("program", REFUSED, ids=lambda p: p.name)
def test_refused_with_every_reason_at_once(program):
    code, out, err = run_check(program.path, *program.args())
    assert code == 2 and out == ""
    refused = [line for line in err.splitlines() if re.match(rf"{re.escape(str(program.path))}:line \d+: (?!note)",
                                                             line)]
    assert [int(line.split(":line ")[1].split(":")[0]) for line in refused] == [n for n, _ in program.refused]
    for (n, words), line in zip(program.refused, refused):
        assert words in line, line
    assert err.splitlines()[-1].endswith(f"refused: {len(program.refused)} lines the plotter cannot do; "
                                         f"nothing moved")
    # The same, one record each, from --json.
    code, out, _ = run_check(program.path, *program.args(), "--json")
    records = [json.loads(line) for line in out.splitlines()]
    assert [r["line"] for r in records if r["type"] == "error"] == [n for n, _ in program.refused]


@pytest.mark.parametrize("program", [p for p in ACCEPTED if p.rs274], ids=lambda p: p.name)
def test_read_as_linuxcnc_reads_it(program, rs274, tmp_path):  # noqa: F811
    """End points within 0.0001 mm and centres as rs274 prints them, the pen by the same model."""
    assert run_check(program.path, "--dialect", "linuxcnc", "--no-limits")[0] == 0
    text = text_of(program)
    if not re.search(r"^\s*(%|M0*2\b|M30\b)", text, re.MULTILINE | re.IGNORECASE):
        text = text.rstrip("\n") + "\nM2\n"     # LinuxCNC wants a program end that grbl does without
    compare(rs274, text, tmp_path, program.name, "linuxcnc")


def config(program: RealProgram) -> StreamerConfig:
    down, up = program.marlin_pen or (30.0, 50.0)
    area = WorkArea(*program.area) if program.area else WorkArea()
    return StreamerConfig(steps_per_mm=STEPS_PER_MM, area=area, dialect=program.dialect,
                          marlin_pen_down=down, marlin_pen_up=up)


@pytest.mark.parametrize("program", ACCEPTED, ids=lambda p: p.name)
def test_the_firmware_core_steps_along_it(program):
    """Every step the firmware core takes for the compiled program lies on the
    program's path, and the pen ends where the program does."""
    text = text_of(program)
    moves = moves_of(parse_program(text, options=options(program)).items)
    steps = program_steps(text, config(program), limit=CORE_STEP_LIMIT)
    assert steps, program.name
    index = lib.MoveIndex(moves)
    # Passes over the same path step the same places: each place once.
    worst = max(set(steps), key=lambda s: index.distance((s[0] / STEPS_PER_MM, s[1] / STEPS_PER_MM)))
    off = index.distance((worst[0] / STEPS_PER_MM, worst[1] / STEPS_PER_MM))
    assert off <= ON_PATH, f"{program.name}: a step at {worst} is {off:.3f} mm off the path"
    if len(steps) < CORE_STEP_LIMIT:
        end = moves[-1]
        assert math.dist((steps[-1][0] / STEPS_PER_MM, steps[-1][1] / STEPS_PER_MM), (end.x, end.y)) \
            <= 1 / STEPS_PER_MM


def board_seconds(program: RealProgram) -> float:
    code, out, _ = run_check(program.path, *program.args())
    return float(re.search(r"about (\d+) s", out).group(1))


SHORT = [p for p in ACCEPTED if board_seconds(p) <= MOCK_SECONDS]


STREAMS_AT_ONCE = 3      # the mock board runs in real time and mostly waits: three share two cores


def stream(program: RealProgram, tmp: Path, domain: int) -> Tuple[subprocess.CompletedProcess, Path, Path]:
    """`plotter stream --mock` of the program, with its step trace and a picture."""
    trace, png = tmp / f"{program.file.replace('/', '_')}.csv", tmp / f"{program.file.replace('/', '_')}.png"
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    r = subprocess.run([str(PLOTTER), "stream", str(program.path), "--mock", "--trace", str(trace), "--quiet",
                        "--png", str(png), *program.args()], capture_output=True, text=True, timeout=900, env=env)
    return r, trace, png


@pytest.fixture(scope="module")
def streams(tmp_path_factory):
    """Every short program streamed, a few at a time, each on a ROS domain of its own."""
    import queue
    from concurrent.futures import ThreadPoolExecutor
    from node_processes import new_domain
    if not PLOTTER.exists():
        pytest.fail("the plotter command is missing: run scripts/setup.sh")
    tmp = tmp_path_factory.mktemp("real")
    domains: "queue.Queue[int]" = queue.Queue()
    for _ in range(STREAMS_AT_ONCE):
        domains.put(new_domain())

    def one(program: RealProgram):
        domain = domains.get()
        try:
            return stream(program, tmp, domain)
        finally:
            domains.put(domain)

    with ThreadPoolExecutor(STREAMS_AT_ONCE) as pool:
        yield {p.file: pool.submit(one, p) for p in SHORT}


@pytest.mark.ros
@pytest.mark.parametrize("program", SHORT, ids=lambda p: p.name)
def test_drawn_on_the_mock_board(program, streams):
    from ros_graph import read_trace
    r, trace, png = streams[program.file].result()
    assert r.returncode == 0, r.stderr
    steps: List[Tuple[float, float]] = [(x / STEPS_PER_MM, y / STEPS_PER_MM) for _, x, y in read_trace(trace)]
    moves = moves_of(parse_program(text_of(program), options=options(program)).items)
    index = lib.MoveIndex(moves)
    worst = max(set(steps), key=index.distance)
    assert index.distance(worst) <= ON_PATH, f"{program.name}: the board stepped off the path at {worst}"
    assert math.dist(steps[-1], (moves[-1].x, moves[-1].y)) <= 1 / STEPS_PER_MM
    # All of it, step for step: the host core's steps for the program as the streamer compiles it.
    drawn = [(x, y) for _, x, y in read_trace(trace)]
    assert drawn_whole(drawn, program_steps(text_of(program), config(program)), (0, 0), STEPS_PER_MM) == ""
    assert png.stat().st_size > 0 and f"picture: {png}" in r.stderr


@pytest.mark.ros
def test_a_refused_stream_moves_nothing_and_draws_no_picture(tmp_path):
    from node_processes import new_domain
    program = next(p for p in REFUSED if p.file.startswith("mrbeam"))
    r, trace, png = stream(program, tmp_path, new_domain())
    assert r.returncode == 2
    assert [n for n, _ in program.refused] == [int(m) for m in re.findall(r":line (\d+): (?!note)", r.stderr)]
    assert not png.exists() and "picture:" not in r.stderr
    assert not trace.exists() or trace.read_text().count("\n") <= 1
