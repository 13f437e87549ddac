"""The FOLLOW=1 image in s51: the command F on the real 8051 code, the
sensor pins set from a virtual sheet as the image steps, step for step the
same path as the host build of the same core (tests/test_follow_command.py
runs that one over the sweep).

The host build runs first, on the sheet: it gives the sensors' bits for
each step the steering decides, and where the pen is when the step
interrupt takes each one from the mailbox (follow.h).  The image then runs
with P2.0-P2.2 set to those bits: the test stops it where its interrupt
takes a step after which the bits change, sets the pins (low over black)
before the main loop reads them for the next step, and checks the pen's
place there against the host's.  A stop for every step would take the
simulator's console a tenth of a second each.
"""
from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass, field
from typing import List, Tuple

import pytest

from firmware_build import FIRMWARE, host_library, mcu_image, require_s51
from follow_lines import Line, circle, square
from node_processes import wait_until
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.sim.sheet import SensorRing, Sheet

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402
import size  # noqa: E402

SPM = 80.0
RING = SensorRing(3.0)
WIDTH = 7.0
STATUS = re.compile(rb"<(\w+) X(-?\d+) Y(-?\d+) .* A(\d+) B(\d+) F(\d+) W(\d+)>")
QUEUED, IDLE, BEGIN, WAIT = 0xFC, 0xFD, 0xFE, 0xFF   # core/follow.h: the mailbox's other values


def pins(black: int) -> int:
    """P2 for these sensors on black: their pins low, the rest high."""
    return 0xFF & ~black


def mailbox_taken(sym: s51sim.Symbols) -> int:
    """The first instruction after the step interrupt has taken a step from the mailbox."""
    lines = sym.rst["stepper"]
    for k, line in enumerate(lines):
        if re.search(r";\s*core/stepper\.c:\d+: follow_next = FOLLOW_WAIT;", line):
            for after in lines[k + 1:]:
                m = re.match(r"\s+([0-9A-F]{6})\s+[0-9A-F]{2}", after)
                if m:
                    return int(m.group(1), 16)
    raise AssertionError("no mailbox take in stepper.rst")


@dataclass
class HostRun:
    bits: List[int] = field(default_factory=list)               # the sensors for each decided step
    takes: List[Tuple[int, int]] = field(default_factory=list)  # the pen when the interrupt takes each


def host_follow(command: str, sheet: Sheet, start: tuple) -> HostRun:
    core = FirmwareCore(host_library(FOLLOW="1"))
    run = HostRun()
    try:
        core.transmitted()
        core.receive(command.encode() + b"\n")
        core.poll(4)
        while core.timer_running():
            bits = sheet.sensor_bits_from(start, core.position, SPM, RING)
            core.set_sensors(bits)
            if core.follow_mailbox in (BEGIN, WAIT):
                run.bits.append(bits)             # the main loop decides a step now
            core.follow_service()
            decided = core.follow_mailbox < QUEUED
            core.tick()
            if decided and core.follow_mailbox in (IDLE, WAIT):
                run.takes.append(core.position)
        return run
    finally:
        core.close()


def s51_follow(command: str, host: HostRun, sample: int = 10):
    """The final status of the FOLLOW image fed the host's sensor bits, how
    many takes the pen's place was compared with the host's at, the
    simulator's clock at each of them, and the stack's deepest use in bytes."""
    changes = [k for k in range(len(host.bits) - 1) if host.bits[k + 1] != host.bits[k]]
    compared = 0
    clocks: List[Tuple[int, int]] = []        # (take, simulator clocks) at the compared takes
    with s51sim.Sim(mcu_image(FOLLOW="1"), timeout=60) as sim:
        taken = mailbox_taken(sim.sym)
        sim.cmd(f"set hw port[2] 0x{pins(host.bits[0]):02x}")
        sim.read_until(rb"ready[^\r\n]*\r\n")
        sim.cmd(f"tbreak 0x{taken:x} {changes[0] + 1}")
        sim.go()
        sim.write(command.encode() + b"\n")
        for n, k in enumerate(changes):
            # Stopped at take k, after which the main loop decides step k + 1 by new bits.
            sim.wait_stop()
            if n % sample == 0:
                raw = sim.iram(sim.sym["_pos_x"], 8)
                pen = tuple(int.from_bytes(raw[i:i + 4], "little", signed=True) for i in (0, 4))
                assert pen == host.takes[k], f"take {k}: the image's pen at {pen}, the host's at {host.takes[k]}"
                compared += 1
                clocks.append((k, sim.ticks()))
            # The pins, the next stop and go in one write.  After the last change the simulation
            # stays stopped, and runs in bounded steps to the follow's end.
            batch = f"set hw port[2] 0x{pins(host.bits[k + 1]):02x}\n"
            if n + 1 < len(changes):
                batch += f"tbreak 0x{taken:x} {changes[n + 1] - k}\n"
                sim.sock.sendall((batch + "go\n").encode())
                sim._until_con(rb"Simulation started[^\n]*\n")
                sim.running = True
            else:
                sim.cmd(batch.strip())
        deadline = time.monotonic() + 60
        while True:
            sim.write(b"?")
            status = STATUS.search(sim.read_until(rb"<[^>]*>"))
            assert status, "no status report"
            if status.group(1) != b"Run" or time.monotonic() > deadline:
                break
            sim.run_for(0.2)
        stack_start = size.parse_mem(f"{mcu_image(FOLLOW='1')}.mem")["stack_start"]
        return status.groups(), compared, clocks, sim.max_sp() - stack_start + 1


STRAIGHT = Line("straight 30 mm", ((20.0, 100.0), (50.0, 100.0)), (20.0, 100.0), 0.0, False)


@pytest.mark.parametrize("line, command, state, feed", [
    (square(100.0, 100.0, 20.0), "F 6 400 0 280", b"2", 250),                           # home, round 4 corners
    (circle(100.0, 100.0, 12.0, ccw=False), "F 18 400 800 280 120", b"4", 120),       # distance
    (STRAIGHT, "F 0 80 0 280", b"3", 250),                                           # lost at its end
], ids=["square 20 ccw home", "circle r12 cw 800 steps at 120 steps/s", "a line's end"])
def test_the_image_follows_the_sheet_step_for_step_as_the_host_build(line, command, state, feed):
    require_s51()
    sheet = Sheet([line.points], WIDTH)
    host = host_follow(command, sheet, line.start)
    (mode, x, y, alarm, bits, follow, walked), compared, clocks, stack = s51_follow(command, host)
    assert len(host.takes) > 700 and compared > 3
    assert (mode, follow, alarm) == (b"Idle", state, b"0")
    # The same end, by the same number of steps, as the host build.
    assert (int(x), int(y)) == host.takes[-1]
    assert int(walked) == len(host.takes) - 1
    assert int(bits) == host.bits[-1]
    # The steering's calls (follow_tick, step_towards, add8) under the interrupts: within the 40 bytes
    # tools/size.py keeps for the stack.
    assert stack <= 40, stack
    # A step every period of the feed: the main loop always had the next one
    # decided in time (a period it had not would pass without a step).  The
    # interrupt's entry waits for the instruction under way: a few cycles.
    period_clocks = round(921_600 / feed) * 12
    for (k0, t0), (k1, t1) in zip(clocks, clocks[1:]):
        assert abs(t1 - t0 - (k1 - k0) * period_clocks) <= 8 * 12, f"takes {k0}..{k1}: {t1 - t0} clocks"


def test_the_follow_key_on_p2_3_starts_a_follow_once_held_for_its_passes():
    """The key held down (P2.3 low) with the pen on black: the image queues a follow of its own, after
    FOLLOW_KEY_PASSES main-loop passes, and steps it."""
    require_s51()
    with s51sim.Sim(mcu_image(FOLLOW="1"), timeout=60) as sim:
        sim.cmd(f"set hw port[2] 0x{pins(7):02x}")
        sim.read_until(rb"ready[^\r\n]*\r\n")
        pressed = sim.ticks()
        sim.cmd(f"set hw port[2] 0x{pins(7) & ~0x08:02x}")
        sim.run_to(sim.sym["_planner_follow"], timeout=30)
        debounce_ms = (sim.ticks() - pressed) / 11_059_200 * 1000
        print(f"follow key: {debounce_ms:.1f} ms from the press to the follow queued (200 passes at rest)")
        assert 1.0 <= debounce_ms <= 100.0
        sim.go()
        reports = []

        def stepped() -> bool:
            # Asked until a step is decided: the simulator runs at the pace the machine allows.
            sim.write(b"?")
            reports.append(STATUS.search(sim.read_until(rb"<[^>]*>")))
            assert reports[-1], "no status report"
            return int(reports[-1].group(7)) > 0
        wait_until(stepped, 60, "the follow's first step")
        mode, x, y, alarm, bits, follow, walked = reports[-1].groups()
        # All three on black: the line's way is unknown, so it keeps the heading, 0 (+X).
        assert (mode, follow, bits, alarm) == (b"Run", b"1", b"7", b"0")
        # X counts the steps taken, W those decided: one may be in the mailbox, one in the pulse.
        assert int(walked) > 0 and 0 <= int(walked) - int(x) <= 2 and int(y) == 0
