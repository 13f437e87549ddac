"""A job's plan before paper (motion/preview.py, `plotter check --svg/--png`):
each pen's paths, the pen-up travel, the lengths, and the board's time, which
the firmware core, running the same commands, takes to within 5 %."""
from __future__ import annotations

import contextlib
import io
import math
from pathlib import Path

import pytest

import gcode_testlib  # noqa: F401  (puts plotter_bridge on the path)
from firmware_build import host_library
from plotter_bridge.cli import main as cli
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from plotter_bridge.motion.preview import duration, preview_program
from plotter_shapes.svg_input import svg_program
from reliability_sim import SimRig

DATA = Path(__file__).parent / "data"


@pytest.fixture
def program(colours):
    """The three-pen drawing of conftest.py as a program."""
    return "\n".join(svg_program(colours)) + "\n"


def test_each_pen_in_its_colour_with_its_length_and_the_travel_through_the_park(program):
    plan = preview_program(program)
    assert [(layer.name, layer.colour) for layer in plan.layers] == [
        ('layer 1 "black"', "#000000"), ('layer 2 "red"', "#ff0000"), ('layer 3 "#0000ff"', "#0000ff")]
    lengths = [layer.length_mm for layer in plan.layers]
    assert lengths == pytest.approx([240.0, 2 * math.pi * 10, 70.0], abs=0.01)
    assert plan.drawn_mm == pytest.approx(sum(lengths))
    assert plan.changes == 2
    parked = [line for line in plan.travel if (0.0, 0.0) in line[1:-1]]
    assert len(parked) == 2, "to the park position and back at each of the two changes"
    assert plan.travel_mm == pytest.approx(sum(sum(math.dist(a, b) for a, b in zip(line, line[1:]))
                                               for line in plan.travel))
    assert "with 3 pens (2 pen changes, not timed)" in plan.summary()


def test_one_pen_without_changes():
    plan = preview_program("G21 G90\nG0 X10 Y10\nM3\nG2 X10 Y10 I5 J0 F1200\nM5\n")
    assert len(plan.layers) == 1 and plan.changes == 0
    assert plan.drawn_mm == pytest.approx(2 * math.pi * 5, abs=0.01)
    assert plan.travel_mm == pytest.approx(math.hypot(10, 10))


def test_durations_as_people_say_them():
    assert [duration(s) for s in (0.4, 42, 185, 3725)] == ["0 s", "42 s", "3 min 05 s", "1 h 02 min"]


def board_seconds(text: str, baud: int) -> tuple:
    """The planned time and the time the firmware core takes, on simulated time at `baud`,
    going on at once at every pen change."""
    config = StreamerConfig(link_baud=baud)
    plan = preview_program(text, config)
    rig = SimRig(library=host_library())
    try:
        rig.port.baud = baud
        rig.connect()
        texts = [c.text for c in compile_program(text, config)]
        job = rig.session.start_job(texts, [1] * len(texts))
        t0 = rig.port.now
        while job.result is None:
            assert rig.run_until(lambda: job.result is not None or job.pen_change is not None, 3600)
            if job.pen_change is not None:
                start = rig.port.now
                assert rig.session.continue_job()[0]
                t0 += rig.port.now - start
        assert job.result.success, job.result
        return plan.seconds, rig.port.now - t0
    finally:
        rig.close()


DRAWINGS = ["corpus/svg/shapes.svg", "corpus/svg/curves.svg", "drawings/vpype/multilayer_named_layers.svg"]


@pytest.mark.parametrize("baud", [9600, 115200])
@pytest.mark.parametrize("drawing", DRAWINGS)
def test_the_planned_time_is_the_board_s_within_5_percent(drawing, baud):
    planned, board = board_seconds("\n".join(svg_program(str(DATA / drawing))) + "\n", baud)
    print(f"{drawing} at {baud} baud: planned {planned:.2f} s, the board {board:.2f} s, "
          f"{(planned - board) / board * 100:+.1f} %")
    assert board > 5.0
    assert abs(planned - board) <= 0.05 * board, (planned, board)


def test_plotter_check_writes_the_preview_with_a_group_per_pen(tmp_path, program):
    text = program
    program = tmp_path / "colours.gcode"
    program.write_text(text)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", str(program), "--svg", str(tmp_path / "plan.svg"),
                         "--png", str(tmp_path / "plan.png")])
    assert code == 0, err.getvalue()
    plan_line = [line for line in out.getvalue().splitlines() if ": plan: " in line]
    assert plan_line and "drawn 372.8 mm with 3 pens" in plan_line[0]
    picture = (tmp_path / "plan.svg").read_text()
    for gid in ("layer-1", "layer-2", "layer-3", "travel"):
        assert f'id="{gid}"' in picture, gid
    assert (tmp_path / "plan.png").read_bytes()[:4] == b"\x89PNG"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        assert cli.main(["check", str(program), "--png", str(tmp_path / "plan.jpg")]) == 2
    assert "--svg takes an .svg file, --png a .png file" in err.getvalue()
