"""BoardLink against the firmware core: streaming, flow control, resends.

No ROS, no pty: the board runs on simulated time through tests/sim_port.py.
"""
import random
import re

import pytest

from firmware_build import FIRMWARE, host_library
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.link.board_link import STATUS_SHARE, WAIT_SHARE, BoardLink
from plotter_bridge.link.protocol import (Banner, Err, Ok, Resend, Status, checksum, compact_command, crc16,
                                     machine_line, parse_reply)
from sim_port import SimPort


@pytest.fixture
def core():
    c = FirmwareCore(host_library())
    yield c
    c.close()


def run_until(port, link, cond, limit=120.0, dt=0.002):
    while port.now < limit:
        link.poll()
        port.advance(dt)
        if cond():
            return True
    return False


def finished(port, link):
    """All commands acknowledged and the board (ground truth) at rest."""
    return lambda: link.outstanding == 0 and not port.core.running and port.core.queue_free == 6


def connect(port, **kw):
    link = BoardLink(port, clock=port.clock, **kw)
    assert run_until(port, link, lambda: link.status is not None, limit=1.0)
    link.sync(link.status.next_seq, link.status.queue_free)
    return link


def test_machine_line_format_and_checksum():
    assert machine_line(17, "L 400 -300") == b"N17L400 -300*%d\n" % checksum("N17L400 -300")
    assert machine_line(65536 + 3, "P 1").startswith(b"N3P1*")


def test_compact_command_drops_only_what_the_firmware_defaults():
    assert compact_command("L 400 -300 2000 0") == "L400 -300 2000"
    assert compact_command("L 400 -300 0 0") == "L400 -300"
    assert compact_command("L 0 0 2000 850") == "L0 0 2000 850"
    assert compact_command("A 10 0 5 0 3000 0") == "A10 0 5 0 3000"
    assert compact_command("C 0 0 -5 0 0 0") == "C0 0 -5 0"
    assert compact_command("P 0") == "P0"          # not a motion command: its argument stays
    assert compact_command("D 0") == "D0"
    assert compact_command("H") == "H"
    assert compact_command("") == ""


@pytest.mark.parametrize("command", [
    "L 400 -300 2000 0", "L -7 0 15 0", "L 0 -1 12850 12850", "A 20 0 10 0 3000 0",
    "C -20 0 -10 0 0 0", "P 1", "D 5", "H", "L 10 0 0 0", "$",
])
def test_compact_machine_lines_do_what_the_typed_line_does(command):
    """The firmware core answers a compacted machine line exactly as it
    answers the command typed in full."""
    replies = []
    for line in (command.encode() + b"\n", machine_line(0, command)):
        c = FirmwareCore(host_library())
        try:
            c.transmitted()                             # the banner
            c.receive(line)
            c.poll(4)
            reply = c.transmitted().decode()
            steps = c.run_steps()
            replies.append((reply.replace(" N0", "").split(" *")[0], c.position, c.pen_down, len(steps)))
        finally:
            c.close()
    assert replies[0] == replies[1]
    assert replies[0][0].startswith(("ok", "$")), replies[0]


def signed(text):
    return f"{text} *{checksum(text + ' ')}"


def test_reply_parsing():
    assert parse_reply(signed("ok N12 Q5")) == Ok(12, 5)
    assert parse_reply(signed("ok Q6")) == Ok(None, 6)
    assert parse_reply(signed("rs N9 E2")) == Resend(9, 2)
    assert parse_reply(signed("err N4 E8 bad arc")) == Err(4, 8, "bad arc")
    assert parse_reply(signed("err N4 E8")) == Err(4, 8, "bad arc")      # as the board sends it
    assert parse_reply(signed("err E99")) == Err(None, 99, "unknown error")
    assert parse_reply(signed("<Run X12 Y-3 Q4 N18 S17 P1 U0 A0>")) == Status("Run", 12, -3, 4, 18, 17, True, 0, 0)
    assert parse_reply(signed("PLOTTER 8051 1.0 ready")) == Banner("PLOTTER 8051 1.0 ready")
    assert parse_reply("ok N12 Q5") is None                   # no checksum: not trusted
    assert parse_reply(signed("ok N12 Q5").replace("N12", "N13")) is None
    assert parse_reply(signed("ok N12 Q5").replace("Q5", "Q")) is None


def test_checksum_is_crc16_ccitt_false():
    assert crc16(b"123456789") == 0x29B1                      # the catalogue's check value
    assert crc16(b"") == 0xFFFF
    assert checksum("N17L400 -300") == 41846


def test_checksum_catches_what_a_sum_misses():
    assert checksum("N1 L 100 ") != checksum("N1 L 1 ")      # a dropped pair of equal bytes
    assert checksum("N1 L 12 ") != checksum("N1 L 21 ")      # swapped bytes
    # 255 and 0 are the same modulo 255, and two flips of bit 7 cancel modulo 256.
    assert crc16(b"\xff\x01") != crc16(b"\x00\x01")
    assert crc16(bytes([0x41, 0x42, 0x43, 0x44])) != crc16(bytes([0x41, 0xC2, 0xC3, 0x44]))


def test_every_two_bit_flips_in_a_line_are_caught():
    body = b"N65535C-32767 -32767 -32767 -32767 12850 12850"
    good = crc16(body)
    bits = len(body) * 8
    for a in range(bits):
        for b in range(a, bits):
            damaged = bytearray(body)
            damaged[a // 8] ^= 1 << (a % 8)
            if b != a:
                damaged[b // 8] ^= 1 << (b % 8)
            assert crc16(bytes(damaged)) != good, (a, b)


def test_protocol_md_worked_examples(core):
    """The check values PROTOCOL.md gives are the host's and the board's."""
    text = (FIRMWARE / "PROTOCOL.md").read_text()
    lines = re.findall(r"^ {4}(N\d+[^*\n]*)\*(\d+)$", text, re.M)
    assert {body for body, _ in lines} >= {"N17 L 400 -300 ", "N17L400 -300"}
    for body, value in lines:
        assert checksum(body) == int(value), body
        core.reset()
        core.transmitted()
        core.receive(f"{body}*{value}\n".encode())
        core.poll(4)
        # N17 while the board expects 0: a sequence gap (E7), not a checksum error (E2).
        replies = [parse_reply(r) for r in core.transmitted().decode().splitlines()]
        assert Resend(0, 7) in replies, replies
    reply = re.search(r"`(ok N17 Q5) \*(\d+)`", text)
    assert reply and checksum(reply.group(1) + " ") == int(reply.group(2))
    assert parse_reply(f"{reply.group(1)} *{reply.group(2)}") == Ok(17, 5)
    assert "0x29B1" in text and crc16(b"123456789") == 0x29B1


def test_stream_many_segments_keeps_queue_busy_and_ends_exactly(core):
    port = SimPort(core)
    link = connect(port)
    rng = random.Random(1)
    x = y = 0
    for _ in range(300):
        dx, dy = rng.randint(-200, 200), rng.randint(-200, 200)
        link.submit(f"L {dx} {dy} 6000 0")
        x, y = x + dx, y + dy
    assert run_until(port, link, finished(port, link))
    assert core.position == (x, y)
    assert link.stats.retransmissions == 0
    assert core.seq_log() == list(range(300))


def test_board_refusal_is_reported_and_not_retried(core):
    port = SimPort(core)
    errors = []
    link = connect(port, on_error=lambda cmd, err: errors.append((cmd.text, err.code)))
    link.submit("L 10 0")
    link.submit("A 10 0 0 0")          # centre on the start: refused
    link.submit("L 0 10")
    assert run_until(port, link, finished(port, link))
    assert errors == [("A 10 0 0 0", 8)]
    assert core.position == (10, 10)


@pytest.mark.parametrize("rate", [0.002, 0.01])
def test_corrupted_bytes_both_ways_lose_nothing_and_repeat_nothing(core, rate):
    rng = random.Random(7)

    def damage(data: bytes) -> bytes:
        out = bytearray()
        for b in data:
            r = rng.random()
            if r < rate:
                continue                       # dropped
            if r < 2 * rate:
                b ^= 1 << rng.randrange(8)     # corrupted
            out.append(b)
        return bytes(out)

    port = SimPort(core, to_board=damage, from_board=damage)
    link = connect(port, ack_timeout=0.3)
    x = y = 0
    moving = []
    for k in range(400):
        dx, dy = (k % 7) * 9 - 27, (k % 5) * 11 - 22
        link.submit(f"L {dx} {dy} 8000 0")
        x, y = x + dx, y + dy
        if (dx, dy) != (0, 0):
            moving.append(k)          # a zero-length line is acknowledged but queues nothing
    assert run_until(port, link, finished(port, link), limit=600)
    assert core.position == (x, y)
    assert core.seq_log() == moving, "every command executed exactly once, in order"
    assert link.stats.retransmissions > 0


class CountingPort(SimPort):
    """Counts the status requests the host sends."""
    polls = 0

    def write(self, data: bytes) -> int:
        self.polls += data.count(b"?")
        return super().write(data)


@pytest.mark.parametrize("baud", [9600, 115200])
def test_status_polls_take_a_share_of_the_link(core, baud):
    """While lines wait to be sent, status reports may take STATUS_SHARE of
    the reply direction's bytes; otherwise up to WAIT_SHARE, however often
    status_interval asks."""
    port = CountingPort(core, baud=baud)
    link = connect(port, status_interval=0.001, baud=baud)

    def budget(share, seconds):
        return share * baud / 10 * seconds / 40 + 2      # a report takes at least 40 bytes

    port.polls, t0 = 0, port.now
    run_until(port, link, lambda: False, limit=port.now + 5.0)          # nothing to send
    assert 0 < port.polls <= budget(WAIT_SHARE, port.now - t0)

    for k in range(4000):                                                # one step each: faster than the link
        link.submit(f"L {1 - 2 * (k % 2)} 0 12850 12850")
    port.polls, t0 = 0, port.now
    assert run_until(port, link, lambda: link.outstanding < 1000, limit=port.now + 600)
    assert 0 < port.polls <= budget(STATUS_SHARE, port.now - t0)


def test_full_queue_is_probed_with_a_line_the_board_has_run(core):
    """With the board's queue full and nothing on its way, the link learns of
    a free slot from the ok to a long-executed number: status reports are
    not needed (here one every 10 s), nothing runs twice, nothing is resent."""
    port = SimPort(core)
    link = connect(port, status_interval=10.0, baud=115200)
    for k in range(40):
        link.submit(f"L {400 * (1 - 2 * (k % 2))} 0 8000 0")       # 50 ms each: the queue fills
    assert run_until(port, link, finished(port, link), limit=port.now + 9.0)
    assert link.stats.probes > 0
    assert link.stats.retransmissions == link.stats.garbled_replies == link.stats.resend_requests == 0
    assert core.seq_log() == list(range(40))
    assert core.position == (0, 0)
