"""A job's progress from the plan: the length the pen travels per command,
the time the board takes for it, and what the terminal shows."""
import io
import math
from types import SimpleNamespace

import pytest

from plotter_bridge.cli.progress import ProgressDisplay, clock_text
from plotter_bridge.motion.commands import from_text
from plotter_bridge.motion.kinematics import Machine
from plotter_bridge.motion.timing import JobProgress, command_seconds, pen_lengths, trapezoid_seconds


def test_trapezoid_cruise_ramp_and_triangle():
    a = 100000.0
    assert trapezoid_seconds(1000, 1000, 1000, 1000, a) == pytest.approx(1.0)
    # 0 -> 1000 steps/s takes 0.01 s and 5 steps each way; 1000 steps in all.
    assert trapezoid_seconds(1000, 0, 1000, 0, a) == pytest.approx(0.02 + 990 / 1000)
    # Too short to reach cruise: up and down through the peak.
    t = trapezoid_seconds(10, 0, 10000, 0, a)
    assert t == pytest.approx(2 * math.sqrt(10 / a))
    assert trapezoid_seconds(0, 0, 1000, 0, a) == 0.0


@pytest.mark.parametrize("text", ["L 400 -300 2000 0", "C 0 0 0 -800 1500 300", "A 800 800 800 0 1200 0",
                                  "P 1", "D 250", "Z -40 500 0"])
def test_commands_come_back_from_their_text(text):
    assert from_text(text).text == text


def test_command_seconds_chain_entry_and_exit():
    cmds = [from_text("P 1"), from_text("L 2000 0 1000 1000"), from_text("L 2000 0 1000 0"), from_text("D 500")]
    pen, first, second, dwell = command_seconds(cmds)
    assert pen == pytest.approx(0.150) and dwell == pytest.approx(0.5)
    assert first == pytest.approx(0.01 + 1995 / 1000)      # starts at rest, leaves at cruise
    assert second == pytest.approx(0.01 + 1995 / 1000)     # enters at cruise, stops
    with pytest.raises(ValueError):
        from_text("N5 L 1 1")


def test_pen_lengths_of_lines_and_arcs():
    m = Machine("cartesian", 80.0)
    cmds = [from_text("L 800 0 1000 0"), from_text("P 1"), from_text("A 0 0 800 0 1000 0"),
            from_text("L 0 -800 1000 0")]
    lengths = pen_lengths(cmds, (0, 0), m.pen_mm, 80.0)
    assert lengths == pytest.approx([10.0, 0.0, 2 * math.pi * 10.0, 10.0])


def test_progress_follows_length_not_commands():
    # One long command and nine short ones of equal time: after the long one, the share is
    # its length, not a tenth.
    job = JobProgress([90.0] + [1.0] * 9, [9.0] + [1.0] * 9)
    assert job.update(0, 0.0) == (0.0, pytest.approx(18.0))
    assert job.update(1, 10.0) == (pytest.approx(0.0), pytest.approx(18.0))
    share, left = job.update(1, 14.5)                          # half way through the long one
    assert share == pytest.approx(45 / 99) and left == pytest.approx(13.5)
    share, left = job.update(2, 20.0)                          # the long one done
    assert share == pytest.approx(90 / 99) and left == pytest.approx(9.0)
    assert job.update(10, 40.0) == (pytest.approx(98 / 99), pytest.approx(1.0))   # the last one starts
    assert job.update(10, 45.0) == (pytest.approx(1.0), pytest.approx(0.0))
    assert JobProgress([], []).update(0, 0.0) == (1.0, 0.0)


def test_progress_and_time_left_of_a_300k_command_job_past_every_power_of_two():
    """The share and the time left come from sums kept per command, exact at any index: past
    2^15, 2^16 and 2^17 commands of a 300,000-command job as at its start."""
    n = 300_000
    lengths = [0.5 + (k % 7) * 0.25 for k in range(n)]
    seconds = [0.01 + (k % 5) * 0.002 for k in range(n)]
    job = JobProgress(lengths, seconds)
    total_length, total_seconds = math.fsum(lengths), math.fsum(seconds)
    assert job.total_length == pytest.approx(total_length) and job.total_seconds == pytest.approx(total_seconds)
    last = (0.0, job.total_seconds)
    for started in (0, 1, 2 ** 15, 2 ** 15 + 1, 2 ** 16 - 1, 2 ** 16, 2 ** 16 + 1, 2 ** 17, 2 ** 17 + 1, n - 1, n):
        share, left = job.update(started, float(started))       # each seen as it starts
        running = started - 1
        assert share == pytest.approx(math.fsum(lengths[:max(running, 0)]) / total_length, abs=1e-9)
        assert left == pytest.approx(total_seconds - math.fsum(seconds[:max(running, 0)]), abs=1e-6)
        assert share >= last[0] and left <= last[1] + 1e-9
        last = (share, left)
    assert job.update(n, float(n) + 1.0) == (pytest.approx(1.0), pytest.approx(0.0))


def _fb(progress, left, ahead=0):
    return SimpleNamespace(progress=progress, seconds_left=left, current_line=3, total_lines=9, x_mm=1.5,
                           y_mm=2.25, jobs_ahead=ahead)


def test_plain_lines_off_a_terminal_and_a_redrawn_bar_on_one():
    now = [0.0]
    plain, bar = io.StringIO(), io.StringIO()
    show_plain = ProgressDisplay("star", plain, tty=False, clock=lambda: now[0])
    show_bar = ProgressDisplay("star", bar, tty=True, clock=lambda: now[0])
    for t, fb in ((0.0, _fb(0.0, 0, 2)), (1.0, _fb(0.1, 65)), (3.0, _fb(0.5, 30)), (3.5, _fb(0.6, 20)),
                  (6.0, _fb(1.0, 0))):
        now[0] = t
        show_plain(fb)
        show_bar(fb)
    show_bar.close(True)
    lines = plain.getvalue().splitlines()
    assert lines[0] == "star: waiting, 2 job(s) ahead"
    assert lines[1] == "star: 50% done, 30 s left, line 3/9  X 1.500  Y 2.250 mm"
    assert len(lines) == 3 and "\r" not in plain.getvalue()
    assert bar.getvalue().count("\r[") >= 4 and "1:05 left" in bar.getvalue()
    assert [clock_text(s) for s in (4.4, 65, 3725)] == ["4 s", "1:05", "1:02:05"]


def test_job_position_follows_feedback_until_the_result():
    from plotter_bridge.motion.timing import JobPosition
    position = JobPosition((1.0, 2.0))
    assert position.xy == (1.0, 2.0)
    position.feedback((3.0, 4.0))
    assert position.xy == (3.0, 4.0)
    position.result((5.0, 6.0))
    position.feedback((3.5, 4.5))           # sent before the result, handled after it
    assert position.xy == (5.0, 6.0)
