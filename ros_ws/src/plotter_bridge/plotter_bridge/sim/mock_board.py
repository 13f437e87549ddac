"""A simulated plotter board behind a pseudo-terminal.

The firmware's own core (host build of firmware/core) runs here: bytes from
the pty reach its receive interrupt at the configured baud rate, its main
loop parses them, and its step interrupt fires on the schedule its timer
asks for, in real time.  Its replies leave at the baud rate too, through the
8051's 16-byte transmit ring: while more than that waits to be sent, the
main loop waits (the firmware's `hal_putc` blocks) and parses nothing.
Every step can be written to a trace file
(`t_s,x_steps,y_steps`, board time in seconds, absolute positions; a
machine with a Z axis runs the core built with ZAXIS=1 and adds `z_steps`), and
every queued command the board starts to a sequence log (`seq`, the wire
sequence number, one a line; `reset` where the board restarted), so a test
can check that each command of a job ran exactly once.

Faults (faults.FaultSpec) are injected on the byte stream between the pty
and the core, both ways: dropped, corrupted, duplicated and delayed bytes;
`unplug()` closes the pty and makes a new one at the same link path after a
while, the core running on meanwhile; `power_cycle()` resets the core
(banner, position 0, queue empty).  Both also fire after a number of steps
(`unplug_at`, `reset_at`).

With a sheet (line following, the core built with FOLLOW=1) the three
sensors read the sheet where the carriage is at every step, and the main
loop decides each step of an `F` just before the step interrupt, as the
chip's does within a step period at the follow's feeds.

No ROS here: nodes/mock_board.py wraps it as a node, `plotter --mock` runs
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
from typing import IO, Optional, Tuple

from .faults import FaultCounts, FaultSpec, FaultyChannel
from .firmware_core import CYCLES_PER_S, FirmwareCore, find_library
from plotter_bridge.link.protocol import DEFAULT_BAUD
from plotter_bridge.motion.kinematics import Machine
from plotter_bridge.motion.planner import BOARD_CPU
from .main_loop_cpu import LineCharge, share_left
from .sheet import SensorRing, Sheet
from .uart import PacedLine

TX_SIZE = 16          # firmware core/config.h: the transmit ring
# Bytes the board acts on as soon as they arrive: line ends and the real-time bytes.
RX_EVENTS = b"\n\r?!~\x18\x1b"
RX_SIZE = 64             # core/config.h: the receive ring
REST_NAP_S = 0.02     # host s the loop sleeps at most while the board rests (_wait)
STALL = 0.003         # s: a pass of the loop this much later than it meant to wake is a stall
PANEL_CATCH_UP_MS = 100   # panel ticks run at most this late: a stalled process does not replay seconds
TRACE_FLUSH_S = 0.1      # s: longest a step waits in the trace's buffer while the board runs
STOP_WAIT_S = 30.0       # s for the loop to stop before stop() gives up rather than close the core under it


@dataclass
class MockBoardConfig:
    baud: int = DEFAULT_BAUD
    link: str = ""                 # also make a symlink to the pty here
    trace: str = ""                # CSV of every step
    speed: float = 1.0             # board time per wall time (tests may run faster)
    seq_log: str = ""              # file of the sequence numbers of the commands started
    faults: FaultSpec = FaultSpec()
    machine: Machine = Machine()   # the trace is in pen coordinates: pen mm * steps_per_mm
    # Limit switches at the -X and -Y ends: each closes at and beyond this motor position (steps from
    # where the board was powered on); None: a machine without them.
    switches: Optional[Tuple[int, int]] = None
    # Charge each line the 8051's main-loop cycles (BoardCpu, `make -C firmware plancost`) in the share of
    # the CPU its steps leave, so that short commands come no faster than the chip parses them; False:
    # a board that parses and plans in no time.
    cpu: bool = True
    # Line following (the core built with FOLLOW=1, XY table only): black lines under the pen, the pen
    # at sheet_start_mm on the sheet where the board was powered on, and the sensors round it.
    sheet: Optional[Sheet] = None
    sheet_start_mm: Tuple[float, float] = (0.0, 0.0)
    sensors: SensorRing = SensorRing(3.0)


class MockBoard:
    def __init__(self, config: MockBoardConfig, core: Optional[FirmwareCore] = None) -> None:
        self.config = config
        if config.sheet is not None:
            if config.machine.kind != "cartesian":
                raise ValueError(f"line following runs on the XY table only, not the {config.machine.kind} "
                                 f"machine: its sensors' directions are the motors' axes")
            config.sheet.check_ring(config.sensors)
        self.core = core or FirmwareCore(find_library(z_axis=config.machine.z_axis, follow=config.sheet is not None))
        if config.sheet is not None and not self.core.has_follow:
            raise ValueError(f"a sheet needs the core built with FOLLOW=1, not {self.core.library}")
        self._carriage = (0, 0)        # motor steps from the power-on place, counted from the pulses
        self._seen = self.core.position
        self._master = self._slave = -1
        self.port_path = ""
        self._open_pty()
        self._trace: Optional[IO[str]] = None
        if config.trace:
            self._trace = open(config.trace, "w", buffering=1 << 16)
            self._trace.write("t_s,x_steps,y_steps" + (",z_steps" if self.core.has_z else "") + "\n")
            self._trace.flush()
        self._seq_file: Optional[IO[str]] = None
        if config.seq_log:
            self._seq_file = open(config.seq_log, "w", buffering=1 << 16)
            self._seq_file.write("seq\n")
            self._seq_file.flush()
        self._trace_dirty = False
        self._trace_flushed_at = 0.0
        self.rx = PacedLine(config.baud)        # pty -> core, on the wire
        self.tx = PacedLine(config.baud)        # core -> pty: transmit ring and shift register
        self._tx_out = bytearray()              # sent by the UART, not yet written to the pty
        self._lines = LineCharge(self._line_seconds)
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self._lock = threading.Lock()           # events asked for by other threads
        self._want_unplug: Optional[float] = None
        self._want_reset = False
        self._replug_at: Optional[float] = None
        self.down = FaultyChannel(config.faults, 0)    # pty -> core
        self.up = FaultyChannel(config.faults, 1)      # core -> pty
        self.board_time = 0.0          # seconds on the board's clock
        self._panel_ms = 0             # board milliseconds the panel has ticked
        # Passes that ran STALL or more after they were due (the process was not
        # scheduled): the board's steps catch up, but its serial line was late.
        self.stalls = 0
        self.stall_max = 0.0
        self._wake_at = 0.0
        self._wall0 = 0.0
        self.steps = 0
        self.unplugs = 0
        self.resets = 0

    def _open_pty(self) -> None:
        self._master, self._slave = pty.openpty()
        tty.setraw(self._slave)
        tty.setraw(self._master)
        os.set_blocking(self._master, False)
        self.port_path = os.ttyname(self._slave)
        if self.config.link:
            link = Path(self.config.link)
            tmp = link.with_name(link.name + ".new")
            if tmp.is_symlink() or tmp.exists():
                tmp.unlink()
            tmp.symlink_to(self.port_path)
            tmp.replace(link)

    def _close_pty(self) -> None:
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self._master = self._slave = -1
        if self.config.link:
            try:
                Path(self.config.link).unlink()
            except OSError:
                pass

    @property
    def connected(self) -> bool:
        return self._master >= 0

    def fault_counts(self) -> FaultCounts:
        return self.down.counts.add(self.up.counts)

    # --- simulated events (any thread) ----------------------------------------------
    def unplug(self, seconds: float) -> None:
        """The port vanishes for `seconds`, then comes back at the same link path."""
        with self._lock:
            self._want_unplug = max(0.0, seconds)

    def power_cycle(self) -> None:
        """The board resets: banner, position 0, queue and numbering cleared."""
        with self._lock:
            self._want_reset = True

    # --- lifecycle ----------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self.run, name="mock-board", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=STOP_WAIT_S)
            if self._thread.is_alive():
                # Closing the core and the pty under a running loop would put two
                # threads in the C core (it is not reentrant) and reuse its fds.
                raise RuntimeError(f"the mock board's loop did not stop within {STOP_WAIT_S:g} s")
        self.close()

    def close(self) -> None:
        if self._trace:
            self._trace.close()
            self._trace = None
        if self._seq_file:
            self._sync_seq_log()
            self._seq_file.close()
            self._seq_file = None
        self._close_pty()
        self.core.close()

    # --- the simulation loop ---------------------------------------------------
    def run(self) -> None:
        self._wall0 = time.monotonic()
        last_seq_sync = 0.0
        while not self._stop.is_set():
            now = self._clock()
            late = now - self._wake_at
            if late >= STALL and self._wake_at > 0:
                self.stalls += 1
                self.stall_max = max(self.stall_max, late)
            self._events(now)
            self._read_pty(now)
            self.rx.push(self.down.receive(now), now)
            self._run_steps(now)
            self._serial(now)
            self._write_pty(now)
            if self._seq_file and (now - last_seq_sync > 0.05 or not self.core.timer_running()):
                self._sync_seq_log()
                last_seq_sync = now
            self._wait(now)

    def _clock(self) -> float:
        """Board seconds since the loop started."""
        return (time.monotonic() - self._wall0) * self.config.speed

    def _wait(self, now: float) -> None:
        """Sleep until the next byte the board or the host acts on (a line
        end or a real-time byte in either direction, bytes a faulty wire
        held back), input from the pty, the port's return after an unplug,
        or at most a millisecond while the board moves (its steps are caught
        up in batches), REST_NAP_S while it rests (nothing else is due then,
        and a graph's boards waking 500 times a second took a tenth of a
        core each)."""
        wake = now + (0.001 if self.core.timer_running() else REST_NAP_S * self.config.speed)
        for t in (self.rx.due(RX_EVENTS), self.tx.due(b"\n"), self._tx_unblocked_at(), self._busy(now),
                  self.down.due(), self.up.due(), self._replug_at):
            if t is not None:
                wake = min(wake, t)
        # From the time it is now: this pass's work has taken some of it.
        self._wake_at = max(now, wake)
        timeout = max(0.0, (wake - self._clock()) / self.config.speed)
        if self.connected:
            select.select([self._master], [], [], timeout)
        else:
            time.sleep(timeout)

    # --- the UART, both ways, at the baud rate ---------------------------------------
    def _serial(self, t: float) -> None:
        """At board time t: bytes that have arrived by then enter the receive
        ring, and the main loop runs if it can."""
        data = self.rx.pop_due(t)
        if data:
            free = self.core.rx_free()
            self.core.receive(data)
            if self.core.rx_free() < free:             # (real-time bytes do not enter the ring)
                self._lines.arrived(data.count(b"\n"))
        self._main_loop(t)

    def _serial_due(self, t: float) -> Optional[float]:
        """When the main loop next has something to act on: a line end or a
        real-time byte arriving, or room again in the transmit ring."""
        times = [x for x in (self.rx.due(RX_EVENTS), self._tx_unblocked_at(), self._busy(self.board_time))
                 if x is not None]
        return min(times) if times else None

    def _tx_blocked(self) -> bool:
        # The transmit ring plus the byte in the shift register.
        return len(self.tx) > TX_SIZE + 1

    def _tx_unblocked_at(self) -> Optional[float]:
        if not self._tx_blocked():
            return None
        return self.tx.due() + (len(self.tx) - TX_SIZE - 2) * self.tx.byte_time

    def _busy(self, after: float) -> Optional[float]:
        """When the main loop is done with the line it parses, if that is after `after`."""
        return self._lines.due(after)

    def _line_seconds(self) -> float:
        """Board seconds the chip's main loop takes for a line (config.cpu), in what the steps leave of the CPU."""
        if not self.config.cpu:
            return 0.0
        return BOARD_CPU.command_cycles / (CYCLES_PER_S * share_left(self.core, BOARD_CPU.step_cycles))

    def _main_loop(self, t: float) -> None:
        """Run the firmware's main loop (a line or a status report per pass)
        while its replies fit in the transmit ring and it is done with the
        line before (config.cpu), and its panel tick for each millisecond up
        to t."""
        self._tx_out += self.tx.pop_due(t)
        self._panel_ticks(t)
        for _ in range(4):
            if self._tx_blocked():
                return
            if not self._lines.may_poll(t):
                return
            self.core.poll()
            self._lines.polled(self.core.rx_free() == RX_SIZE)
            self._switches(stepped=False)
            out = self.core.transmitted()
            if out:
                self.tx.push(out, t)

    def _panel_ticks(self, t: float) -> None:
        """The board's 1 ms panel tick, caught up to board time t; after a
        stall of the process, at most PANEL_CATCH_UP_MS of them."""
        if not self.core.has_panel:
            return
        due = int(t * 1000)
        self._panel_ms = max(self._panel_ms, due - PANEL_CATCH_UP_MS)
        while self._panel_ms < due:
            self._panel_ms += 1
            self.core.panel_tick()

    def _events(self, now: float) -> None:
        faults = self.config.faults
        with self._lock:
            unplug, self._want_unplug = self._want_unplug, None
            reset, self._want_reset = self._want_reset, False
        if faults.unplug_at and self.steps >= faults.unplug_at and not self.unplugs:
            unplug = faults.unplug_for
        if faults.reset_at and self.steps >= faults.reset_at and not self.resets:
            reset = True
        if unplug is not None and self.connected:
            self.unplugs += 1
            self._close_pty()
            self.rx.clear()
            self.tx.clear()
            self._tx_out.clear()
            self.down.clear()
            self.up.clear()
            self._replug_at = now + unplug * self.config.speed
        if self._replug_at is not None and now >= self._replug_at:
            self._replug_at = None
            self._open_pty()
        if reset:
            self.resets += 1
            self._sync_seq_log()
            if self._seq_file:
                self._seq_file.write("reset\n")
            self.core.reset()
            self.rx.clear()
            self.tx.clear()
            self._tx_out.clear()
            self._lines.clear()

    def _sync_seq_log(self) -> None:
        """Append the commands started since the last call to the log file."""
        if not self._seq_file:
            return
        new = self.core.take_seq_log()
        if new:
            self._seq_file.write("".join(f"{s}\n" for s in new))
        self._seq_file.flush()

    def _flush_trace(self, now: float) -> None:
        """Readers see a finished move before the board can report itself at
        rest, and a running one (a hold among them: the step timer runs on)
        at most TRACE_FLUSH_S late."""
        if self._trace_dirty and (not self.core.timer_running() or now - self._trace_flushed_at >= TRACE_FLUSH_S):
            self._trace.flush()
            self._trace_dirty = False
            self._trace_flushed_at = now

    def _switches(self, stepped: bool = True) -> None:
        """The inputs where the carriage is, before the next pulse: the limit switches, and the line
        sensors over the sheet.  The carriage's place is counted from the pulses (`stepped`), not read
        from the board's position, which an `H` moves."""
        config = self.config
        if config.switches is None and config.sheet is None:
            return
        x, y = self.core.position
        if stepped:
            self._carriage = (self._carriage[0] + x - self._seen[0], self._carriage[1] + y - self._seen[1])
        self._seen = (x, y)
        if config.switches is not None:
            sx, sy = config.switches
            self.core.set_switches(self._carriage[0] <= sx, self._carriage[1] <= sy)
        if config.sheet is not None:
            self.core.set_sensors(config.sheet.sensor_bits_from(config.sheet_start_mm, self._carriage,
                                                                config.machine.steps_per_mm, config.sensors))

    def _run_steps(self, now: float) -> None:
        core = self.core
        self._switches(stepped=False)
        self._flush_trace(now)
        if not core.timer_running():
            self.board_time = now
            return
        # Catch up with every step interrupt due by now, on the board's own
        # clock, the serial line's events in between.
        serial_due = self._serial_due(now)
        budget = 20000
        while core.timer_running() and budget:
            due = self.board_time + core.period() / CYCLES_PER_S
            if due > now:
                break
            if serial_due is not None and serial_due <= due:
                self._serial(due)
                serial_due = self._serial_due(due)
            self.board_time = due
            budget -= 1
            if self.config.sheet is not None:
                # The chip's main loop decides each step of a follow within a step period at the
                # follow's feeds (tests/test_firmware_follow.py): here, just before the interrupt.
                core.follow_service()
            if core.tick():
                self.steps += 1
                self._switches()
                if self._trace:
                    x, y = core.position
                    z = "" if not core.has_z else f",{core.position_z}"
                    if self.config.machine.kind != "cartesian":
                        # Pen position by forward kinematics, in the trace's units.
                        m = self.config.machine
                        px, py = m.pen_mm((x, y))
                        self._trace.write(f"{self.board_time:.6f},{px * m.steps_per_mm:.3f},"
                                          f"{py * m.steps_per_mm:.3f}{z}\n")
                    else:
                        self._trace.write(f"{self.board_time:.6f},{x},{y}{z}\n")
                    self._trace_dirty = True
            if budget % 64 == 0:
                self._main_loop(due)
                serial_due = self._serial_due(due)
        self._flush_trace(now)

    def _read_pty(self, now: float) -> None:
        if not self.connected:
            return
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return
        self.down.send(data, now)

    def _write_pty(self, now: float) -> None:
        out = bytes(self._tx_out) + self.tx.pop_due(now)
        self._tx_out.clear()
        if out and self.connected:
            self.up.send(out, now)
        data = self.up.receive(now)
        if data and self.connected:
            try:
                os.write(self._master, data)
            except OSError:
                pass
