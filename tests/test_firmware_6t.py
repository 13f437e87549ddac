"""The board's image built for the chip's 6-clock mode (make CPU6T=1,
firmware/build/6t/) in the s51 simulator.

s51 knows only 12 clocks per machine cycle; at a 22.1184 MHz crystal its
cycles last 0.5425 us, as the STC89C52RC's do in 6-clock mode at 11.0592
MHz.  Times below are the simulator's, in real seconds:

- a line at a moderate feed steps at the commanded rate: cruise pulses one
  period of the feed apart, and the whole move takes as long as the 12-clock
  image's at 11.0592 MHz (the planner and the ramp table count cycles of
  the build's clock);
- the UART answers a status query, and its baud rate, worked out from the
  registers the running image has set (Timer 1's reload for 1,843,200
  cycles/s), is 9600.

Skipped when s51 (Debian package sdcc-ucsim) is missing, except on CI.
"""
import re
import statistics
import sys

import pytest

from firmware_build import FIRMWARE, QUIET_LATENCY, mcu_image, require_s51, uart_step_delay

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"
STATUS = rb"<(\w+) [^>]*>[^\n]*\n"
STEP_BITS = 0x05                      # P1.0 X step, P1.2 Y step
FEED = 1000                           # steps/s: far below what either clock can do
LINE = f"L 2000 0 {FEED}"


def build(**options):
    require_s51()
    return mcu_image(**options)


@pytest.fixture(scope="module")
def image6t():
    return build(CPU6T="1")


def line_pulses(base, clock_hz, tmp):
    """Times (s) of the step pulses of LINE, from a VCD trace of port 1."""
    vcd = str(tmp / "p1.vcd")
    with s51sim.Sim(base, vcd=vcd, clock_hz=clock_hz) as sim:
        assert sim.read_until(rb"\r\n").startswith(b"PLOTTER 8051")
        sim.vcd_start()
        sim.write(LINE.encode() + b"\n")
        assert sim.read_until(REPLY).startswith(b"ok")
        for _ in range(200):
            sim.write(b"?")
            if re.search(STATUS, sim.read_until(STATUS)).group(1) == b"Idle":
                break
        sim.vcd_stop()
    times, prev = [], 0xFF
    for t, v in s51sim.read_vcd(vcd)["P1"]:
        if v & STEP_BITS and not prev & STEP_BITS:
            times.append(t / 1e12)
        prev = v
    return times


@pytest.fixture(scope="module")
def lines(image6t, tmp_path_factory):
    return {
        "6t": line_pulses(image6t, s51sim.CLOCK_HZ_6T, tmp_path_factory.mktemp("6t")),
        "12t": line_pulses(build(), s51sim.CLOCK_HZ, tmp_path_factory.mktemp("12t")),
    }


def test_line_steps_at_the_commanded_rate(lines, image6t):
    t = lines["6t"]
    assert len(t) == 2000
    gaps = [b - a for a, b in zip(t, t[1:])]
    cruise = gaps[len(gaps) // 4:3 * len(gaps) // 4]
    # 1843 cycles of 1/1,843,200 s: 0.99995 ms, within the interrupt latency and, while the
    # status polls make the UART work, one UART interrupt: a late pulse lengthens one interval and
    # shortens the next
    assert statistics.median(cruise) == pytest.approx(1 / FEED, rel=2e-4)
    cycles_per_s = s51sim.CLOCK_HZ_6T / 12
    assert max(cruise) - min(cruise) <= 2 * (QUIET_LATENCY + uart_step_delay(image6t)) / cycles_per_s


def test_line_takes_as_long_as_at_12t(lines):
    t6, t12 = lines["6t"], lines["12t"]
    assert len(t6) == len(t12)
    # the ramp in real time: the same rates, periods rounded to each clock's cycles
    assert t6[-1] - t6[0] == pytest.approx(t12[-1] - t12[0], rel=2e-3)
    c6 = [b - a for a, b in zip(t6, t6[1:])][500:1500]
    c12 = [b - a for a, b in zip(t12, t12[1:])][500:1500]
    assert statistics.mean(c6) == pytest.approx(statistics.mean(c12), rel=1e-3)


def test_uart_answers_at_9600_baud(image6t):
    clock = s51sim.CLOCK_HZ_6T
    with s51sim.Sim(image6t, clock_hz=clock) as sim:
        assert sim.read_until(rb"\r\n").startswith(b"PLOTTER 8051")
        sim.write(b"?")
        status = sim.read_until(STATUS)
        # s51 paces its UART by its own rule, not by Timer 1 (about 0.55 ms
        # a byte at either clock), so the rate is worked out from the
        # registers as the chip has them set: Timer 1 in mode 2 overflowing
        # 32 times a bit (16 with PCON.SMOD), Timer 2 not the baud source.
        tmod, th1, pcon, t2con, scon = (sim.sfr(a) for a in (0x89, 0x8D, 0x87, 0xC8, 0x98))
    assert re.search(rb"<Idle X0 Y0 ", status), status
    assert scon & 0xC0 == 0x40                       # mode 1: 10 bits a byte
    assert tmod & 0xF0 == 0x20                       # Timer 1: 8-bit auto-reload
    assert t2con & 0x30 == 0                         # RCLK, TCLK clear: Timer 1 clocks the UART
    per_bit = (16 if pcon & 0x80 else 32) * (256 - th1)
    assert 1_843_200 / per_bit == 9600
