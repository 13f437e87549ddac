"""The `$` settings of firmware/PROTOCOL.md in the host build of the firmware
core (the same C as the 8051 image), measured on its simulated clock:

- `$1` picks the ramp: the trapezoid climbs at a constant acceleration, the
  exponential (seed 004) follows R0 + (RMAX - R0) (1 - exp(-t / tau)), with
  the same slope at the start and a soft approach to the top; both brake
  as they climbed and end on the segment's last step;
- `$0` holds every level longer: the acceleration divided by it;
- `$2` is the feed of a line that gives none, `$3` the pause after a pen
  change;
- a stop holds the start rate as long as a start does;
- out-of-range values, unknown keys and changes while moving are refused
  and change nothing.
"""
from __future__ import annotations

import math
import re
import sys

import pytest

from firmware_build import FIRMWARE, host_library
from plotter_bridge.sim.firmware_core import FirmwareCore, Step

sys.path.insert(0, str(FIRMWARE / "tools"))
import gen_ramp  # noqa: E402

CYCLES_PER_S = gen_ramp.CYCLES_PER_S
ACCEL = gen_ramp.DR / gen_ramp.DT_TRAP            # steps/s^2 of the trapezoid at $0=1
TOP = gen_ramp.RMAX


@pytest.fixture
def core():
    c = FirmwareCore(host_library())
    c.transmitted()
    yield c
    c.close()


def send(core: FirmwareCore, line: str) -> str:
    """One typed line, its reply without the checksum."""
    core.receive(line.encode() + b"\n")
    core.poll(3)
    reply = core.transmitted().decode().strip().splitlines()[-1]
    return re.sub(r" \*\d+$", "", reply)


def climb(steps: list[Step], upto: float = 0.9, top: float = TOP) -> list[tuple[float, float]]:
    """(seconds since the first step, steps/s) of each step interval until the
    rate reaches `upto` of the top (the first interval is the start's)."""
    out, t = [], 0.0
    for s in steps[1:]:
        t += s.cycles / CYCLES_PER_S
        rate = CYCLES_PER_S / s.cycles
        if rate >= top * upto:
            return out
        out.append((t, rate))
    raise AssertionError("never reached the top rate")


def move_x(core: FirmwareCore, dx: int) -> list[Step]:
    x = core.position[0]
    assert send(core, f"L {dx} 0 {TOP}").startswith("ok")
    steps = core.run_steps()
    assert core.position == (x + dx, 0) and len(steps) == abs(dx)
    return steps


def trapezoid_time(rate: float, accel: float = ACCEL) -> float:
    """When the trapezoid reaches `rate`, seconds."""
    return (rate - gen_ramp.R0) / accel


def exponential_time(rate: float) -> float:
    """When R0 + (RMAX - R0)(1 - exp(-t / tau)) reaches `rate`, seconds."""
    return -gen_ramp.TAU * math.log(1 - (rate - gen_ramp.R0) / (TOP - gen_ramp.R0))


def time_error(profile, when) -> float:
    """How far, in seconds, the climb runs ahead of or behind the curve."""
    return max(abs(t - when(rate)) for t, rate in profile)


def test_trapezoid_climbs_at_constant_acceleration(core):
    up = climb(move_x(core, 8000))
    # a level is 2 ms; a hold is whole steps, so a level may come up to
    # two levels early (at the lowest rates one step is longer than a level)
    assert time_error(up, trapezoid_time) <= 2.5 * gen_ramp.DT_TRAP
    assert time_error(up, exponential_time) > 0.1


def test_exponential_ramp_follows_its_curve(core):
    assert send(core, "$1=1").startswith("ok")
    steps = move_x(core, 8000)
    up = climb(steps)
    assert time_error(up, exponential_time) <= 3 * gen_ramp.DT_EXP
    assert time_error(up, trapezoid_time) > 0.1
    # tau ln 2 to half the rise; the trapezoid with the same initial slope
    # gets there in 0.72 of that
    half = next(t for t, rate in up if rate >= (gen_ramp.R0 + TOP) / 2)
    assert half == pytest.approx(gen_ramp.TAU * math.log(2), rel=0.1)
    # braking mirrors the climb, and the segment ends on its last step
    assert len(climb(steps[::-1])) == pytest.approx(len(up), rel=0.02)


def test_acceleration_divisor_holds_each_level_longer(core):
    assert send(core, "$0=4").startswith("ok")
    up = climb(move_x(core, 20000))
    assert time_error(up, lambda r: trapezoid_time(r, ACCEL / 4)) <= 2.5 * 4 * gen_ramp.DT_TRAP
    assert send(core, "$1=1").startswith("ok")
    slow = climb(move_x(core, -30000))
    assert slow[-1][0] == pytest.approx(4 * exponential_time(0.9 * TOP), rel=0.05)


@pytest.mark.parametrize("shape", [0, 1])
@pytest.mark.parametrize("divisor", [1, 3, 8])
def test_a_stop_ends_at_the_start_rate_as_a_start_begins(core, shape, divisor):
    """A start holds the lowest level (the rate a motor starts at without a
    ramp) for its hold; a stop must come down to it and hold it as long, not
    stop from the level above."""
    assert send(core, f"$1={shape}").startswith("ok")
    assert send(core, f"$0={divisor}").startswith("ok")
    hold = gen_ramp.tables()["exp" if shape else "trap"][2][0] * divisor
    for dx in (300, -3000):
        rates = [CYCLES_PER_S / s.cycles for s in move_x(core, dx)[1:]]
        slow = [r <= gen_ramp.R0 * 1.01 for r in rates]
        at_start = slow.index(False) + 1                  # the first step is the start's
        at_end = slow[::-1].index(False)
        assert at_start == hold
        assert hold <= at_end <= hold + 1


@pytest.mark.parametrize("options", [{"INTERP": "dda"}, {"INTERP": "compare"}, {"ZAXIS": "1"}],
                         ids=["dda", "compare", "zaxis"])
def test_the_option_images_have_both_ramps(options):
    """Their ramps count step interrupts (iterations, README.md): the
    interrupts' own periods follow the curve `$1` picks, up to the image's
    cap for a line (core/ramp.h LINE_TOP, below the ramp's top)."""
    core = FirmwareCore(host_library(**options))
    try:
        cap = core.feed_caps[0]
        assert cap < TOP
        for shape, when in ((1, exponential_time), (0, trapezoid_time), (1, exponential_time)):
            assert send(core, f"$1={shape}").startswith("ok")
            x = core.position[0]
            dues = list(core.interrupts([f"L 8000 0 {TOP}"]))
            assert core.position == (x + 8000, 0)
            assert abs(CYCLES_PER_S / sorted(dues)[len(dues) // 2] - cap) <= 0.01 * cap   # cruising at it
            up = climb([Step(1, 0, due) for due in dues], top=cap)
            assert time_error(up, when) <= 3 * (gen_ramp.DT_EXP if shape else gen_ramp.DT_TRAP)
        assert send(core, "$1=2") == "err E11"
    finally:
        core.close()


def test_default_feed_is_the_cruise_of_a_line_without_one(core):
    assert send(core, "$2=1000").startswith("ok")
    assert send(core, "L 3000 0").startswith("ok")
    steps = core.run_steps()
    cruise = sorted(s.cycles for s in steps[1000:2000])
    assert cruise[len(cruise) // 2] == round(CYCLES_PER_S / 1000)


@pytest.mark.parametrize("ms", [1, 150, 400])
def test_pen_delay_pauses_after_a_pen_change(core, ms):
    assert send(core, f"$3={ms}").startswith("ok")
    for cmd in ("L 10 0", "P 1", "L 10 0"):
        assert send(core, cmd).startswith("ok")
    steps = core.run_steps()
    pause = steps[10].cycles / CYCLES_PER_S * 1000        # from the 10th step to the 11th
    assert ms <= pause < ms + 5


@pytest.mark.parametrize("text,code", [
    ("$0=0", 11), ("$0=51", 11), ("$1=2", 11), ("$2=14", 11), ("$3=0", 11), ("$3=5001", 11),
    ("$4=1", 11), ("$0=70000", 3), ("$0=-1", 3), ("$0", 3), ("$=1", 3),
])
def test_bad_settings_are_refused_and_change_nothing(core, text, code):
    assert send(core, text) == f"err E{code}"
    assert time_error(climb(move_x(core, 8000)), trapezoid_time) <= 2.5 * gen_ramp.DT_TRAP


def test_settings_wait_for_the_machine_to_stand_still(core):
    assert send(core, "L 4000 0").startswith("ok")
    for _ in range(100):
        core.tick()
    assert core.running
    assert send(core, "$1=1") == "err E10"
    core.run_steps()
    assert send(core, "$1=1").startswith("ok")
