"""Opening the board's serial port.

Exclusively (pyserial's `exclusive`, an advisory lock on the device): a
second serial_bridge, or a `plotter ... --port` beside a running bridge,
would otherwise open the same port and each would read part of the board's
replies.  No ROS.
"""
from __future__ import annotations

import errno


def open_port(name: str, baud: int):
    """The port `name` (a device path or any pyserial URL) at `baud`, not
    blocking on reads; OSError saying why it did not open."""
    import serial  # pyserial
    try:
        return serial.serial_for_url(name, baudrate=baud, timeout=0, exclusive=True)
    except Exception as exc:
        raise OSError(f"cannot open {name}: {open_error(exc)}") from exc


def open_error(exc: Exception) -> str:
    """The reason a port did not open, without pyserial's repetition of its name."""
    cause = exc.__context__
    if isinstance(cause, OSError) and cause.errno in (errno.EAGAIN, errno.EWOULDBLOCK) \
            and "exclusively lock" in str(exc):
        return "another program has it open (a serial_bridge, or a plotter command with --port)"
    if isinstance(cause, OSError) and cause.strerror:
        return cause.strerror
    return str(exc)
