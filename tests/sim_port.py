"""A serial port wired straight into the firmware core, on simulated time.

Tests drive BoardLink against the real protocol and interpolation code
without a pty or real-time waits: `advance(dt)` runs the board for dt
seconds of its own clock (UART bytes at the baud rate, main loop, step
interrupts).  Optional hooks may damage the bytes in either direction, or a
FaultSpec (plotter_bridge.sim.faults) whose channels count what they did; and
`unplugged` makes the port vanish for the host while the board runs on.
"""
from __future__ import annotations

from typing import Callable, Optional

from plotter_bridge.sim.faults import FaultSpec, FaultyChannel
from plotter_bridge.sim.firmware_core import CYCLES_PER_S, FirmwareCore

Mangle = Callable[[bytes], bytes]
SEQ_TAKE_EVERY = 500      # advances between takes of the core's log: far fewer starts than it holds


class SimPort:
    def __init__(self, core: FirmwareCore, baud: int = 115200,
                 to_board: Optional[Mangle] = None, from_board: Optional[Mangle] = None,
                 faults: Optional[FaultSpec] = None, record_steps: bool = True) -> None:
        self.core = core
        self.record_steps = record_steps  # False: a long job's steps are not kept (memory)
        self.faults = faults
        self.down = FaultyChannel(faults, 0) if faults else None   # host -> board
        self.up = FaultyChannel(faults, 1) if faults else None     # board -> host
        self.unplugged = False
        self.baud = baud
        self.now = 0.0
        self._to_board = to_board
        self._from_board = from_board
        self._wire = bytearray()      # host -> board, not yet delivered
        self._out = bytearray()       # board -> host, not yet read
        self._board_time = 0.0
        self._rx_credit = 0.0
        self.steps = []               # (t, x, y) of every step
        self._advances = 0

    # pyserial-like
    def write(self, data: bytes) -> int:
        if self.unplugged:
            raise OSError(5, "Input/output error")
        data = self._to_board(data) if self._to_board else data
        if self.down:
            self.down.send(data, self.now)
        else:
            self._wire += data
        return len(data)

    def read(self, n: int) -> bytes:
        if self.unplugged:
            raise OSError(5, "Input/output error")
        out, self._out = bytes(self._out[:n]), self._out[n:]
        return out

    def close(self) -> None:
        pass

    def unplug(self) -> None:
        """The port vanishes: whatever is on the wire is lost; the board runs on."""
        self.unplugged = True
        self._wire.clear()
        self._out.clear()
        for channel in (self.down, self.up):
            if channel:
                channel.clear()

    def replug(self) -> None:
        self.unplugged = False

    def clock(self) -> float:
        return self.now

    def advance(self, dt: float) -> None:
        """Run the board for dt seconds."""
        end = self.now + dt
        core = self.core
        while True:
            if self.down:
                self._wire += self.down.receive(self.now)
            self._rx_credit = min(self._rx_credit + dt * self.baud / 10, 64)
            n = min(int(self._rx_credit), len(self._wire))
            if n:
                core.receive(bytes(self._wire[:n]))
                del self._wire[:n]
                self._rx_credit -= n
            core.poll(4)
            if not core.timer_running():
                self._board_time = end          # idle: the board's clock just follows
            else:
                while core.timer_running():
                    due = self._board_time + core.period() / CYCLES_PER_S
                    if due > end:
                        break
                    self._board_time = due
                    if core.tick() and self.record_steps:
                        x, y = core.position
                        self.steps.append((due, x, y))
                    core.poll()
            out = core.transmitted()
            if out and not self.unplugged:
                out = self._from_board(out) if self._from_board else out
                if self.up:
                    self.up.send(out, end)
                else:
                    self._out += out
            if self.up:
                self._out += self.up.receive(end)
            self.now = end
            self._advances += 1
            if self._advances % SEQ_TAKE_EVERY == 0:
                core.collect_seq_log()  # the core logs SEQ_LOG_CAP starts between takes
            return
