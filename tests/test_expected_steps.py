"""The steps a program should draw, from the firmware core (sim/expected.py),
and a step trace held against them: whole, cut short, astray or too long."""
from __future__ import annotations

import re
from typing import List

import pytest

from firmware_build import host_library
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from plotter_bridge.sim.expected import Point, drawn_whole, program_steps, step_positions
from plotter_shapes.geometry import SEED_FIGURES, goal_program
from reliability_sim import SimRig

CONFIG = StreamerConfig()       # config/plotter.yaml's values: 80 steps/mm


def figure_text(fig: dict) -> str:
    _, lines = goal_program(fig["shape"], fig["x"], fig["y"], fig["size"], fig.get("clockwise", False),
                            fig.get("reverse", False))
    return "\n".join(lines) + "\n"


CAR = figure_text(next(f for f in SEED_FIGURES if f["shape"] == "car"))


def test_lines_step_one_axis_at_a_time_from_the_start():
    steps = step_positions(["P 1", "L 3 0 1000 0", "L 0 -2 1000 0", "P 0"], (100, 200), host_library())
    assert steps == [(101, 200), (102, 200), (103, 200), (103, 199), (103, 198)]


def test_nothing_to_step():
    assert step_positions(["P 1", "P 0"], (5, 5), host_library()) == []


@pytest.mark.parametrize("fig", SEED_FIGURES, ids=lambda f: f["shape"] + ("-reversed" if f.get("reverse") else ""))
def test_a_seed_figure_takes_the_compiled_steps_to_its_end(fig):
    start = (80, 160)
    text = figure_text(fig)
    commands = compile_program(text, CONFIG, start)
    steps = program_steps(text, CONFIG, start, host_library())
    # The compiler counts an arc's steps on the true circle; the firmware's
    # point-by-point arc may take a few more around it.
    assert len(steps) == pytest.approx(sum(c.steps for c in commands if c.is_motion), abs=8)
    end = (start[0] + sum(c.args[0] for c in commands if c.is_motion),
           start[1] + sum(c.args[1] for c in commands if c.is_motion))
    assert steps[-1] == end
    path = [start, *steps]
    assert all(abs(b[0] - a[0]) + abs(b[1] - a[1]) == 1 for a, b in zip(path, path[1:]))


def board_trace(text: str) -> List[Point]:
    """The steps the board takes for a program streamed to it as serial_bridge
    streams a job: the board session over a serial line into the firmware core,
    on simulated time, the core's main loop taking each command as its queue
    frees.  Another way to the core than step_positions' own feeding of it."""
    commands = [c.text for c in compile_program(text, CONFIG, (0, 0))]
    rig = SimRig(library=host_library())
    try:
        rig.connect()
        job = rig.start(commands)
        assert rig.run_until(lambda: job.result is not None, 600), "the job did not end"
        assert job.result.success, job.result
        return [(x, y) for _, x, y in rig.port.steps]
    finally:
        rig.close()


def test_the_whole_drawing_passes():
    expected = program_steps(CAR, CONFIG, (0, 0), host_library())
    drawn = board_trace(CAR)
    assert drawn_whole(drawn, expected, (0, 0), 80.0) == ""
    # The same trace a step short, or with a step astray, is not the whole drawing.
    assert drawn_whole(drawn[:-1], expected, (0, 0), 80.0).startswith(f"the board stepped {len(drawn) - 1} of ")
    astray = drawn[:5000] + [(drawn[5000][0] + 1, drawn[5000][1])] + drawn[5001:]
    assert drawn_whole(astray, expected, (0, 0), 80.0).startswith("the board left the path at step 5001 of ")


def test_a_drawing_cut_short_says_how_far_it_got_and_where_it_stopped():
    steps = program_steps(CAR, CONFIG, (0, 0), host_library())
    cut = steps[:10450]
    why = drawn_whole(cut, steps, (0, 0), 80.0)
    found = re.fullmatch(r"the board stepped 10450 of (\d+) steps, it stopped at X (\S+) Y (\S+) mm "
                         r"\(expected to end at X (\S+) Y (\S+) mm\)", why)
    assert found, why
    assert int(found[1]) == len(steps)
    assert [float(v) * 80 for v in found.groups()[1:]] == pytest.approx([*cut[-1], *steps[-1]])


def test_words_of_each_way_to_differ():
    expected = [(81, 0), (82, 0), (82, 1), (82, 2)]
    assert drawn_whole(expected, expected, (80, 0), 80.0) == ""
    assert drawn_whole(expected[:2], expected, (80, 0), 80.0) == (
        "the board stepped 2 of 4 steps, it stopped at X 1.025 Y 0.0 mm (expected to end at X 1.025 Y 0.025 mm)")
    assert drawn_whole([], expected, (80, 0), 80.0) == (
        "the board stepped 0 of 4 steps, it stopped at X 1.0 Y 0.0 mm (expected to end at X 1.025 Y 0.025 mm)")
    assert drawn_whole([(81, 0), (81, 1), (82, 1), (82, 2)], expected, (80, 0), 80.0) == (
        "the board left the path at step 2 of 4: it stepped to X 1.0125 Y 0.0125 mm "
        "where the program goes to X 1.025 Y 0.0 mm")
    assert drawn_whole(expected + [(82, 3)], expected, (80, 0), 80.0) == (
        "the board stepped 5 steps, 1 more than the 4 programmed, and stopped at X 1.025 Y 0.0375 mm "
        "(expected to end at X 1.025 Y 0.025 mm)")
