"""The forms other tools' programs use (tests/data/real has them whole), one
rule at a time: what each dialect takes, notes, or refuses, naming the
feature; and a program with several bad lines refused with all of them at
once, before anything moves.
"""
from __future__ import annotations

import contextlib
import io
import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)

from plotter_bridge.cli import main as cli  # noqa: E402
from plotter_bridge.gcode.dialect import GCodeOptions  # noqa: E402
from plotter_bridge.gcode.limits import WorkArea  # noqa: E402
from plotter_bridge.gcode.parser import MAX_ERRORS, check_program, moves_of, parse_program  # noqa: E402
from plotter_bridge.gcode.tokens import decode_program  # noqa: E402
from plotter_bridge.gcode.types import (Dwell, GCodeError, GCodeErrors, Move, Pause, PenChange,  # noqa: E402
                                        ToolChange, ZMove)


def read(text: str, dialect: str = "linuxcnc", **kw):
    return parse_program(text, options=GCodeOptions(dialect, **kw))


def notes(text: str, dialect: str = "linuxcnc", **kw):
    return [(n.line, n.text) for n in read(text, dialect, **kw).notes]


def drawn(text: str, dialect: str = "linuxcnc", **kw):
    return [(m.kind, round(m.x, 4), round(m.y, 4)) for m in moves_of(read(text, dialect, **kw).items)
            if m.pen == "down" and not m.rapid]


def refusal(text: str, dialect: str = "linuxcnc", **kw) -> GCodeErrors:
    with pytest.raises(GCodeErrors) as exc:
        read(text, dialect, **kw)
    return exc.value


# ------------------------------------------------------------ every refusal at once

def test_every_bad_line_is_listed_in_line_order():
    exc = refusal("G21 F100\nG1 X1 Q5\nG1 X2\nG1 X3 #1\nM250\nG1 X4\n")
    assert [e.line for e in exc.errors] == [2, 4, 5]
    for error, words in zip(exc.errors, ("unsupported word letter 'Q'", "parameters (#)", "unsupported M code M250")):
        assert words in error.message
    assert str(exc).splitlines()[0] == "line 2: unsupported word letter 'Q'"
    assert exc.line == 2     # a caller that shows one error shows the first


def test_parse_and_work_area_refusals_come_together():
    with pytest.raises(GCodeErrors) as exc:
        check_program("G21 F100\nG1 X300\nG1 X1 Q1\nG1 Y-5\n", WorkArea())
    assert [e.line for e in exc.value.errors] == [2, 3, 4]


def test_a_program_refused_everywhere_lists_at_most_max_errors():
    exc = refusal("F100\n" + "G1 X1 Q1\n" * (MAX_ERRORS + 7))
    assert len(exc.errors) == MAX_ERRORS and exc.more == 7
    assert str(exc).splitlines()[-1] == "... and 7 more refused lines"


def test_check_lists_every_refusal_and_note_and_json_has_a_record_each(tmp_path):
    path = tmp_path / "p.gcode"
    path.write_text("G21 G40 F100\nG1 X1 Q1\nT2 M6\nG1 X2\nM250\n")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        assert cli.main(["check", str(path), "--json"]) == 2
    lines = err.getvalue().splitlines()
    assert [line.split(":")[1] for line in lines[:-1]] == ["line 1", "line 2", "line 3", "line 5"]
    assert lines[-1] == f"{path}: refused: 2 lines the plotter cannot do; nothing moved"
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    assert [(r["line"], r["type"]) for r in records] == [(1, "note"), (2, "error"), (3, "note"), (5, "error")]


def test_a_note_said_on_many_lines_is_one_entry(tmp_path):
    path = tmp_path / "p.gcode"
    path.write_text("G21\nM3\n" + "".join(f"G1 X{k} E{k} F600\n" for k in range(1, 40)) + "M5\n")
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        assert cli.main(["check", str(path), "--dialect", "marlin"]) == 0
    assert err.getvalue().splitlines() == [
        f"{path}:line 3: note: E word: an extruder's, no effect on a plotter (and 38 more lines from line 4 on)"]


# ------------------------------------------------------------ comments and text

def test_comments_of_any_length_and_language():
    text = "(" + "options " * 60 + ")\n; " + "x" * 500 + "\n;Per compatibilità G-Code viewers\n(中文注释)\nG0 X1\n"
    assert len(read(text).items) == 1
    assert decode_program("(é)\nG0 X1\n".encode("latin-1")) == "(é)\nG0 X1\n"   # an old Windows code page
    assert decode_program(b"\xef\xbb\xbfG0 X1\n") == "G0 X1\n"                  # a byte-order mark
    exc = refusal("G0 X1 é\n")
    assert "invalid character U+00E9 outside a comment" in exc.message


# ------------------------------------------------------------ words with no effect

@pytest.mark.parametrize("dialect", ["linuxcnc", "grbl", "marlin"])
def test_modal_words_of_cam_headers_are_notes_everywhere(dialect):
    said = notes("G00 G17 G40 G21 G54\nG90 G64 G49 G80 G91.1\nT1\nM8\nM9\nG0 X1\n", dialect)
    for words in ("G40", "G54", "G64", "G49", "G80", "G91.1", "T1", "M8", "M9"):
        assert any(text.startswith(words) for _, text in said), (words, said)


def test_tool_change_lifts_the_pen_and_waits_for_the_next_one():
    items = read("G21 F100\nM3\nG1 X1\nT2 M6\nG1 X2\n").items
    assert [i.pen for i in items if isinstance(i, PenChange)] == ["down", "up"]
    assert [m.pen for m in moves_of(items)] == ["down", "up"]
    assert [(i.line, i.tool, i.wait) for i in items if isinstance(i, ToolChange)] == [(4, 2, True)]


def test_m1_pauses_as_m0_and_m4_draws_as_m3():
    items = read("G21 F100\nM4\nG1 X1\nM1\nM5\n").items
    assert any(isinstance(i, Pause) and i.line == 4 for i in items)
    assert drawn("G21 F100\nM4\nG1 X1\nM5\n") == [("line", 1.0, 0.0)]


@pytest.mark.parametrize("dialect", ["linuxcnc", "grbl"])
def test_the_spindle_at_zero_lifts_the_pen(dialect):
    """CamBam and SketchUcam write M3 S1000: it draws; S0 stops the spindle as it switches a laser off."""
    assert drawn("G21 F100\nM3 S1000\nG1 X1\nS0\nG1 X2\nS500\nG1 X3\nM5\n", dialect) == [
        ("line", 1.0, 0.0), ("line", 3.0, 0.0)]


# ------------------------------------------------------------ going home

def test_g28_travels_home_with_the_pen_up_through_its_point():
    items = read("G21 F100\nG0 X50 Y40\nM3\nG1 X60\nG28 X70 Y10\nG1 X5\n").items
    moves = moves_of(items)
    assert [(m.x, m.y, m.pen, m.rapid) for m in moves[-3:]] == [
        (70.0, 10.0, "up", True), (0.0, 0.0, "up", True), (5.0, 0.0, "down", False)]


def test_bare_axes_home_only_those_axes():
    """Marlin's G28 X and G28 Y (Makelangelo, gcodeplot); elsewhere a letter needs its number."""
    moves = moves_of(read("G21\nG0 X50 Y40\nG28 X\nG28 Y\n", "marlin").items)
    assert [(m.x, m.y) for m in moves] == [(50.0, 40.0), (0.0, 40.0), (0.0, 0.0)]
    assert "'X' word without a number" in refusal("G21 F100\nG1 X\n").message


def test_g28_z_lifts_the_pen_and_on_a_z_axis_goes_to_z0():
    assert [i.pen for i in read("G21 F100\nG1 Z-1\nG1 X1\nG28 Z0\n").items if isinstance(i, PenChange)] == \
        ["down", "up"]
    z = [i.z for i in parse_program("G21 F100\nG1 Z-3\nG91 G28 Z0\n", z_axis=True).items if isinstance(i, ZMove)]
    assert z == [-3.0, 0.0]


def test_homing_cycle_and_stored_homes_are_refused_with_the_reason():
    assert "the homing cycle runs between jobs" in refusal("$H\nG0 X1\n", "grbl").message
    assert "G28.1 (store the home position) is refused" in refusal("G0 X1\nG28.1\n").message


# ------------------------------------------------------------ drilling: a dot per hole

def test_drilling_cycles_draw_a_dot_at_each_hole():
    items = read("G21 G90 F100\nG0 Z3\nG98 G81 X5 Y10 Z-1 R2\nX20\nG80\nG0 X30\n").items
    moves = moves_of(items)
    assert [(m.x, m.y, m.rapid) for m in moves] == [(5.0, 10.0, True), (20.0, 10.0, True), (30.0, 10.0, True)]
    pens = [(i.line, i.pen) for i in items if isinstance(i, PenChange)]
    assert pens == [(3, "down"), (3, "up"), (4, "down"), (4, "up")]


def test_g82_dwells_at_the_bottom_and_g99_stays_at_r():
    items = read("G21 F100\nG0 Z5\nG99 G82 X1 Y1 Z-1 R-0.5 P0.25\n").items
    assert [type(i).__name__ for i in items] == ["Move", "PenChange", "Dwell"]
    assert items[2].seconds == 0.25          # and R below the pen's threshold: it stays down, at R


def test_drilling_is_refused_where_its_firmware_refuses_it():
    assert "G81 is refused in the grbl dialect" in refusal("G81 X1 Y1 Z-1 R1 F100\n", "grbl").message
    assert "needs R" in refusal("G21 F100\nG81 X1 Y1 Z-1\n").message
    assert "incremental mode (G91)" in refusal("G21 F100 G91\nG81 X1 Y1 Z-1 R1\n").message


# ------------------------------------------------------------ Marlin's forms

def test_makelangelo_servo_and_messages():
    text = "M300\nM200\nG28 X Y\nM280 P0 S90 T50\nM0 Ready black and click\nG0 X10 Y5 F3000.0\n" \
           "M280 P0 S25 T50\nG1 X20 Y5 F3000.0\nM280 P0 S90 T50\nM400\n"
    program = read(text, "marlin", marlin_pen_down=25, marlin_pen_up=90)
    assert drawn(text, "marlin", marlin_pen_down=25, marlin_pen_up=90) == [("line", 20.0, 5.0)]
    assert any(isinstance(i, Pause) and i.line == 5 for i in program.items)
    said = dict(notes(text, "marlin", marlin_pen_down=25, marlin_pen_up=90))
    assert said[1].startswith("M300: not a servo angle") and said[2].startswith("M200")
    assert said[5] == "message 'Ready black and click': shown here, not on the board"


def test_unicorn_servo_off_beep_and_its_last_z_do_not_move_the_pen():
    text = "G21\nM300 S50 (pen down)\nG4 P150\nG1 X10 F3500\nM300 S45 (pen up)\nM300 S255 (turn off servo)\n" \
           "G1 Z0.00 F150.00 (go up to finished level)\nG1 X0 Y0 F3500\n"
    assert drawn(text, "marlin", marlin_pen_down=50, marlin_pen_up=45) == [("line", 10.0, 0.0)]
    said = [t for _, t in notes(text, "marlin", marlin_pen_down=50, marlin_pen_up=45)]
    assert any(t.startswith("M300 S255: not a servo angle") for t in said)
    assert any(t.startswith("Z does not move the pen") for t in said)


def test_gcodeplot_endstop_and_extruder_words_and_marlins_default_feed():
    text = "G00 S1; endstops\nG00 E0; no extrusion\nG1 Z0\nG1 X10\nG1 Z2.5\n"
    moves = moves_of(read(text, "marlin").items)
    assert [(m.x, m.feed, m.pen) for m in moves] == [(10.0, 1500.0, "down")]
    assert "no feed rate for G1" in refusal(text.replace("E0", "X0"), "grbl").message


def test_servo_angles_out_of_range_or_unknown_are_refused():
    assert "a servo angle is 0..180" in refusal("M280 P0 S200\nG0 X1\n", "marlin").message
    assert "neither the pen-down angle 30" in refusal("M300 S40\nG0 X1\n", "marlin").message
    assert notes("M280 P1 S40\nG0 X1\n", "marlin")[0][1].startswith("M280 P1: servo 1 is not the pen's")


def test_m0_text_is_a_message_only_in_marlin():
    assert "(Marlin writes a message after M0/M1/M117: --dialect marlin)" in \
        refusal("G0 X1\nM0 Pen In\n").message
    assert any(isinstance(i, Pause) for i in read("G0 X1\nM0 Pen In\n", "marlin").items)


# ------------------------------------------------------------ grbl's lines for the board

def test_grbl_queries_are_notes_and_jogging_is_refused():
    said = notes("$I\n$$\n?\n$G\n$X\nG0 X1\n", "grbl")
    assert [line for line, _ in said] == [1, 2, 3, 4, 5]
    assert "jogging is not part of a program" in refusal("$J=G91 X10 F100\nG0 X1\n", "grbl").message


def test_k_on_an_xy_arc_is_taken_as_its_firmware_takes_it():
    """FreeCAD's grbl post writes K0 on every arc: grbl and Marlin ignore it, LinuxCNC refuses it."""
    assert drawn("G21 F100\nM3\nG2 X2 Y0 I1 J0 K0\n", "grbl") == [("arc", 2.0, 0.0)]
    assert "K on an arc in the XY plane" in refusal("G21 F100\nM3\nG2 X2 Y0 I1 J0 K0\n").message
    assert "K word without an arc" in refusal("G21 F100\nG1 X1 K0\n", "grbl").message


# ------------------------------------------------------------ what stays refused, named

@pytest.mark.parametrize("text, words", [
    ("G38.2 Z-5 F10\n", "probing"),
    ("o100 sub\n", "O-words"),
    ("G41 D1\nG0 X1\n", "cutter radius compensation"),
    ("#1=5\nG0 X1\n", "parameters (#)"),
    ("G0 X[1+2]\n", "expressions"),
    ("M100 P100\nG0 X1\n", "a machine's own command"),
])
def test_what_stays_refused_names_the_feature(text, words):
    assert words in refusal(text).message


def test_dwell_units_are_the_dialects():
    assert [i.seconds for i in read("G4 P150\nG0 X1\n", "marlin").items if isinstance(i, Dwell)] == [0.15]
    assert [i.seconds for i in read("G4 P1.5\nG0 X1\n").items if isinstance(i, Dwell)] == [1.5]


def test_a_move_item_keeps_its_pen_when_notes_come_between():
    items = read("G21 F100\nM3\nG1 X1\nM8\nG1 X2\n").items
    assert [m.pen for m in items if isinstance(m, Move)] == ["down", "down"]


def test_single_errors_still_raise_gcode_error():
    with pytest.raises(GCodeError):
        read("G1 X1 Q1\n")
