"""The parts of `make -C firmware bench` (firmware/tools/bench.py) that need
no simulator: a bench command's lines, and the check that a saturated run's
middle half measures cruise rather than a ramp.  The bench itself runs in
s51 for minutes and prints figures; it is not a test."""
import sys

import pytest

from firmware_build import FIRMWARE, host_library

sys.path.insert(0, str(FIRMWARE / "tools"))
import bench  # noqa: E402


def test_a_command_carries_settings_before_its_move():
    assert bench.lines_of("$1=1; L 30000 0 12850") == ["$1=1", "L 30000 0 12850"]
    assert bench.lines_of("A 0 0 1500 0 12850") == ["A 0 0 1500 0 12850"]


def test_settings_change_the_schedule_the_bench_compares_with():
    plain = bench.host_schedule(host_library(), "L 3000 0 12850")
    exponential = bench.host_schedule(host_library(), "$1=1; L 3000 0 12850")
    assert len(plain) == len(exponential) == 2999
    assert plain != exponential


def test_a_line_that_cruises_is_measured_over_its_middle_half():
    command = "L 6000 0 12850"          # climbs for 782 steps, brakes for as many
    n = len(bench.host_schedule(host_library(), command))
    assert bench.cruise_of(host_library(), command, n) == range(n // 4, 3 * n // 4)


def test_a_circle_on_the_ramp_throughout_is_refused_as_a_cruise_figure():
    command = "A 0 0 0 -25 12850"      # never reaches the arcs' top feed
    n = len(bench.host_schedule(host_library(), command))
    with pytest.raises(RuntimeError, match="not all at cruise"):
        bench.cruise_of(host_library(), command, n)


def test_a_run_of_another_length_than_the_schedule_is_refused():
    with pytest.raises(RuntimeError):
        bench.cruise_of(host_library(), "L 3000 0 12850", 2900)


def test_the_planner_caps_an_arcs_feed_and_the_host_knows_the_cap():
    """Arcs cruise at the arcs' top feed (core/ramp.h ARC_TOP), lines at the ramp's top, whatever the
    command asks for; the host's commands carry the same caps (link/protocol.py)."""
    from plotter_bridge.link.protocol import MAX_ARC_RATE, MAX_RATE
    from isr_share import ARC_TOP as arc_top, RAMP_TOP as ramp_top     # read from core/ramp.h
    assert (MAX_ARC_RATE, MAX_RATE) == (arc_top, ramp_top)
    from plotter_bridge.sim.firmware_core import FirmwareCore
    core = FirmwareCore(host_library())          # the board's build, as the mock board runs it
    try:
        assert core.feed_caps == (MAX_RATE, MAX_ARC_RATE)
    finally:
        core.close()
    cycles_per_s = 11059200 // 12
    for command in ("A 0 0 1500 0 12850", "C 0 0 0 3000 9000", "A -2561 1061 -1500 0 5001"):
        assert min(bench.host_schedule(host_library(), command)) == round(cycles_per_s / arc_top), command
    assert min(bench.host_schedule(host_library(), "A 0 0 1500 0 4000")) == round(cycles_per_s / 4000)
    assert min(bench.host_schedule(host_library(), "L 30000 0 12850")) == round(cycles_per_s / ramp_top)
