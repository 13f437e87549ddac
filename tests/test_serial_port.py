"""link/serial_port.py: the board's port is opened exclusively, and a port
that does not open says why in words a user can act on.  No ROS: ptys."""
import os

import pytest

from plotter_bridge.link.serial_port import open_port


@pytest.fixture
def pty():
    master, slave = os.openpty()
    yield os.ttyname(slave)
    os.close(master)
    os.close(slave)


def test_a_second_opener_is_refused_and_told_who_holds_the_port(pty):
    first = open_port(pty, 115200)
    try:
        with pytest.raises(OSError) as refused:
            open_port(pty, 115200)
        assert str(refused.value) == (f"cannot open {pty}: another program has it open "
                                      f"(a serial_bridge, or a plotter command with --port)")
    finally:
        first.close()
    open_port(pty, 115200).close()              # free again once the first lets go


def test_the_port_talks_both_ways(pty):
    port = open_port(pty, 9600)
    try:
        assert port.baudrate == 9600 and port.timeout == 0
        assert port.read(10) == b""              # no wait for bytes that are not there
    finally:
        port.close()


def test_a_missing_port_names_the_reason():
    with pytest.raises(OSError, match=r"^cannot open /nonexistent/ttyUSB9: No such file or directory$"):
        open_port("/nonexistent/ttyUSB9", 115200)


def test_urls_open_as_pyserial_opens_them():
    port = open_port("loop://", 115200)
    try:
        port.write(b"?")
        assert port.read(1) == b"?"
    finally:
        port.close()
