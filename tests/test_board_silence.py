"""An open port whose board does not answer: switched off, another device
on the port, or firmware at another baud rate.  BoardSession says so after
`answer_timeout`, telling silence from bytes that are no reply, and again
at growing intervals; the board's first status report clears it.  No ROS:
the firmware core behind a simulated port."""
from typing import List

import pytest

from plotter_bridge.link.board_session import CONNECTED, CONNECTING, BoardSession, SessionConfig
from plotter_bridge.sim.firmware_core import FirmwareCore
from sim_port import SimPort

DT = 0.01


class Rig:
    def __init__(self, mangle) -> None:
        self.core = FirmwareCore()
        self.cut = True                     # the line is cut as `mangle` says, until cleared

        def through(data: bytes) -> bytes:
            return mangle(data) if self.cut else data
        self.port = SimPort(self.core, to_board=through, from_board=through)
        self.errors: List[str] = []
        self.session = BoardSession(lambda: self.port, SessionConfig(baud=115200), clock=self.port.clock,
                                    log_error=self.errors.append)

    def run(self, until: float) -> None:
        while self.port.now < until:
            self.session.pump()
            self.port.advance(DT)

    def close(self) -> None:
        self.core.close()


@pytest.fixture
def silent():
    rig = Rig(lambda data: b"")
    yield rig
    rig.close()


def test_a_board_that_sends_nothing_is_named_after_the_answer_timeout(silent):
    silent.run(4.9)
    assert silent.errors == [] and silent.session.connection == CONNECTING
    silent.run(5.2)
    assert len(silent.errors) == 1
    assert silent.errors[0].startswith("no answer from the board in 5 s: nothing came back on the port "
                                       "at 115200 baud; is the board powered")
    assert silent.session.last_error == silent.errors[0]


def test_it_is_said_again_at_growing_intervals(silent):
    silent.run(120.0)
    said_at = [int(e.split(" in ")[1].split(" s")[0]) for e in silent.errors]
    assert said_at[:3] == [5, 15, 45]
    gaps = [b - a for a, b in zip(said_at, said_at[1:])]
    assert all(g <= 61 for g in gaps) and gaps == sorted(gaps)


def test_bytes_that_are_no_reply_point_at_the_baud_rate():
    rig = Rig(lambda data: bytes(0x80 | (b ^ 0x5A) for b in data))     # what a wrong baud rate makes of them
    try:
        rig.run(5.2)
        assert len(rig.errors) == 1, rig.errors
        assert "bytes came back on the port at 115200 baud, none of them a line the firmware sends" in rig.errors[0]
        assert "BAUD=115200" in rig.errors[0]
    finally:
        rig.close()


def test_the_first_status_report_clears_it(silent):
    silent.run(5.2)
    assert silent.session.last_error
    silent.cut = False                       # the board is switched on
    silent.run(8.0)
    assert silent.session.connection == CONNECTED
    assert silent.session.last_error == ""
    assert len(silent.errors) == 1
