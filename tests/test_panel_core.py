"""The front panel's logic in the host build of the board's image
(firmware/build/libplotter_core.so): the same C as the 8051 image, with
the keypad, LCD, 7-segment display, e-stop and limit switches played by the
test (hal/host).  Fast and exhaustive where the s51 test
(test_firmware_panel.py) is faithful to the pins: every key of the seed's
map, the digit keys, every figure against its geometry.
"""
from __future__ import annotations

import ctypes
import math
import sys

import pytest

from firmware_build import FIRMWARE, host_library
from panel_keys import (JOG, K_CAR, K_CAR_REV, K_CIRCLE, K_CONE, K_DIAG, K_DIAMOND, K_FASTER,
                        K_NO_FUNCTION, K_PAUSE, K_RESET, K_SLOWER, K_STAR, K_XN, K_XP, K_YN, K_YP, NO_KEY,
                        assert_on_figure, digit_key, figure_segments)
from vcd_trace import SEGMENTS
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.link.protocol import (ERROR_TEXT, RT_RESET, RT_STATUS, Banner, Err, Ok, Resend, Status,
                                          machine_line, parse_reply)

sys.path.insert(0, str(FIRMWARE / "tools"))
import gen_figures  # noqa: E402


BIT_X_DIR, BIT_Y_DIR = 0x02, 0x08           # the closed limit switches, as the direction bits


class Panel:
    """The board image's core with its 1 ms tick, keys and displays."""

    def __init__(self) -> None:
        self.core = FirmwareCore(host_library())
        lib = self.core._lib
        lib.core_lcd_line.restype = ctypes.c_char_p
        self.lib = lib
        self.trace: list[tuple[int, int, bool]] = []     # (x, y, pen) after each step
        self.due: int | None = None                      # cycles to the next step interrupt
        self.tick(50)

    def close(self) -> None:
        self.core.close()

    def tick(self, ms: int = 1) -> None:
        """ms of simulated time: the panel tick every millisecond (922
        machine cycles), the main loop, and the step interrupts that fall due."""
        for _ in range(ms):
            self.lib.core_panel_tick()
            self.core.poll()
            budget = 922
            while self.core.timer_running():
                if self.due is None:
                    self.due = self.core.period()
                if self.due > budget:
                    self.due -= budget
                    break
                budget -= self.due
                before = self.core.position
                self.core.tick()
                after = self.core.position
                if after != before:
                    self.trace.append((*after, self.core.pen_down))
                self.due = self.core.period() if self.core.timer_running() else None
                self.core.poll()
            else:
                self.due = None

    def press(self, key: int, hold: int = 20) -> None:
        self.lib.core_set_key(key)
        self.tick(hold)
        self.lib.core_set_key(NO_KEY)
        self.tick(20)

    def run(self, ms: int = 3000) -> None:
        self.tick(ms)

    def lcd(self) -> tuple[str, str]:
        self.tick(110)                       # one LCD refresh
        return (self.lib.core_lcd_line(0).decode().rstrip(), self.lib.core_lcd_line(1).decode().rstrip())

    def digits(self) -> str:
        return "".join(SEGMENTS[self.lib.core_segment(k)] for k in range(8))

    @property
    def position(self) -> tuple[int, int]:
        return self.core.position


@pytest.fixture
def panel():
    p = Panel()
    yield p
    p.close()


def test_start_screen(panel):
    assert panel.core.transmitted().startswith(b"PLOTTER 8051 1.0 ready")
    assert panel.lcd() == ("X0 Y0", "Ready")
    assert panel.digits() == "    2000"              # the jog feed


@pytest.mark.parametrize("key,move", [(K_XP, (JOG, 0)), (K_XN, (-JOG, 0)), (K_YP, (0, JOG)),
                                      (K_YN, (0, -JOG)), (K_DIAG, (JOG, JOG))])
def test_jog_keys(panel, key, move):
    panel.press(key)
    panel.run(2000)
    assert panel.position == move
    assert panel.lcd() == (f"X{move[0]} Y{move[1]}", "Ready")


def test_jog_feed_keys_double_and_halve_within_limits(panel):
    shown = []
    for key in [K_FASTER] * 3 + [K_SLOWER] * 7:
        panel.press(key)
        shown.append(panel.digits().strip())
    assert shown == ["4000", "8000", "8000", "4000", "2000", "1000", "0500", "0250", "0250", "0250"]


def test_a_key_held_acts_once(panel):
    panel.press(K_XP, hold=500)
    panel.run(2000)
    assert panel.position == (JOG, 0)


def test_contact_bounce_and_short_touches_do_nothing(panel):
    """A key acts once it has read the same for 10 ms (core/panel.c
    DEBOUNCE): a contact bouncing on and off every few milliseconds, and a
    touch of 8 ms, move nothing; bouncing, then held, the key jogs once."""
    def bounce():
        for _ in range(5):
            panel.lib.core_set_key(K_XP)
            panel.tick(3)
            panel.lib.core_set_key(NO_KEY)
            panel.tick(2)

    bounce()
    panel.press(K_XP, hold=8)
    panel.run(1000)
    assert panel.position == (0, 0)
    bounce()
    panel.press(K_XP, hold=30)
    panel.run(2000)
    assert panel.position == (JOG, 0)


def test_keys_without_function_do_nothing(panel):
    for key in (K_NO_FUNCTION, K_PAUSE):          # pausing nothing does nothing
        panel.press(key)
    panel.run(500)
    assert panel.position == (0, 0) and panel.lcd()[1] == "Ready"


def test_digits_shift_in_from_the_right(panel):
    panel.press(K_CIRCLE)
    assert panel.lcd()[1] == "Centre X?"
    assert panel.digits() == "    0000"
    seen = []
    for d in (1, 2, 3, 4):
        panel.press(digit_key(d))
        seen.append(panel.digits())
    assert seen == ["    0001", "    0012", "    0123", "    1234"]
    panel.press(digit_key(9))                          # a fifth key takes the number
    assert panel.lcd()[1] == "Centre Y?"


def type_circle(panel, cx: str, cy: str, r: str) -> None:
    panel.press(K_CIRCLE)
    for number in (cx, cy, r):
        for d in number:
            panel.press(digit_key(int(d)))
        panel.press(K_NO_FUNCTION)


def test_typed_circle(panel):
    type_circle(panel, "0500", "0400", "0300")
    panel.run(8000)
    down = [(x, y) for x, y, pen in panel.trace if pen]
    assert len(down) >= 8 * 300 - 8
    assert all(abs(math.dist(p, (500, 400)) - 300) <= 1.0 for p in down)
    assert panel.position == (800, 400)
    assert panel.lcd()[1] == "Ready"


def test_circle_out_of_reach_is_refused(panel):
    panel.core.receive(b"L -30000 0 12000\n")    # the pen far to the left
    panel.run(5000)
    type_circle(panel, "9999", "0000", "9999")   # 39998 steps to its right
    panel.run(100)
    assert panel.lcd()[1] == "Out of range"
    assert panel.position == (-30000, 0)


def test_reset_key_clears_position_when_still_and_stops_motion(panel):
    panel.press(K_XP)
    panel.run(2000)
    panel.press(K_RESET)
    assert panel.position == (0, 0)
    panel.press(K_STAR)
    panel.tick(400)                               # the star has begun
    moved = len(panel.trace)
    panel.press(K_RESET)
    panel.run(2000)
    assert len(panel.trace) - moved < 50          # stopped at once
    assert b"[reset]" in panel.core.transmitted()
    assert panel.lcd()[1] == "Ready"


def test_pause_key_stops_on_the_path_and_resumes_where_it_stopped(panel):
    panel.press(K_XP)
    panel.run(2000)
    start = panel.position
    panel.trace.clear()
    panel.press(K_STAR)
    panel.tick(400)
    panel.press(K_PAUSE)
    panel.run(300)                                # braked along the path by now
    held = len(panel.trace)
    assert panel.lcd()[1] == "Paused"
    panel.run(2000)
    assert len(panel.trace) == held and held > 0
    panel.core.receive(b"?")
    panel.tick(2)
    assert b"<Hold " in panel.core.transmitted()
    panel.press(K_PAUSE)
    panel.run(40000)
    assert_on_figure(panel.trace, gen_figures.all_figures()["FIG_STAR"], start)
    assert panel.lcd()[1] == "Ready"


def test_reset_key_while_paused_ends_the_figure(panel):
    panel.press(K_STAR)
    panel.tick(400)
    panel.press(K_PAUSE)
    panel.run(300)
    panel.press(K_RESET)
    panel.run(2000)
    moved = len(panel.trace)
    panel.run(2000)
    assert len(panel.trace) == moved
    assert b"[reset]" in panel.core.transmitted()
    assert panel.lcd()[1] == "Ready"
    panel.press(K_XP)                             # not held any more: a jog runs
    panel.run(2000)
    assert len(panel.trace) == moved + JOG


@pytest.mark.parametrize("key,figure", [(K_DIAMOND, "FIG_DIAMOND"), (K_STAR, "FIG_STAR"), (K_CONE, "FIG_CONE"),
                                        (K_CAR, "FIG_CAR"), (K_CAR_REV, "FIG_CAR_REV")])
def test_figure_keys_draw_their_figures(panel, key, figure):
    panel.press(K_XP)                             # not at the origin: figures are about the pen
    panel.run(2000)
    start = panel.position
    panel.trace.clear()
    panel.press(key)
    panel.run(40000)
    assert_on_figure(panel.trace, gen_figures.all_figures()[figure], start)
    assert panel.lcd()[1] == "Ready"


def test_serial_a_draws_the_star_but_only_between_lines(panel):
    panel.core.receive(b"a")
    panel.run(30000)
    assert_on_figure(panel.trace, gen_figures.all_figures()["FIG_STAR"])
    panel.trace.clear()
    panel.core.receive(b"L 10 a\n")               # inside a line: part of it, a bad number
    panel.run(500)
    assert panel.trace == [] and b"err E3" in panel.core.transmitted()


def test_serial_a_leaves_a_number_being_typed_alone(panel):
    panel.press(K_CIRCLE)
    panel.press(digit_key(4))
    panel.core.receive(b"a")
    panel.tick(50)
    assert panel.digits() == "    0004" and panel.lcd()[1] == "Centre X?"
    assert panel.trace == []


def test_serial_motion_is_refused_while_a_figure_is_drawn(panel):
    panel.press(K_STAR)
    panel.tick(300)
    panel.core.transmitted()
    panel.core.receive(b"L 100 0\n")
    panel.tick(5)
    assert b"err E10" in panel.core.transmitted()


def test_figures_are_the_host_shapes_within_the_grid(panel):
    """The ROM figures are plotter_shapes.geometry's, rounded to the grid."""
    half = gen_figures.GRID / 2
    for name, make in gen_figures.FIGURES:
        fig = make()
        commands = gen_figures.all_figures()[name]
        ends = [seg[2] for seg in figure_segments(commands)]
        want = [(s.end[0] * gen_figures.STEPS_PER_MM, s.end[1] * gen_figures.STEPS_PER_MM)
                for st in fig.strokes for s in st.segments]
        for p in want:
            assert min(math.dist(p, e) for e in ends) <= half * math.sqrt(2), (name, p)


def test_estop_pin_alarm_until_released_and_reset(panel):
    panel.press(K_CAR)
    panel.tick(500)
    panel.lib.core_set_estop(1)
    panel.tick(2)
    n = len(panel.trace)
    panel.run(1000)
    assert len(panel.trace) == n
    assert panel.core.alarm == 1
    assert b"[alarm estop]" in panel.core.transmitted()
    assert panel.lcd()[1] == "alarm estop"
    panel.press(K_RESET)                          # still held: the alarm comes back
    panel.tick(5)
    assert panel.core.alarm == 1
    panel.lib.core_set_estop(0)
    panel.press(K_RESET)
    assert panel.core.alarm == 0 and panel.lcd()[1] == "Ready"
    panel.press(K_XP)
    panel.run(2000)
    assert len(panel.trace) == n + JOG


def test_limit_switch_stops_only_the_move_towards_it(panel):
    panel.lib.core_set_limits(BIT_X_DIR)          # the -X switch closed
    panel.press(K_XN)
    panel.run(1000)
    assert panel.position == (0, 0) and panel.core.alarm == 2
    assert b"[alarm limit]" in panel.core.transmitted()
    assert panel.lcd()[1] == "alarm limit"
    panel.press(K_RESET)
    panel.press(K_XP)                             # away from it
    panel.run(2000)
    assert panel.position == (JOG, 0) and panel.core.alarm == 0
    panel.lib.core_set_limits(BIT_Y_DIR)
    panel.press(K_DIAG)                           # +X +Y: not towards -Y
    panel.run(2000)
    assert panel.position == (2 * JOG, JOG)


def test_the_panel_and_the_host_link_share_the_board(panel):
    """Beside the panel, the serial controller's whole protocol, checked with
    the host's own encoder and parser: checksummed banner, replies and
    status, machine lines and resends, `$` settings (both ramp shapes), and
    E10 for motion while a figure is drawn."""
    def send(data: bytes):
        panel.core.receive(data)
        panel.tick(3)
        return parse_reply(panel.core.transmitted().decode().splitlines()[-1])

    assert isinstance(parse_reply(panel.core.transmitted().decode().splitlines()[0]), Banner)
    assert send(machine_line(0, "L 100 0")) == Ok(0, 5)
    damaged = bytearray(machine_line(1, "P 1"))
    damaged[2] ^= 0x01
    assert send(bytes(damaged)) == Resend(1, 2)
    assert send(machine_line(1, "$0=2")) == Err(1, 10, ERROR_TEXT[10])     # moving
    panel.run(2000)
    assert panel.position == (100, 0)
    assert send(machine_line(2, "$1=2")) == Err(2, 11, ERROR_TEXT[11])     # two shapes: 0 and 1
    assert send(machine_line(3, "$1=1")) == Ok(3, 6)
    assert send(machine_line(4, "$0=2")) == Ok(4, 6)
    status = send(RT_STATUS)
    assert isinstance(status, Status) and (status.state, status.x, status.next_seq) == ("Idle", 100, 5)
    panel.press(K_STAR)                           # drawn with the exponential ramp
    panel.tick(300)
    assert send(machine_line(5, "L 100 0")) == Err(5, 10, ERROR_TEXT[10])
    panel.core.receive(RT_RESET)                  # ends the figure too
    panel.tick(5)
    assert send(machine_line(6, "L 0 10")) == Ok(6, 5)
