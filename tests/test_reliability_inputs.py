"""Pure checks behind the reliability work: the job journal and its resume,
and the refusal of bad requests and bad programs before anything moves."""
import pytest

from gcode_bad_corpus import CORPUS
from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.link.journal import (DONE, INTERRUPTED, Journal, JobRecord, Progress, resume_commands,
                                    state_before, travel)
from plotter_bridge.motion.compiler import MAX_PROGRAM_BYTES, StreamerConfig, compile_program


# --- the journal ------------------------------------------------------------------------

def record():
    return JobRecord("ab" * 16, "square", ["L 100 0 2000 0", "P 1", "L 0 100 2000 0", "L -100 0 2000 0",
                                           "P 0", "C 20 0 10 0 2000 0"],
                     [2, 3, 4, 5, 6, 7], (1000, 1000), False, 8000)


def test_state_before_each_command():
    r = record()
    assert state_before(r, 0) == ((1000, 1000), False)
    assert state_before(r, 2) == ((1100, 1000), True)
    assert state_before(r, 4) == ((1000, 1100), True)
    assert state_before(r, 6) == ((1020, 1100), False)


def test_resume_where_the_board_stopped_adds_nothing():
    r = record()
    commands, lines = resume_commands(r, 3, (1100, 1100), True)
    assert commands == r.commands[3:] and lines == r.lines[3:]
    assert resume_commands(r, 6, (1020, 1100), False) == ([], [])


def test_resume_from_elsewhere_travels_pen_up_then_lowers_it():
    r = record()
    commands, lines = resume_commands(r, 3, (1150, 1120), True)     # stopped inside command 3
    assert commands == ["P 0", "L -50 -20 8000 0", "P 1"] + r.commands[3:]
    assert lines == [5, 5, 5] + r.lines[3:]
    commands, _ = resume_commands(r, 2, (1100, 1000), False)        # pen raised by a reset
    assert commands == ["P 1"] + r.commands[2:]


def test_travel_is_split_into_firmware_sized_pieces():
    pieces = travel(70000, -3, 5000)
    assert len(pieces) == 3
    assert sum(int(p.split()[1]) for p in pieces) == 70000
    assert sum(int(p.split()[2]) for p in pieces) == -3
    assert all(abs(int(p.split()[1])) <= 32767 for p in pieces)


def test_journal_round_trip_and_listing(tmp_path):
    j = Journal(tmp_path / "j")
    r = record()
    j.create(r)
    j.update(r.job_id, Progress(3, INTERRUPTED, "client gone"))
    back, prog = j.load(r.job_id)
    assert back == r and prog == Progress(3, INTERRUPTED, "client gone") and prog.resumable
    j.update(r.job_id, Progress(6, DONE, "done"))
    assert [(i, p.state) for i, p, _ in j.jobs()] == [(r.job_id, DONE)]
    with pytest.raises(KeyError):
        j.load("cd" * 16)
    with pytest.raises(KeyError, match="not a job id"):
        j.load("../../etc/passwd")
    assert not list((tmp_path / "j").glob("*.tmp"))


# --- requests refused before anything moves ------------------------------------------------

def test_streamer_request_checks():
    pytest.importorskip("rclpy")
    from plotter_bridge.nodes.gcode_streamer import check_request
    assert check_request("G0 X1\n", "ok", "") is None
    assert "too large" in check_request("G0 X1\n" * (MAX_PROGRAM_BYTES // 6 + 1), "p", "")
    assert "name" in check_request("G0 X1", "a\x00b", "")
    assert "name" in check_request("G0 X1", "n" * 201, "")
    assert "not a job id" in check_request("", "p", "../x")
    assert check_request("", "p", "ab" * 16) is None


def test_bridge_goal_checks():
    pytest.importorskip("rclpy")
    from plotter_bridge.nodes.serial_bridge import validate_goal
    assert validate_goal(["L 1 2 3 4"], [1]) is None
    for commands, lines, word in (([], [], "empty"), (["L 1 1", "N3 L 1 1 *5"], [], "command 2"),
                                  (["\x1b"], [], "command 1"), (["$2=9"], [], "command 1"),
                                  (["L " + "1" * 50], [], "command 1"), (["L 1 1"], [1, 2], "length")):
        assert word in validate_goal(commands, lines)


def test_a_goal_as_one_text_is_checked_as_its_list_is():
    pytest.importorskip("rclpy")
    from plotter_bridge.link.command_store import CommandStore
    from plotter_bridge.nodes.serial_bridge import MAX_COMMAND_LEN, validate_commands
    good = ["P 1", "L 77 -92 5635 1872", "C 10 0 5 0 3000 0", "M6 0", "D 250", "L -1 0 15 0"]
    assert validate_commands(CommandStore(good)) is None and validate_commands(good) is None
    for bad in ("", "\tL 1 1", "L 1 1 *5", "N3 L 1 1", "$2=9", "?", "L 1 \x7f", "L \u00e9 1", "L " + "1" * MAX_COMMAND_LEN,
                "~", "!"):
        for where in (0, 3, len(good)):
            commands = good[:where] + [bad] + good[where:]
            expected = validate_commands(commands)
            assert expected is not None and f"command {where + 1} " in expected, (bad, expected)
            assert validate_commands(CommandStore(commands)) == expected
    edge = "L 1 1 " + "2" * (MAX_COMMAND_LEN - 6)             # exactly the longest a command may be
    assert len(edge) == MAX_COMMAND_LEN and validate_commands(CommandStore([edge])) is None


def test_a_goal_as_one_text_names_its_unknown_pen_change_as_its_list_does():
    """validate_goal's pen changes: each "M6 k" needs a k-th entry of pen_changes (when the goal
    gives any), read over a CommandStore's text at once or command by command, the same answer."""
    pytest.importorskip("rclpy")
    from plotter_bridge.link.command_store import CommandStore
    from plotter_bridge.nodes.serial_bridge import validate_goal
    base = ["P 1", "L 77 -92 5635 1872", "M6 0", "L 1 1 15 0", "M6 1", "D 250"]
    for extra in ("M6 1", "M6 2", "M6 12", "M6  2", "M6 2 ", "M6 x", "M62", "M6 0"):
        for where in (0, 3, len(base)):
            commands = base[:where] + [extra] + base[where:]
            for pens in ([], ["black"], ["black", "red"], ["black", "red", "blue"]):
                lines = list(range(1, len(commands) + 1))
                expected = validate_goal(commands, lines, pens)
                assert validate_goal(CommandStore(commands), lines, pens) == expected, (extra, where, pens)
                if pens == ["black", "red"] and extra.split() == ["M6", "2"]:
                    assert expected is not None and f"command {where + 1} " in expected


@pytest.mark.parametrize("case", CORPUS, ids=lambda c: c.name)
def test_bad_programs_refused_by_the_streamer_pipeline(case):
    """compile_program is what gcode_streamer runs before streaming: every
    malformed program of the corpus is refused whole, naming line and reason."""
    with pytest.raises(GCodeError) as info:
        compile_program(case.program.decode("utf-8", "surrogateescape"), StreamerConfig(), (0, 0))
    assert info.value.line == case.line and case.keyword in info.value.message, str(info.value)


hypothesis = pytest.importorskip("hypothesis")
st = hypothesis.strategies


@hypothesis.settings(max_examples=300, deadline=None)
@hypothesis.given(st.text(alphabet="GMXYZIJRFPN0123456789.-+ ()\n;%", max_size=300),
                  st.tuples(st.integers(-2000, 20000), st.integers(-2000, 20000)))
def test_garbage_through_the_whole_compile_only_raises_gcode_error(text, start):
    try:
        commands = compile_program(text, StreamerConfig(), start)
    except GCodeError as exc:
        assert str(exc).startswith(f"line {exc.line}: ")
        return
    for c in commands:
        assert len(c.text) <= 40 and all(abs(a) <= 32767 for a in c.args)


def test_a_job_that_ended_part_way_says_where_and_how_to_finish_it():
    pytest.importorskip("rclpy")
    from plotter_bridge.nodes.gcode_streamer import stopped_message
    record = JobRecord("ab" * 16, "p", ["L 1 1", "L 2 2", "L 3 3"], [3, 4, 7], (0, 0), False, 1000)
    assert stopped_message("emergency stop", 2, record, "ab" * 16) == \
        f"emergency stop; stopped after command 2 of 3 (line 4): plotter resume {'ab' * 16} finishes it"
    assert stopped_message("board alarm", 0, record, "ab" * 16).startswith(
        "board alarm; stopped after command 0 of 3: plotter resume")
    reset = stopped_message("board reset during the job: the position is unknown", 1, record, "ab" * 16)
    assert "(line 3)" in reset and "plotter resume" not in reset
