"""Pen changes: M6 once something is drawn stops the job, pen up and parked, until resume.

From the G-code (gcode/parser.py, gcode/pens.py) through the compiler to the
bridge's session (link/board_session.py) on the firmware core, without ROS.
"""
from __future__ import annotations

from dataclasses import replace

import pytest

import gcode_testlib  # noqa: F401  (puts plotter_bridge on the path)
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.parser import parse_program
from plotter_bridge.gcode.pens import label_colour, park_for_changes
from plotter_bridge.gcode.types import GCodeError, Move, Note, ToolChange
from plotter_bridge.link.journal import JobRecord, resume_commands
from plotter_bridge.link.protocol import pen_change_number
from plotter_bridge.motion.compiler import StreamerConfig, compile_program

TWO_PENS = ("G21 G90 F1200\nT1 M6 (layer 1 \"black\" #000000)\nG0 X10 Y10\nM3\nG1 X30\nM5\n"
            "T2 M6 (layer 2 \"red\" #FF0000)\nG0 X10 Y20\nM3\nG1 X30\nM5\n")


def items_of(text: str):
    return parse_program(text).items


# ------------------------------------------------------------ the G-code

def test_m6_after_drawing_is_a_pen_change_with_its_tool_and_comment():
    items = items_of(TWO_PENS)
    changes = [i for i in items if isinstance(i, ToolChange) and i.wait]
    assert changes == [ToolChange(7, 2, 'layer 2 "red" #FF0000')]
    assert label_colour(changes[0].label) == "#ff0000"
    # the pen is up before it, and the move after it is drawn again once M3 says so
    k = items.index(changes[0])
    assert [m.pen for m in items[:k] if isinstance(m, Move)][-1] == "down"
    assert all(m.pen == "up" for m in items[k:k + 2] if isinstance(m, Move))


def test_m6_before_anything_is_drawn_is_a_note_and_the_job_goes_on():
    program = parse_program("T1 M6 (black)\nG0 X5\nM3\nG1 X6 F100\n")
    assert [i for i in program.items if isinstance(i, ToolChange)] == [ToolChange(1, 1, "black", wait=False)]
    assert not [c for c in compile_program("T1 M6 (black)\nG0 X5\nM3\nG1 X6 F100\n", StreamerConfig())
                if c.verb == "M6"], "nothing to wait for"
    assert any(isinstance(n, Note) and n.text.startswith("M6 tool change") for n in program.notes)


def test_a_semicolon_comment_names_the_pen_and_t_alone_only_selects():
    items = items_of("G1 X1 F100 Z-1\nT3 ; blue pen #0000ff\nG1 X2\nM6 ; blue pen #0000ff\nG1 X3\n")
    assert [i for i in items if isinstance(i, ToolChange)] == [ToolChange(4, 3, "blue pen #0000ff")]


# ------------------------------------------------------------ parking

def test_the_pen_goes_to_park_and_back_around_each_change():
    items = items_of(TWO_PENS)
    parked = park_for_changes(items, (0.0, 0.0))
    k = next(i for i, item in enumerate(parked) if isinstance(item, ToolChange) and item.wait)
    out, back = parked[k - 1], parked[k + 1]
    assert (out.rapid, out.sx, out.sy, out.x, out.y) == (True, 30.0, 10.0, 0.0, 0.0)
    assert (back.rapid, back.sx, back.sy, back.x, back.y) == (True, 0.0, 0.0, 30.0, 10.0)
    assert park_for_changes(items, None) == list(items)


def test_compiled_the_change_is_one_command_after_the_pen_is_lifted():
    commands = compile_program(TWO_PENS, StreamerConfig())
    texts = [c.text for c in commands]
    k = next(i for i, t in enumerate(texts) if pen_change_number(t) is not None)
    assert texts[k] == "M6 0" and commands[k].note == 'layer 2 "red" #FF0000'
    assert "P 0" in texts[:k] and texts[:k].index("P 0") < k
    # out to the park position (0, 0) from X30 Y10: -2400, -800 steps, and the same back
    before, after = commands[k - 1], commands[k + 1]
    assert before.verb == after.verb == "L"
    assert before.args == (-2400, -800) and after.args == (2400, 800)
    assert before.exit_rate == 0 and after.exit_rate >= 0


def test_a_park_position_outside_the_work_area_is_refused_at_the_m6():
    config = StreamerConfig(area=WorkArea(5, 200, 5, 200))
    with pytest.raises(GCodeError) as exc:
        compile_program(TWO_PENS.replace("X10", "X15"), config)
    assert exc.value.line == 7 and "park position" in exc.value.message
    assert compile_program(TWO_PENS.replace("X10", "X15"), replace(config, park=(5.0, 5.0)))


# ------------------------------------------------------------ the session holds the job

def start(rig, texts):
    job = rig.session.start_job(texts, list(range(1, len(texts) + 1)))
    assert job.result is None, job.result
    return job


def test_the_job_waits_at_the_change_with_nothing_moving_until_continued(rig):
    texts = [c.text for c in compile_program(TWO_PENS, StreamerConfig())]
    k = texts.index("M6 0")
    job = start(rig, texts)
    assert rig.run_until(lambda: job.pen_change is not None, 60)
    assert job.pen_change == 0 and job.result is None
    assert rig.run_until(lambda: rig.session.link.status.state == "Hold", 2), "the board is held for it"
    assert not rig.core.pen_down and rig.core.position == (0, 0), "parked at (0, 0) with the pen up"
    assert job.started == k + 1 and job.submitted == job.part_end == k + 1
    steps = len(rig.port.steps)
    rig.run_until(lambda: job.result is not None, 5.0)
    assert job.result is None and len(rig.port.steps) == steps, "nothing moves while the pen is changed"
    ok, message = rig.session.continue_job()
    assert ok, message
    assert rig.run_until(lambda: job.result is not None, 60)
    assert job.result.success and (job.result.executed, job.result.completed) == (len(texts), len(texts))
    assert rig.core.position == (30 * 80, 20 * 80)
    assert rig.session.continue_job()[0] is False


def test_a_job_canceled_at_the_change_resumes_at_the_change(rig):
    texts = [c.text for c in compile_program(TWO_PENS, StreamerConfig())]
    job = start(rig, texts)
    assert rig.run_until(lambda: job.pen_change is not None, 60)
    rig.session.cancel(job, timeout=0)
    assert rig.run_until(lambda: job.result is not None, 10)
    assert not job.result.success
    k = texts.index("M6 0")
    assert job.result.completed == k, "the change itself is not done"
    record = JobRecord("0" * 32, "two pens", texts, list(range(1, len(texts) + 1)), (0, 0))
    rest, _ = resume_commands(record, job.result.completed, rig.core.position, rig.core.pen_down)
    assert rest[0] == "M6 0", "the resumed job starts with the pen change again"
    job2 = start(rig, rest)
    assert rig.run_until(lambda: job2.pen_change is not None, 60)
    assert rig.session.continue_job()[0]
    assert rig.run_until(lambda: job2.result is not None, 60) and job2.result.success
    assert rig.core.position == (30 * 80, 20 * 80)


def press_on_the_panel(rig, key: int, ms: int = 30) -> None:
    """A key of the board's keypad held for `ms` ms, the panel ticking every millisecond."""
    from panel_keys import NO_KEY
    for k in (key, NO_KEY):
        rig.core._lib.core_set_key(k)
        for _ in range(ms):
            rig.core.panel_tick()
            rig.step(0.001)


def test_the_board_s_pause_resume_key_goes_on_after_a_pen_change(rig):
    from panel_keys import K_PAUSE
    texts = [c.text for c in compile_program(TWO_PENS, StreamerConfig())]
    job = start(rig, texts)
    assert rig.run_until(lambda: job.pen_change is not None and rig.session.link.status.state == "Hold", 60)
    rig.run_until(lambda: False, 1.0)
    assert job.pen_change == 0, "the hold alone does not go on"
    press_on_the_panel(rig, K_PAUSE)
    assert rig.run_until(lambda: job.result is not None, 60)
    assert job.result.success and rig.core.position == (30 * 80, 20 * 80)
    assert any("resumed on the board's panel" in line for line in rig.log)


# ------------------------------------------------------------ the plotter command's prompt

def test_the_prompt_asks_once_per_change_and_goes_on_or_gives_up():
    import contextlib
    import io
    from typing import Callable
    from node_processes import wait_until
    from plotter_bridge.cli.pens import PenPrompt, watch_session
    went, gave_up = [], []
    err = io.StringIO()
    answers = iter([True, False])
    prompt = PenPrompt(err, lambda: (went.append(1), (True, "ok"))[1], ask=lambda: next(answers),
                       give_up=lambda: gave_up.append(1))
    state = {"at": (0, 'layer 2 "red" #ff0000'), "polls": 0}

    def waiting():
        state["polls"] += 1
        return state["at"]

    def polled(times: int) -> Callable[[], bool]:
        """True once the watch has read the state `times` times after now."""
        seen = state["polls"]
        return lambda: state["polls"] >= seen + times
    stop = watch_session(prompt, waiting, period=0.01)
    try:
        wait_until(lambda: went, 10, "the job to go on")
        wait_until(polled(10), 10, "the same change seen again")      # and again: asked once
        assert went == [1] and prompt.changes == 1
        state["at"] = None
        wait_until(polled(1), 10, "the change seen over")
        state["at"] = (1, 'layer 3 "blue" #0000ff')
        with contextlib.suppress(TimeoutError):
            wait_until(lambda: gave_up, 10, "the job to give up")
        assert gave_up == [1] and went == [1], "no answer: canceled there, not gone on"
    finally:
        stop.set()
    said = err.getvalue()
    assert 'put in layer 2 "red" #ff0000, then press Enter' in said and "no one to change the pen" in said
    # Without anyone to ask (--no-pen-wait): said once, and the job goes on once.
    told = io.StringIO()
    quiet = PenPrompt(told, lambda: (went.append(2), (True, "ok"))[1])
    quiet.at(0, "pen 2")
    quiet.at(0, "pen 2")
    with contextlib.suppress(TimeoutError):
        wait_until(lambda: 2 in went, 10, "the quiet prompt to go on")
    assert went == [1, 2] and quiet.changes == 1
    assert told.getvalue() == "pen change: pen 2 (not waited for: --no-pen-wait)\n"


def test_an_emergency_stop_at_a_pen_change_ends_the_job_there(rig):
    texts = [c.text for c in compile_program(TWO_PENS, StreamerConfig())]
    job = start(rig, texts)
    assert rig.run_until(lambda: job.pen_change is not None and rig.session.link.status.state == "Hold", 60)
    rig.session.realtime("estop", timeout=0)
    assert rig.run_until(lambda: job.result is not None, 5)
    assert not job.result.success and "emergency stop" in job.result.message
    assert job.result.completed == texts.index("M6 0"), "resumable at the pen change"
    assert rig.session.continue_job()[0] is False
    at = rig.core.position
    rig.run_until(lambda: False, 1.0)
    assert rig.core.position == at == (0, 0)
