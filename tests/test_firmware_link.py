"""The host link of firmware/PROTOCOL.md, spoken by the real 8051 image in s51.

The board's image (make -C firmware: the serial controller with the front
panel beside it) is driven the way serial_bridge drives it, with the host's
own encoder and reply parser (plotter_bridge.link.protocol).  Checked:

- machine lines are answered `ok N<seq> Q<free>`, every reply and status
  report carries a checksum that the host's parser accepts;
- a damaged line is refused with `rs`, changes nothing, and its resend runs;
- a line sent twice runs once; a gap asks for the missing number;
- a dwell (`D`) waits; a typed line still works beside machine lines;
- a single `!` or `~` between lines does nothing, and takes no byte of the
  line after it;
- feed hold (`!!`) stops the pulses on the path and resume (`~~`) finishes
  the move where it was going: the position is exact;
- lines written back to back, as a host's adapter sends them, all arrive;
- a reset pair (Ctrl-X Ctrl-X) between lines stops the move at once and
  the board says `[reset]`.

Skipped when s51 (Debian package sdcc-ucsim) is missing, except on CI.
"""
from __future__ import annotations

import sys
import time

import pytest

from firmware_build import FIRMWARE, mcu_image, require_s51
from plotter_bridge.link.protocol import (RT_HOLD, RT_RESET, RT_RESUME, RT_STATUS, Banner, Message, Ok, Resend,
                                          Status, machine_line, parse_reply)

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"


class Link:
    """The host's end of the simulated board's UART."""

    def __init__(self, sim: s51sim.Sim) -> None:
        self.sim = sim

    def send(self, data: bytes):
        """One line out, its one reply back, parsed (None: checksum failed)."""
        self.sim.write(data)
        return self.reply()

    def reply(self):
        """The next line reply, raw and parsed."""
        raw = self.sim.read_until(REPLY).decode().strip().splitlines()[-1]
        return raw, parse_reply(raw)

    def status(self) -> Status:
        self.sim.write(RT_STATUS)
        raw = self.sim.read_until(rb"<[^>]*>[^\n]*\n").decode().strip().splitlines()[-1]
        reply = parse_reply(raw)
        assert isinstance(reply, Status), raw
        return reply

    def wait_state(self, state: str, timeout: float = 120.0) -> Status:
        deadline = time.time() + timeout
        while True:
            s = self.status()
            if s.state == state:
                return s
            assert time.time() < deadline, f"still {s.state}, waiting for {state}"
            time.sleep(0.05)


@pytest.fixture(scope="module")
def link():
    require_s51()
    with s51sim.Sim(mcu_image(), timeout=60.0) as sim:
        sim.go()
        banner = sim.read_until(rb"ready[^\n]*\n").decode().strip()
        link = Link(sim)
        link.banner = banner
        yield link


def test_banner_is_checked(link):
    reply = parse_reply(link.banner)
    assert isinstance(reply, Banner), link.banner
    assert reply.text == "PLOTTER 8051 1.0 ready"


def test_machine_lines_resends_and_dwell(link):
    raw, reply = link.send(machine_line(0, "L 100 0"))
    assert reply == Ok(0, reply.queue_free), raw
    raw, reply = link.send(machine_line(0, "L 100 0"))       # sent again: not run again
    assert isinstance(reply, Ok) and reply.seq == 0, raw
    raw, reply = link.send(machine_line(2, "L 0 50"))          # a gap: 1 is missing
    assert reply == Resend(1, 7), raw                          # E7: sequence gap
    damaged = bytearray(machine_line(1, "L 0 50"))
    damaged[3] ^= 0x01                                         # "L0 50" -> "L1 50"
    raw, reply = link.send(bytes(damaged))
    assert reply == Resend(1, 2), raw                          # E2: checksum
    raw, reply = link.send(machine_line(1, "L 0 50"))
    assert isinstance(reply, Ok) and reply.seq == 1, raw
    raw, reply = link.send(machine_line(2, "D 20"))
    assert isinstance(reply, Ok) and reply.seq == 2, raw
    raw, reply = link.send(b"L -20 -10\n")                     # typed, beside machine lines
    assert isinstance(reply, Ok) and reply.seq is None, raw
    s = link.wait_state("Idle")
    assert (s.x, s.y) == (80, 40)
    assert s.next_seq == 3 and s.seq == 0                      # S: the typed line ran last
    assert s.alarm == 0


def test_a_single_hold_or_resume_byte_does_nothing(link):
    start = link.wait_state("Idle")
    # 8 s of the board's time: still running when the bytes come, however fast s51 runs here
    # (at 1000 steps/s an idle machine's s51 once finished it between them).
    raw, reply = link.send(machine_line(3, "L 2000 0 250"))
    assert isinstance(reply, Ok) and reply.seq == 3, raw
    link.wait_state("Run")
    for byte in (b"!", b"~"):
        # The status request behind it is taken after it, and `!?!` is no pair (PROTOCOL.md).
        link.sim.write(byte)
        assert link.status().state == "Run"
    raw, reply = link.send(b"!" + machine_line(4, "L 0 100"))
    assert isinstance(reply, Ok) and reply.seq == 4, raw
    s = link.wait_state("Idle")
    assert (s.x - start.x, s.y - start.y) == (2000, 100)
    assert s.seq == 4 and s.next_seq == 5


def test_feed_hold_stops_on_the_path_and_resume_finishes(link):
    start = link.wait_state("Idle")
    raw, reply = link.send(machine_line(5, "L 3000 -1500 1000"))
    assert isinstance(reply, Ok) and reply.seq == 5, raw
    link.wait_state("Run")
    link.sim.write(RT_HOLD)
    held = link.wait_state("Hold")
    while True:                                                # braking along the path
        still = link.status()
        if (still.x, still.y) == (held.x, held.y):
            break
        held = still
    time.sleep(0.5)
    still = link.status()
    assert still.state == "Hold" and (still.x, still.y) == (held.x, held.y)
    moved = (held.x - start.x, held.y - start.y)
    assert 0 < moved[0] < 3000 and -1500 < moved[1] < 0
    assert abs(2 * moved[1] + moved[0]) <= 2                   # on the line, within a step
    link.sim.write(RT_RESUME)
    s = link.wait_state("Idle")
    assert (s.x - start.x, s.y - start.y) == (3000, -1500)
    assert s.seq == 5 and s.underruns == 0


def test_lines_written_back_to_back_all_arrive(link):
    """Bursts of four lines at once, a hundred times: each line answered ok, in order."""
    seq = link.wait_state("Idle").next_seq
    for _ in range(100):
        link.sim.write(b"".join(machine_line(seq + k, "D 1") for k in range(4)))
        for k in range(4):
            raw, reply = link.reply()
            assert isinstance(reply, Ok) and reply.seq == seq + k, raw
        seq += 4
    assert link.wait_state("Idle").next_seq == seq


def test_a_reset_pair_between_lines_stops_the_move(link):
    start = link.wait_state("Idle")
    seq = start.next_seq
    raw, reply = link.send(machine_line(seq, "L 20000 0 1000"))
    assert isinstance(reply, Ok) and reply.seq == seq, raw
    link.wait_state("Run")
    link.sim.write(RT_RESET)
    raw = link.sim.read_until(rb"\[[^\]]*\][^\n]*\n").decode().strip().splitlines()[-1]
    assert parse_reply(raw) == Message("[reset]"), raw
    stopped = link.wait_state("Idle")
    time.sleep(0.3)
    still = link.status()
    assert (still.state, still.x, still.y, still.alarm) == ("Idle", stopped.x, stopped.y, 0)
    assert 0 < stopped.x - start.x < 20000 and stopped.y == start.y
