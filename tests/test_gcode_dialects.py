"""G-code dialects (gcode/dialect.py): grbl's power word, Marlin's pen servo
and dwell in milliseconds, the pen from Z by threshold, notes and refusals.

The main check is a sweep: random programs written the LinuxCNC way are
rewritten line for line in each dialect's own forms, with several power
values, servo angles and pen_up_z thresholds, and must give the same moves,
pens and dwells.  No ROS.
"""
from __future__ import annotations

import contextlib
import io
import math
import random
import sys
from pathlib import Path
from typing import List, Tuple

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)

from plotter_bridge.cli import main as cli  # noqa: E402
from plotter_bridge.gcode.dialect import DIALECTS, GCodeOptions  # noqa: E402
from plotter_bridge.gcode.parser import GCodeError, parse, parse_program  # noqa: E402
from plotter_bridge.gcode.types import Dwell, Move, PenChange  # noqa: E402
from plotter_bridge.motion.compiler import StreamerConfig, compile_program  # noqa: E402

NOOP = "(no-op)"     # where a dialect's accepted-without-effect word goes
DOWN, UP = "(pen down)", "(pen up)"


def linuxcnc_program(rng: random.Random) -> List[str]:
    """Random lines, arcs, pen changes, dwells and no-op slots, LinuxCNC-style pen."""
    lines = ["G21 G90", f"F{rng.choice([300, 1200, 2500])}"]
    x, y = 0.0, 0.0    # where parse starts
    for _ in range(rng.randint(6, 25)):
        r = rng.random()
        if r < 0.2:
            lines.append(rng.choice([DOWN, UP]))
        elif r < 0.3:
            lines.append(f"G4 P{rng.choice(['0.15', '0.5', '2', '0'])}")
        elif r < 0.4:
            lines.append(NOOP)
        elif r < 0.75:
            x, y = round(x + rng.uniform(-30, 30), 3), round(y + rng.uniform(-30, 30), 3)
            lines.append(f"{rng.choice(['G0', 'G1'])} X{x} Y{y}")
        else:
            radius = rng.uniform(2, 20)
            a0, sweep = rng.uniform(0, 2 * math.pi), rng.uniform(0.3, 5.5)
            cx, cy = x - radius * math.cos(a0), y - radius * math.sin(a0)
            tx, ty = round(cx + radius * math.cos(a0 + sweep), 3), round(cy + radius * math.sin(a0 + sweep), 3)
            lines.append(f"G3 X{tx} Y{ty} I{cx - x:.6f} J{cy - y:.6f}")
            x, y = tx, ty
    lines.append(DOWN)
    lines.append(f"G1 X{x + 1} Y{y}")
    lines.append("M2")
    return lines


def in_dialect(lines: List[str], dialect: str, rng: random.Random,
               angles: Tuple[float, float] = (30.0, 50.0)) -> Tuple[str, List[int]]:
    """The program in the dialect's forms, line for line; and the lines that must give a note."""
    out, noted = [], []
    spindle = False
    for number, line in enumerate(lines, start=1):
        if line == DOWN:
            if dialect == "grbl":
                power = rng.choice([1, 255, 1000, 0.5])
                # S alone turns the power up again when M3 is already in force.
                out.append(f"S{power}" if spindle and rng.random() < 0.3 else f"M3 S{power}")
                spindle = True
            elif dialect == "marlin":
                out.append(f"M300 S{angles[0]:g}")
            else:
                out.append("M3")
        elif line == UP:
            if dialect == "grbl":
                out.append(rng.choice(["M5", "M3 S0"] + (["S0"] if spindle else [])))
                spindle = spindle and not out[-1] == "M5"
            elif dialect == "marlin":
                out.append(f"M300 S{angles[1]:g}")
            else:
                out.append("M5")
        elif line.startswith("G4 P") and dialect == "marlin":
            out.append(f"G4 P{float(line[4:]) * 1000:g}")
        elif line == NOOP:
            word = rng.choice({"linuxcnc": ["G64", "G61"], "grbl": ["G54", "M7", "M8", "M9", "G64", "G61"],
                               "marlin": ["M17", "M18", "M84", "G64"]}[dialect])
            out.append(word)
            noted.append(number)
        else:
            out.append(line)
    return "\n".join(out) + "\n", noted


def normalised(items) -> List[tuple]:
    """Items comparable across dialects: dwells to the microsecond."""
    out = []
    for item in items:
        if isinstance(item, Dwell):
            out.append(("dwell", item.line, round(item.seconds, 6)))
        else:
            out.append(item)
    return out


@pytest.mark.parametrize("seed", range(60))
@pytest.mark.parametrize("dialect", sorted(DIALECTS))
def test_each_dialect_draws_what_linuxcnc_draws(seed, dialect):
    rng = random.Random(seed)
    lines = linuxcnc_program(rng)
    reference, _ = in_dialect(lines, "linuxcnc", random.Random(0))
    angles = [(30.0, 50.0), (90.0, 0.0), (12.5, 140.0)][seed % 3]
    text, noted = in_dialect(lines, dialect, rng, angles)
    options = GCodeOptions(dialect, marlin_pen_down=angles[0], marlin_pen_up=angles[1])
    program = parse_program(text, options=options)
    expected = parse(reference)
    assert normalised(program.items) == normalised(expected), text
    assert [note.line for note in program.notes] == noted, text
    # A program drawing something must have drawn: the sweep is not vacuous.
    assert any(isinstance(i, Move) and i.pen == "down" for i in program.items)


@pytest.mark.parametrize("pen_up_z", [-2.0, -0.5, 0.0, 0.3, 1.0, 5.0])
@pytest.mark.parametrize("dialect", sorted(DIALECTS))
def test_pen_from_z_by_threshold(pen_up_z, dialect):
    # A seed of its own per case (str hashes change with each process), and the levels on both
    # sides of the threshold and at it each appear: the check is never vacuous.
    rng = random.Random(f"{dialect}/{pen_up_z}")
    levels = [-3.0, -1.0, -0.5, 0.0, 0.3, 1.0, 2.0, 5.0, 6.0, pen_up_z]
    zs = [pen_up_z - 1.0, pen_up_z, pen_up_z + 1.0] + [rng.choice(levels) for _ in range(37)]
    rng.shuffle(zs)
    lines, expected = ["G21 G90 F600"], []
    for k, z in enumerate(zs):
        lines.append(f"G1 X{k + 1} Z{z}")
        expected.append("up" if z > pen_up_z else "down")
    moves = [m for m in parse("\n".join(lines) + "\n", options=GCodeOptions(dialect, pen_up_z))
             if isinstance(m, Move)]
    assert [m.pen for m in moves] == expected
    assert set(expected) == {"up", "down"}


def test_pen_up_z_default_is_the_linuxcnc_rule():
    items = parse("F100\nG1 X1 Z0\nG1 X2 Z0.001\nG1 X3 Z-0.001\n")
    assert [m.pen for m in items if isinstance(m, Move)] == ["down", "up", "down"]


@pytest.mark.parametrize("p, dialect, seconds", [
    ("150", "marlin", 0.15), ("2000", "marlin", 2.0), ("0", "marlin", 0.0),
    ("150", "linuxcnc", 150.0), ("0.5", "linuxcnc", 0.5), ("1.5", "grbl", 1.5), ("150", "grbl", 150.0)])
def test_dwell_units(p, dialect, seconds):
    items = parse(f"G4 P{p}\nG0 X1\n", options=GCodeOptions(dialect))
    assert items[0] == Dwell(1, pytest.approx(seconds))


def test_marlin_dwell_in_seconds_with_s():
    items = parse("G4 S2\nG0 X1\n", options=GCodeOptions("marlin"))
    assert items[0] == Dwell(1, 2.0)


def test_grbl_power_rules():
    text = ("G21 F100\nM3\nG1 X1\nS0\nG1 X2\nS10\nG1 X3\nM5\nG1 X4\nS20\nG1 X5\n"
            "M4 S300\nG1 X6\nG1 X7 S0\nM3 S0\nG1 X8\n")
    moves = [m for m in parse(text, options=GCodeOptions("grbl")) if isinstance(m, Move)]
    # M3 with no power yet draws; S0 lifts; S10 while M3 runs lowers; S20 after M5 does not;
    # M4 (laser, dynamic power) draws like M3; S0 on a move's line lifts before the move.
    assert [m.pen for m in moves] == ["down", "up", "down", "up", "up", "down", "up", "up"]


def test_marlin_m3_m5_still_move_the_pen():
    moves = [m for m in parse("F100\nM3\nG1 X1\nM5\nG1 X2\n", options=GCodeOptions("marlin"))
             if isinstance(m, Move)]
    assert [m.pen for m in moves] == ["down", "up"]


def test_notes_name_their_lines():
    program = parse_program("G21 G54\nM8\nG0 X1\nG92 Z3\nM9\n", options=GCodeOptions("grbl"))
    assert [(n.line, n.text.split(":")[0]) for n in program.notes] == [
        (1, "G54 work coordinate system 1"), (2, "M8 flood coolant"), (4, "G92 Z"), (5, "M9 coolant off")]


# Bad input in each dialect: (dialect, program, line, words of the reason).
REFUSED = [
    ("linuxcnc", "F100\nG2 X2 I1 K0\n", 2, "unsupported word letter 'K' (K on an arc in the XY plane"),
    ("linuxcnc", "M300 S30\n", 1, "unsupported M code M300: a machine's own command"),
    ("linuxcnc", "G55\nG0 X1\n", 1, "G55 (work coordinate system 2) is refused: G54 is the only one"),
    ("linuxcnc", "M62 P1\nG0 X1\n", 1, "unsupported M code M62"),
    ("linuxcnc", "G1 X1 E2 F100\n", 1, "unsupported word letter 'E' (an extruder word"),
    ("linuxcnc", "G0 X1\n$H\n", 2, "homing cycle $H is refused: the homing cycle runs between jobs"),
    ("grbl", "G21\n$H\nG0 X1\n", 2, "grbl's homing cycle $H is refused"),
    ("grbl", "$J=G91 X10 F100\nG0 X1\n", 1, "grbl jog '$J=G91' is refused"),
    ("grbl", "  $32=1\nG0 X1\n", 1, "grbl system command '$32=1' is refused"),
    ("grbl", "G0 X1\nG28.1\n", 2, "G28.1 (store the home position) is refused"),
    ("grbl", "G0 X1\nG81 X1 Y1 Z-1 R1 F100\n", 2, "G81 is refused in the grbl dialect"),
    ("grbl", "G0 X1\nG43\n", 2, "G43 is refused in the grbl dialect"),
    ("grbl", "G55\nG0 X1\n", 1, "G55 (work coordinate system 2) is refused: G54 is the only one"),
    ("grbl", "G59 G0 X1\n", 1, "G59 (work coordinate system 6) is refused"),
    ("grbl", "G53 G0 X1\n", 1, "G53 (machine coordinates) is refused"),
    ("grbl", "G0 X1\nM3 S-5\n", 2, "negative S word (spindle speed or power) S-5"),
    ("grbl", "G0 X1\nM300 S30\n", 2, "unsupported M code M300"),
    ("grbl", "M17\nG0 X1\n", 1, "unsupported M code M17"),
    ("marlin", "M300 S40\nG0 X1\n", 1, "M300 S40: neither the pen-down angle 30 nor the pen-up angle 50"),
    ("marlin", "G0 X1\nM280 P0\n", 2, "M280 (pen servo) needs an S word"),
    ("marlin", "G0 X1\nM280 P0 S200\n", 2, "M280 S200: a servo angle is 0..180 degrees"),
    ("marlin", "G0 X1\nG81 X1 Y1 Z-1 R1\n", 2, "G81 is refused in the marlin dialect"),
    ("marlin", "G0 X1\nG4\n", 2, "G4 dwell needs a P word (milliseconds)"),
    ("marlin", "G0 X1\nG4 P100 S1\n", 2, "G4 dwell with both P (milliseconds) and S (seconds)"),
    ("marlin", "G0 X1\nG4 P-100\n", 2, "G4 dwell with a negative time"),
    ("marlin", "G0 X1\nG28.1\n", 2, "G28.1 (store the home position) is refused"),
    ("marlin", "M62 P1\nG0 X1\n", 1, "unsupported M code M62"),
    ("marlin", "G55\nG0 X1\n", 1, "G55 (work coordinate system 2) is refused"),
]


@pytest.mark.parametrize("dialect, program, line, reason", REFUSED,
                         ids=[f"{d}-{i}" for i, (d, *_rest) in enumerate(REFUSED)])
def test_refused_with_line_and_reason(dialect, program, line, reason, tmp_path):
    with pytest.raises(GCodeError) as exc:
        parse(program, options=GCodeOptions(dialect))
    assert exc.value.line == line and reason in exc.value.message, str(exc.value)
    # The same through plotter check, and before any board command exists.
    path = tmp_path / "bad.gcode"
    path.write_text(program)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", str(path), "--dialect", dialect])
    assert code == 2 and err.getvalue().startswith(f"{path}:line {line}: ") and reason in err.getvalue()
    assert out.getvalue() == ""
    with pytest.raises(GCodeError):
        compile_program(program, StreamerConfig(dialect=dialect))


def test_the_default_dialect_is_linuxcnc(tmp_path):
    """K on an XY arc: LinuxCNC refuses it, grbl ignores it."""
    path = tmp_path / "grbl.gcode"
    path.write_text("G21 F100\nM3\nG2 X2 I1 K0\nM5\n")
    for extra, code in (([], 2), (["--dialect", "linuxcnc"], 2), (["--dialect", "grbl"], 0)):
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            assert cli.main(["check", str(path), *extra]) == code, extra


def test_check_lists_notes_line_by_line(tmp_path):
    path = tmp_path / "marlin.gcode"
    path.write_text("G21\nM17\nM300 S30\nG4 P150\nG1 X10 F1000\nM300 S50\nM84\n")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        assert cli.main(["check", str(path), "--dialect", "marlin"]) == 0
    assert err.getvalue().splitlines() == [
        f"{path}:line 2: note: M17 stepper motors on: no effect",
        f"{path}:line 7: note: M84 stepper motors off: no effect"]
    assert "dwell 0.15 s" in out.getvalue() and "2 notes" in out.getvalue()


@pytest.mark.parametrize("kwargs", [dict(dialect="fanuc"), dict(pen_up_z=math.nan),
                                    dict(marlin_pen_down=40.0, marlin_pen_up=40.2),
                                    dict(marlin_pen_up=math.inf)])
def test_bad_options_are_refused(kwargs):
    with pytest.raises(ValueError):
        GCodeOptions(**kwargs)
    with pytest.raises(ValueError):
        StreamerConfig(**kwargs)


def test_streamer_config_reads_the_dialect():
    text = "G21 F1000\nM300 S90\nG1 X10\nM300 S0\nG0 X0\n"
    commands = compile_program(text, StreamerConfig(dialect="marlin", marlin_pen_down=90.0, marlin_pen_up=0.0))
    pens = [c.text for c in commands if c.verb == "P"]
    assert len(pens) == 2
    with pytest.raises(GCodeError):
        compile_program(text, StreamerConfig(dialect="marlin"))
