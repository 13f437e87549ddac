"""The real-time bytes of firmware/PROTOCOL.md in the host build of the
firmware core (the same receive path as the 8051's UART interrupt):

- hold `!`, resume `~` and reset Ctrl-X act only as a pair of the same byte
  between lines; a single one between lines does nothing, and the line
  after it runs whole;
- a pair split by any other byte does nothing, and that other byte is
  handled as usual (another real-time byte arms in its turn);
- inside a line none of them acts, paired or not, and none enters the
  line;
- the damaged line starts of docs/reliability.md (`N` dropped, `8` flipped
  into Ctrl-X, `1` into `!`) cost a resend and nothing else;
- ESC and `?` still act as single bytes, anywhere.
"""
from __future__ import annotations

import pytest

from firmware_build import host_library
from plotter_bridge.link.protocol import (RT_ESTOP, RT_HOLD, RT_RESET, RT_RESUME, RT_STATUS, Ok, Resend,
                                          Status, machine_line, parse_reply)
from plotter_bridge.sim.firmware_core import FirmwareCore

HOLD, RESUME, RESET = b"!", b"~", b"\x18"
LONG = 4000                   # steps of the move under way while the bytes arrive


@pytest.fixture
def core():
    c = FirmwareCore(host_library())
    c.poll(3)
    c.transmitted()
    yield c
    c.close()


def replies(core: FirmwareCore, data: bytes) -> list:
    """Bytes in, the main loop run, every reply line parsed."""
    core.receive(data)
    core.poll(5)
    return [parse_reply(line) for line in core.transmitted().decode().splitlines() if line.strip()]


def status(core: FirmwareCore) -> Status:
    reply = replies(core, RT_STATUS)[-1]
    assert isinstance(reply, Status), reply
    return reply


def advance(core: FirmwareCore, ticks: int) -> None:
    for _ in range(ticks):
        core.poll()
        if core.timer_running():
            core.tick()


def moving(core: FirmwareCore) -> None:
    """Line 0, a long move, under way; line 1 queued behind it."""
    assert replies(core, machine_line(0, f"L {LONG} 0 2000")) == [Ok(0, 5)]
    assert replies(core, machine_line(1, "L 0 100")) == [Ok(1, 4)]
    advance(core, 300)
    st = status(core)
    assert st.state == "Run" and 0 < st.x < LONG


def finish(core: FirmwareCore, x: int = LONG, y: int = 100) -> Status:
    """Run to the end: every queued line ran, exactly once."""
    core.run_steps()
    core.poll(3)
    st = status(core)
    assert (st.state, st.x, st.y, st.queue_free) == ("Idle", x, y, 6), st
    return st


def test_the_host_sends_pairs():
    assert (RT_HOLD, RT_RESUME, RT_RESET) == (HOLD * 2, RESUME * 2, RESET * 2)
    assert (RT_ESTOP, RT_STATUS) == (b"\x1b", b"?")


@pytest.mark.parametrize("byte", [HOLD, RESUME, RESET], ids=["hold", "resume", "reset"])
def test_a_single_byte_between_lines_does_nothing_and_the_next_line_runs(core, byte):
    moving(core)
    assert replies(core, byte) == []
    advance(core, 300)
    assert status(core).state == "Run"
    # The armed byte takes nothing of the line after it: its N is read.
    assert replies(core, byte + machine_line(2, "L 0 50")) == [Ok(2, 4)]
    st = finish(core, y=150)
    assert st.next_seq == 3 and core.seq_log() == [0, 1, 2]


def test_the_hold_pair_holds_and_the_resume_pair_resumes(core):
    moving(core)
    assert replies(core, b"!!") == []
    advance(core, 2000)
    held = status(core)
    assert held.state == "Hold" and held.x < LONG
    advance(core, 300)
    assert status(core).x == held.x                   # standing still on the path
    assert replies(core, b"~") == []
    advance(core, 300)
    assert status(core) == held                      # a single resume does nothing either
    assert replies(core, b"~~") == []
    advance(core, 300)
    assert status(core).state == "Run"
    finish(core)
    assert core.seq_log() == [0, 1]


def test_the_reset_pair_stops_and_flushes_keeping_the_position(core):
    moving(core)
    core.receive(b"\x18\x18")
    assert not core.timer_running()                  # the pulses stop in the interrupt
    core.poll(3)
    assert "[reset]" in core.transmitted().decode()
    st = status(core)
    assert (st.state, st.queue_free, st.alarm) == ("Idle", 6, 0) and 0 < st.x < LONG
    assert core.seq_log() == [0]                      # line 1 was flushed, never started


def test_a_third_byte_arms_again(core):
    moving(core)
    assert replies(core, b"!!!") == []
    advance(core, 2000)
    assert status(core).state == "Hold"
    assert replies(core, b"~~~") == []                # resumed; the third only armed
    advance(core, 300)
    assert status(core).state == "Run"
    assert replies(core, b"!") == []                  # arms: the leftover ~ is not a pair with it
    advance(core, 300)
    assert status(core).state == "Run"
    finish(core)


@pytest.mark.parametrize("data", [b"!?!", b"!\n!", b"!\r!", b"!~!", b"\x18!\x18", b"\x18~\x18",
                                  b"~!~", b"\x18\n\x18"])
def test_a_pair_split_by_another_byte_does_nothing(core, data):
    moving(core)
    for reply in replies(core, data):
        assert isinstance(reply, Status), reply      # only the '?' is answered
    advance(core, 2000)
    assert status(core).state == "Run"
    finish(core)
    assert core.seq_log() == [0, 1]


def test_the_byte_that_splits_a_pair_is_handled_as_usual(core):
    moving(core)
    assert replies(core, b"~!!") == []               # ~ armed, then ! armed and acted
    advance(core, 2000)
    assert status(core).state == "Hold"
    assert replies(core, b"!~~") == []
    advance(core, 300)
    assert status(core).state == "Run"
    finish(core)


@pytest.mark.parametrize("pair", [b"!!", b"~~", b"\x18\x18"], ids=["hold", "resume", "reset"])
@pytest.mark.parametrize("at", [1, 3, 6])
def test_inside_a_line_nothing_acts(core, pair, at):
    moving(core)
    line = machine_line(2, "L 0 50")
    assert replies(core, line[:at] + pair + line[at:]) == [Ok(2, 4)]   # dropped, never in the line
    advance(core, 2000)
    assert status(core).state == "Run"
    finish(core, y=150)
    assert core.seq_log() == [0, 1, 2]


@pytest.mark.parametrize("n, pos, bit", [(8, 1, 0x20), (81, 1, 0x20), (18, 1, 0x10), (1, 1, 0x10), (18, 2, 0x20)],
                         ids=["8-ctrl-x", "81-ctrl-x", "18-bang", "1-bang", "18-ctrl-x-inside"])
def test_a_damaged_line_start_costs_a_resend_only(core, n, pos, bit):
    """The cases of docs/reliability.md: line n's N dropped, and a digit with
    one bit flipped into Ctrl-X ('8' ^ 0x20) or '!' ('1' ^ 0x10)."""
    for k in range(n - 1):
        assert replies(core, machine_line(k, "H")) == [Ok(k, 6)]
    assert replies(core, machine_line(n - 1, f"L {LONG} 0 2000")) == [Ok(n - 1, 5)]
    advance(core, 300)
    damaged = bytearray(machine_line(n, "L 0 100"))
    damaged[pos] ^= bit
    damaged = bytes(damaged[1:])                     # the N dropped
    assert damaged[pos - 1:pos] in (RESET, HOLD)
    assert replies(core, damaged) == [Resend(n, 2)]
    advance(core, 2000)
    assert status(core).state == "Run"
    assert replies(core, machine_line(n, "L 0 100")) == [Ok(n, 5)]
    st = finish(core)
    assert st.next_seq == n + 1 and core.seq_log() == [n - 1, n]


def test_estop_and_status_still_act_as_single_bytes_anywhere(core):
    moving(core)
    line = machine_line(2, "L 0 50")
    out = replies(core, line[:4] + b"?" + line[4:])
    assert isinstance(out[0], Status) and out[0].state == "Run"
    assert out[1:] == [Ok(2, 4)]                     # the ? is not part of the line
    core.receive(line[:4] + RT_ESTOP)
    assert not core.timer_running()
    core.poll(3)
    st = status(core)
    assert (st.state, st.alarm, st.queue_free) == ("Alarm", 1, 6)
