"""Malformed programs: each is rejected as a whole, naming the right line and reason."""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib as lib  # noqa: E402
from gcode_bad_corpus import CORPUS  # noqa: E402

from plotter_bridge.cli import main as cli  # noqa: E402
from plotter_bridge.gcode.parser import (GCodeError, check_limits, load_program, parse,  # noqa: E402
                                  to_steps)

LINUXCNC_BAD = lib.acceptance_programs("bad")

# Our wording for each LinuxCNC message of shared/acceptance/linuxcnc/bad.
LINUXCNC_REASONS = {
    "Radius to end of arc differs from radius to start": "radius to end of arc differs",
    "Cannot do g1 with zero feed rate": "no feed rate",
    "R i j k words all missing for arc": "needs I/J",
}


def reject(program: bytes, limits: bool = True) -> GCodeError:
    with pytest.raises(GCodeError) as info:
        items = load_program(program)
        if limits:
            check_limits(items)
    return info.value


def test_corpus_is_large_enough():
    assert len(CORPUS) >= 30
    assert len({case.name for case in CORPUS}) == len(CORPUS)


@pytest.mark.parametrize("case", CORPUS, ids=lambda c: c.name)
def test_corpus_rejected_with_line_and_reason(case):
    error = reject(case.program)
    assert error.line == case.line, str(error)
    assert case.keyword in error.message, str(error)
    assert str(error) == f"line {case.line}: {error.message}"


@pytest.mark.parametrize("case", CORPUS, ids=lambda c: c.name)
def test_corpus_rejected_by_plotter_check(case, tmp_path):
    path = tmp_path / "bad.gcode"
    path.write_bytes(case.program)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", str(path)])
    assert code == 2
    assert err.getvalue().startswith(f"{path}:line {case.line}: "), err.getvalue()
    assert case.keyword in err.getvalue()
    assert out.getvalue() == ""  # nothing of a rejected program is printed


def test_bad_line_rejects_whole_program():
    """Good moves before a bad line produce nothing: the program is parsed first."""
    program = "G21 F100\n" + "G1 X1 Y1\n" * 50 + "G1 X2 Q1\n" + "G1 X3\n"
    with pytest.raises(GCodeError) as info:
        parse(program)
    assert info.value.line == 52


def test_error_after_m2_is_ignored_but_error_before_is_not():
    assert parse("G21 F100\nG1 X1\nM2\nQ7 garbage [\n")
    with pytest.raises(GCodeError):
        parse("G21 F100\nG1 X1\nQ7\nM2\n")


def test_line_length_limit_is_exact_and_counts_commands_only():
    ok = "G0 X1" + " " * 251
    assert len(ok) == 256
    parse(ok + "\n")
    with pytest.raises(GCodeError, match=r"line too long \(257 characters outside comments, at most 256\)"):
        parse(ok + " \n")
    # A comment is not a command: Unicorn's options and Mr Beam's layer notes run to hundreds of characters.
    parse(ok + "(" + "x" * 1000 + ");" + "y" * 1000 + "\n")


@pytest.mark.parametrize("path", LINUXCNC_BAD, ids=lambda p: p.name)
def test_linuxcnc_bad_programs_rejected_for_the_same_reason(path):
    """shared/acceptance/linuxcnc/bad: expressions are replaced by their values."""
    text = path.read_text()
    expected = lib.expected_message(text)
    keyword = next(v for k, v in LINUXCNC_REASONS.items() if expected.startswith(k))
    program = lib.substitute_expressions(text)
    assert "[" not in program
    bad_line = len(program.rstrip("\n").split("\n"))  # the last line is the bad one
    with pytest.raises(GCodeError) as info:
        parse(program)
    assert info.value.line == bad_line, str(info.value)
    assert keyword in info.value.message, str(info.value)


def test_linuxcnc_bad_set_present():
    assert len(LINUXCNC_BAD) >= 8, f"no LinuxCNC bad programs in {lib.acceptance_dir()}"


def test_expression_evaluator():
    assert lib.evaluate("[0.9985 * 100]") == pytest.approx(99.85)
    assert lib.evaluate("[25.00 - [0.0101 * sqrt[2]]]") == pytest.approx(
        25 - 0.0101 * 2 ** 0.5)
    assert lib.evaluate("[-2 + 3 * [4 - 1] / 2]") == pytest.approx(2.5)
    assert lib.substitute_expressions("g2 x5 i[1 + [2 * 3]]") == "g2 x5 i7"


# ------------------------------------------------------------- properties

hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies
FAST = hypothesis.settings(max_examples=300, deadline=2000)

GCODE_ALPHABET = "GMXYZIJRFPN0123456789.-+ ()\n;%[]#*/QSabc\t\r"


def only_gcode_errors(data: bytes) -> None:
    try:
        items = load_program(data)
        check_limits(items)
    except GCodeError as exc:
        assert str(exc).startswith(f"line {exc.line}: ") and exc.line >= 1
        return
    to_steps(items, 80.0)


@FAST
@hypothesis.given(st.binary(max_size=400))
def test_random_bytes_only_raise_gcode_error(data):
    only_gcode_errors(data)


@FAST
@hypothesis.given(st.text(max_size=300))
def test_random_text_only_raises_gcode_error(text):
    only_gcode_errors(text.encode("utf-8"))


@FAST
@hypothesis.given(st.text(alphabet=GCODE_ALPHABET, max_size=300))
def test_random_gcode_like_text_only_raises_gcode_error(text):
    only_gcode_errors(text.encode("ascii"))


WORD = st.builds(lambda letter, value: f"{letter}{value}",
                 st.sampled_from("GMXYZIJRFPN"),
                 st.one_of(st.integers(-1000, 1000).map(str),
                           st.floats(-1e4, 1e4, allow_nan=False).map(lambda v: f"{v:.4f}")))
LINE = st.lists(WORD, max_size=6).map(" ".join)


@FAST
@hypothesis.given(st.lists(LINE, max_size=25))
def test_random_word_programs_only_raise_gcode_error(lines):
    only_gcode_errors("\n".join(lines).encode("ascii"))
