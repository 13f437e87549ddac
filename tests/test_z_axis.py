"""G-code Z as a third axis (z_mode axis, firmware ZAXIS=1) on the host side:
the status report's Z field, the parser's order of Z and XY, the Z travel,
the board commands in both modes, resuming a job with Z moves, and the
compiled commands run on the firmware core built with the Z axis.  No ROS."""
import contextlib
import io
import json

import pytest

from firmware_build import host_library
from plotter_bridge.cli import main as cli
from plotter_bridge.motion.commands import MAX_DELTA
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.gcode.parser import GCodeError, Move, PenChange, ZMove, parse
from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.link.journal import JobRecord, resume_commands
from plotter_bridge.motion.kinematics import Machine
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from plotter_bridge.link.protocol import Status, checksum, parse_reply

AXIS = StreamerConfig(z_mode="axis")       # 80 steps/mm in X and Y, 400 in Z
PROGRAM = "G21 G90\nG0 X10 Y0 Z2\nG1 Z-0.5 F300\nG1 X20 F1200\nG0 Z2\nM2\n"


def signed(text):
    return f"{text} *{checksum(text + ' ')}"


def kinds(items):
    return [type(i).__name__ for i in items]


# ------------------------------------------------------------------ status

def test_status_report_with_and_without_z():
    assert parse_reply(signed("<Idle X0 Y5 Z-120 Q6 N3 S2 P0 U0 A0>")) == \
        Status("Idle", 0, 5, 6, 3, 2, False, 0, 0, z=-120)
    plain = parse_reply(signed("<Run X12 Y-3 Q4 N18 S17 P1 U0 A0>"))
    assert plain == Status("Run", 12, -3, 4, 18, 17, True, 0, 0) and plain.z is None
    assert parse_reply(signed("<Idle X0 Y5 Z Q6 N3 S2 P0 U0 A0>")) is None


# ------------------------------------------------------------------ parser

def test_z_alone_is_a_z_move_at_the_feed():
    items = parse("G21 F300\nG1 Z-1\n", z_axis=True)
    assert items == [ZMove(2, 0.0, -1.0, 300.0)]


def test_z_with_xy_goes_first_except_a_rapid_going_down():
    items = parse("F600\nG1 X5 Z-1\nG0 X10 Z2\nG0 X20 Z-0.5\nG1 X30\n", z_axis=True)
    assert kinds(items) == ["ZMove", "Move", "ZMove", "Move", "Move", "ZMove", "Move"]
    plunge, cut, retract, travel, travel2, lower, draw = items
    assert (plunge.sz, plunge.z, plunge.rapid) == (0.0, -1.0, False)
    assert (retract.z, retract.rapid, retract.feed) == (2.0, True, 3000.0)
    assert (travel2.x, lower.z, lower.rapid) == (20.0, -0.5, True)
    # The pen output is not Z's: it stays up without M3.
    assert all(m.pen == "up" for m in items if isinstance(m, Move))


def test_pen_mode_is_the_default_and_unchanged():
    items = parse("F600\nG1 X5 Z-1\n")
    assert items == [PenChange(2, "down"), Move(2, "line", 0.0, 0.0, 5.0, 0.0, 600.0, "down")]
    assert not any(isinstance(i, ZMove) for i in parse(PROGRAM))


def test_m3_m5_still_drive_the_pen_with_a_z_axis():
    items = parse("F600\nM3\nG1 Z-1\nG1 X5\nM5\n", z_axis=True)
    assert kinds(items) == ["PenChange", "ZMove", "Move", "PenChange"]
    assert items[2].pen == "down"


def test_z_starts_where_the_board_is_incremental_offsets_and_inches():
    assert parse("F100 G91\nG1 Z-1\n", z_axis=True, start_z=2.5) == [ZMove(2, 2.5, 1.5, 100.0)]
    assert parse("F100\nG1 Z-1\n", z_axis=True, start_z=2.5) == [ZMove(2, 2.5, -1.0, 100.0)]
    # G92 Z0 where Z is 2.5: Z-1 is then 1.5 from the origin.
    items = parse("F100\nG92 Z0\nG1 Z-1\n", z_axis=True, start_z=2.5)
    assert items == [ZMove(3, 2.5, 1.5, 100.0)]
    (z,) = parse("G20 F10\nG1 Z-0.1\n", z_axis=True)
    assert z.z == pytest.approx(-2.54) and z.feed == pytest.approx(254.0)


def test_unchanged_z_makes_no_z_move_and_a_z_only_program_is_a_program():
    assert kinds(parse("F100\nG1 Z0 X1\n", z_axis=True)) == ["Move"]
    assert kinds(parse("F100\nG1 Z1\nG1 Z1\n", z_axis=True)) == ["ZMove"]
    with pytest.raises(GCodeError, match="makes no moves"):
        parse("F100\nG1 Z0\n", z_axis=True)


def test_helical_arc_is_refused_naming_the_line():
    with pytest.raises(GCodeError) as exc:
        parse("G21 F100\nG1 X10\nG2 X20 I5 Z-1\n", z_axis=True)
    assert exc.value.line == 3
    assert "helical arc" in exc.value.message and "G2" in exc.value.message
    assert "Z0 to Z-1" in exc.value.message
    # An arc whose Z word does not change Z is a plain arc; with the pen, Z is the pen.
    assert kinds(parse("G21 F100\nG1 Z-1\nG3 X10 I5 Z-1\n", z_axis=True)) == ["ZMove", "Move"]
    assert kinds(parse("G21 F100\nG2 X10 I5 Z-1\n")) == ["PenChange", "Move"]


def test_z_travel_is_checked_before_anything_moves():
    with pytest.raises(GCodeError) as exc:
        compile_program("G21\nG1 Z-1 F100\nG1 X10\nG1 Z-60\n", AXIS)
    assert exc.value.line == 4 and "Z-60.0000" in exc.value.message and "-50..50" in exc.value.message
    deep = StreamerConfig(z_mode="axis", area=WorkArea(z_min=-100.0, z_max=5.0))
    assert compile_program("G21\nG1 Z-60 F100\n", deep)
    with pytest.raises(GCodeError, match="Z axis' travel"):
        compile_program("G21\nG0 Z6\n", deep)


def test_bad_z_settings_are_refused():
    with pytest.raises(ValueError, match="z_mode"):
        StreamerConfig(z_mode="up")
    with pytest.raises(ValueError, match="z_steps_per_mm"):
        StreamerConfig(z_mode="axis", z_steps_per_mm=0.0)
    with pytest.raises(ValueError, match="z_mode"):
        Machine(z_mode="spindle")


# ------------------------------------------------------------------ board commands

def texts(commands):
    return [c.text for c in commands]


def test_compiled_program_in_both_modes():
    # Rapid: 6000 mm/min = 8000 steps/s in X and Y, 40000 in Z (the ramp's top, 12850);
    # the plunge at 300 mm/min is 2000 steps/s of Z.
    assert texts(compile_program(PROGRAM, StreamerConfig())) == [
        "P 0", "L 800 0 8000 0", "P 1", "L 800 0 1600 0", "P 0"]
    assert texts(compile_program(PROGRAM, AXIS)) == [
        "Z 800 12850 0", "P 0", "L 800 0 8000 0", "Z -1000 2000 0", "L 800 0 1600 0", "Z 1000 12850 0"]
    # From a board whose Z is already 2 mm up, and from one 2 mm down.
    assert texts(compile_program(PROGRAM, AXIS, (0, 0), 800))[0] == "P 0"
    assert texts(compile_program(PROGRAM, AXIS, (0, 0), -800))[0] == "Z 1600 12850 0"


def test_z_moves_start_and_end_at_rest():
    program = "G21 G90 F1200\nG1 X10\nG1 X20 Z-1\nG1 X30\nG1 X40\n"
    commands = compile_program(program, AXIS)
    assert texts(commands)[:4] == ["P 0", "L 800 0 1600 0", "Z -400 8000 0", "L 800 0 1600 1600"]
    assert commands[-1].exit_rate == 0


def test_z_rounds_absolute_positions_and_splits_long_moves():
    program = "G21 G91 F600\n" + "G1 Z0.0013\n" * 1000
    zs = [c.args[0] for c in compile_program(program, AXIS)]
    assert sum(zs) == round(1.3 * 400) and set(zs) <= {0, 1}
    fine = StreamerConfig(z_mode="axis", z_steps_per_mm=1000.0)
    long = compile_program("G21\nG1 Z-45 F600\n", fine)
    assert [c.verb for c in long] == ["Z", "Z"]
    assert sum(c.args[0] for c in long) == -45000 and all(abs(c.args[0]) <= MAX_DELTA for c in long)


def test_hanging_machine_with_a_z_axis():
    config = StreamerConfig(machine="hanging", area=WorkArea(0, 800, 0, 1000), z_mode="axis")
    commands = compile_program("G21\nG0 X100 Y100\nG1 Z-1 F300\nG1 X110\n", config)
    assert [c.verb for c in commands].count("Z") == 1
    assert commands[[c.verb for c in commands].index("Z")].args == (-400,)


def test_check_command_shows_z_moves(tmp_path):
    path = tmp_path / "z.gcode"
    path.write_text(PROGRAM)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        assert cli.main(["check", str(path), "--z-axis", "--json"]) == 0
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    assert records[0] == {"line": 2, "type": "z", "z": 2.0, "feed": 3000.0, "rapid": True}
    assert [r["type"] for r in records] == ["z", "line", "z", "line", "z"]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli.main(["check", str(path), "--z-axis"]) == 0
    assert "3 Z moves" in out.getvalue() and "z-200" in out.getvalue()


# ------------------------------------------------------------------ resume

def test_resume_brings_z_back_where_the_command_starts():
    record = JobRecord("ab" * 16, "engrave", ["Z -400 2000 0", "L 800 0 1600 0", "Z 800 8000 0", "L 0 800 8000 0",
                                               "Z -800 2000 0", "L -800 0 1600 0"],
                       [2, 3, 4, 5, 6, 7], (0, 0), False, 8000, start_z=0)
    # Stopped in the plunge: the rest of it first, alone.
    assert resume_commands(record, 0, (0, 0), False, -100)[0][:2] == ["Z 100 8000 0", "Z -400 2000 0"]
    # Moved away and lower (a reset after the retract was sent): up first, then the travel.
    head = resume_commands(record, 3, (300, 0), False, -400)[0][:2]
    assert head == ["Z 800 8000 0", "L 500 0 8000 0"]
    # Higher than the command starts (at -400): the travel first, then down.
    head = resume_commands(record, 5, (0, 0), False, 400)[0][:2]
    assert head == ["L 800 800 8000 0", "Z -800 8000 0"]
    # A job without a Z axis ignores it.
    plain = JobRecord("cd" * 16, "square", ["L 100 0 2000 0"], [1], (0, 0))
    assert resume_commands(plain, 0, (0, 0), False, 50) == (["L 100 0 2000 0"], [1])


# ------------------------------------------------------------------ on the firmware core

def run(library, commands):
    """Typed commands through the core's UART: every step as ("x"|"y"|"z", d, z
    at that step), and the end position."""
    core = FirmwareCore(library)
    try:
        core.transmitted()
        steps = []
        (x1, y1), z1 = core.position, core.position_z or 0
        for _ in core.interrupts(commands):
            (x0, y0), z0 = (x1, y1), z1
            (x1, y1), z1 = core.position, core.position_z or 0
            for axis, d in (("x", x1 - x0), ("y", y1 - y0), ("z", z1 - z0)):
                if d:
                    steps.append((axis, d, z1))
        assert b"err" not in core.transmitted()
        return steps, (*core.position, core.position_z)
    finally:
        core.close()


def test_compiled_z_program_on_the_z_axis_core():
    program = ("G21 G90\nG0 X5 Y5 Z3\nG1 Z-1 F300\nG1 X15 Y12 F1200\nG2 X25 Y12 I5 J0\n"
               "G0 Z3\nG0 X40 Y30 Z-0.25\nG1 X30 Y35\nM2\n")
    commands = texts(compile_program(program, AXIS))
    steps, end = run(host_library(ZAXIS="1"), commands)
    assert end == (30 * 80, 35 * 80, -100)

    def xy_at(z):
        moved = [(a, d) for a, d, at in steps if a != "z" and at == z]
        return sum(d for a, d in moved if a == "x"), sum(d for a, d in moved if a == "y")
    # Travel with Z up, the cut (line and arc) all at Z -1 mm, the last line
    # after the rapid's travel has brought Z down to -0.25 mm.
    assert xy_at(3 * 400) == (5 * 80 + 15 * 80, 5 * 80 + 18 * 80)
    assert xy_at(-400) == (20 * 80, 7 * 80)
    assert xy_at(-100) == (-10 * 80, 5 * 80)
    # X and Y step for step as the default core steps the same XY commands.
    default, default_end = run(host_library(), [c for c in commands if not c.startswith("Z")])
    assert [(a, d) for a, d, _ in steps if a != "z"] == [(a, d) for a, d, _ in default]
    assert default_end == (*end[:2], None)
