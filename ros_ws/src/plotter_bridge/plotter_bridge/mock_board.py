"""A simulated plotter board behind a pseudo-terminal.

The firmware's own core (host build of firmware/core) runs here: bytes from
the pty reach its receive interrupt at the configured baud rate, its main
loop parses them, and its step interrupt fires on the schedule its timer
asks for, in real time.  Every step can be written to a trace file
(`t_s,x_steps,y_steps`, board time in seconds, absolute positions).

No ROS here: mock_board_node.py wraps it as a node, `plotter --mock` runs
it in a thread.
"""
from __future__ import annotations

import os
import pty
import select
import threading
import time
import tty
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Optional

from .firmware_core import CYCLES_PER_S, FirmwareCore


@dataclass
class MockBoardConfig:
    baud: int = 115200
    link: str = ""                 # also make a symlink to the pty here
    trace: str = ""                # CSV of every step
    speed: float = 1.0             # board time per wall time (tests may run faster)


class MockBoard:
    def __init__(self, config: MockBoardConfig, core: Optional[FirmwareCore] = None) -> None:
        self.config = config
        self.core = core or FirmwareCore()
        self._master, self._slave = pty.openpty()
        tty.setraw(self._slave)
        tty.setraw(self._master)
        os.set_blocking(self._master, False)
        self.port_path = os.ttyname(self._slave)
        if config.link:
            link = Path(config.link)
            if link.is_symlink() or link.exists():
                link.unlink()
            link.symlink_to(self.port_path)
        self._trace: Optional[IO[str]] = None
        if config.trace:
            self._trace = open(config.trace, "w", buffering=1 << 16)
            self._trace.write("t_s,x_steps,y_steps\n")
        self._trace_dirty = False
        self._pending_rx = bytearray()
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self.board_time = 0.0          # seconds on the board's clock
        self.steps = 0

    # --- lifecycle ----------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self.run, name="mock-board", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=5)
        self.close()

    def close(self) -> None:
        if self._trace:
            self._trace.close()
            self._trace = None
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.config.link:
            try:
                Path(self.config.link).unlink()
            except OSError:
                pass
        self.core.close()

    # --- the simulation loop ---------------------------------------------------
    def run(self) -> None:
        wall0 = time.monotonic()
        last = 0.0
        rx_credit = 0.0
        while not self._stop.is_set():
            now = (time.monotonic() - wall0) * self.config.speed
            dt, last = now - last, now
            self._read_pty()
            # The UART delivers one byte per 10 bit times.
            rx_credit = min(rx_credit + dt * self.config.baud / 10, 256)
            n = min(int(rx_credit), len(self._pending_rx))
            if n:
                self.core.receive(bytes(self._pending_rx[:n]))
                del self._pending_rx[:n]
                rx_credit -= n
            self.core.poll(4)
            self._run_steps(now)
            self._write_pty()
            if not self.core.timer_running() and not self._pending_rx:
                select.select([self._master], [], [], 0.002)
            elif self.core.timer_running() and self.board_time > now:
                time.sleep(min(0.001, (self.board_time - now) / self.config.speed))

    def _run_steps(self, now: float) -> None:
        core = self.core
        if not core.timer_running():
            self.board_time = now
            if self._trace_dirty:
                self._trace.flush()       # readers see a finished move at once
                self._trace_dirty = False
            return
        # Catch up with every step interrupt due by now, on the board's own clock.
        budget = 20000
        while core.timer_running() and budget:
            due = self.board_time + core.period() / CYCLES_PER_S
            if due > now:
                break
            self.board_time = due
            budget -= 1
            if core.tick():
                self.steps += 1
                if self._trace:
                    x, y = core.position
                    self._trace.write(f"{self.board_time:.6f},{x},{y}\n")
                    self._trace_dirty = True
            if budget % 64 == 0:
                core.poll()

    def _read_pty(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return
        self._pending_rx += data

    def _write_pty(self) -> None:
        out = self.core.transmitted()
        if out:
            try:
                os.write(self._master, out)
            except OSError:
                pass
