"""The firmware core and a host link on one simulated clock.

Event-driven and exact to the machine cycle (11.0592 MHz / 12): the board's
step interrupts fire on the periods its timer asks for, and its UART moves
one byte per 10 bit times in *both* directions:

- host to board: bytes written by the host queue on the wire and reach the
  receive interrupt one by one (real-time bytes act there, the rest enter
  the 64-byte receive ring);
- board to host: replies leave through the 16-byte transmit ring and the
  UART's shift register.  The 8051's `hal_putc` waits while that ring is
  full, so the main loop is blocked (it parses nothing) until the reply it is
  writing fits: modelled by running the main loop only while at most
  TX_SIZE + 1 bytes are waiting to be sent.

The main loop itself runs in zero time (the host build of the core), unless
`line_cycles` gives it a cost per line, e.g. as measured on the 8051 image
(`make -C firmware plancost`): a line in the ring is then queued and
answered that long after the main loop starts on it; with `step_cycles`
the step interrupt takes that many cycles a step from it, so a line takes
line_cycles over the share of the CPU the steps leave at the rate they run
when it starts.
The host side polls every `host_period` seconds, standing for the serial
bridge's I/O thread, which wakes when bytes arrive: whatever has arrived is
read, and what the link decides to send goes on the wire at that moment.

Used by the benchmark for board times and link throughput without real-time
waits; `MockBoard` does the same in real time (its replies through the
transmit ring too, but a pass of its main loop cannot stop half-way).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, List, Optional, Tuple

from plotter_bridge.sim.firmware_core import CYCLES_PER_S, FirmwareCore
from plotter_bridge.sim.main_loop_cpu import LineCharge, share_left

TX_SIZE = 16          # core/config.h: the transmit ring
RX_SIZE = 64          # core/config.h: the receive ring
NEVER = 1 << 62
REALTIME = (b"?", b"!", b"~", b"\x18", b"\x1b")   # acted on by the receive interrupt


@dataclass
class SimStats:
    steps: int = 0
    first_step: float = -1.0          # seconds of board time
    last_step: float = -1.0
    bytes_to_board: int = 0
    bytes_from_board: int = 0
    rx_overflows: int = 0             # bytes the receive ring had no room for
    main_loop_blocked: float = 0.0    # seconds the main loop waited on the transmit ring
    positions: List[tuple] = field(default_factory=list)   # (t, x, y) if recorded
    # One per queued command the step interrupt loaded: (time, rate of the
    # step emitted by that same interrupt, i.e. the last step of the command
    # before, steps/s; 0.0 if none: loaded from rest).
    loads: List[Tuple[float, float]] = field(default_factory=list)


class SimBoard:
    """A board and its serial line on simulated time; `port` is the host's end."""

    def __init__(self, core: FirmwareCore, baud: int = 115200, host_period: float = 0.001,
                 line_cycles: int = 0, record_steps: bool = False, step_cycles: float = 0.0) -> None:
        self.core = core
        self.step_cycles = step_cycles
        self.baud = baud
        self.byte_cycles = round(CYCLES_PER_S * 10 / baud)
        self.host_cycles = max(1, round(CYCLES_PER_S * host_period))
        self.line_cycles = line_cycles
        self.record_steps = record_steps
        self.stats = SimStats()
        self.t = 0                          # now, machine cycles
        self._to_board = bytearray()        # on the wire or waiting for it
        self._rx_done = NEVER               # the byte on the wire arrives then
        self._tx_queue = bytearray()        # transmit ring + shift register
        self._tx_done = NEVER
        self._to_host = bytearray()         # arrived at the host, not yet read
        self._tick_at = NEVER
        self._last_tick = NEVER
        self._lines = LineCharge(self._line_time)
        self._next_host = 0
        self.port = _HostPort(self)
        self._main_loop()                   # the power-on banner

    # --- time ----------------------------------------------------------------
    @property
    def now(self) -> float:
        return self.t / CYCLES_PER_S

    def clock(self) -> float:
        return self.now

    # --- the host's end -------------------------------------------------------
    def _host_write(self, data: bytes) -> None:
        if not self._to_board:
            self._rx_done = self.t + self.byte_cycles
        self._to_board += data
        self.stats.bytes_to_board += len(data)

    def _host_read(self, n: int) -> bytes:
        out = bytes(self._to_host[:n])
        del self._to_host[:n]
        return out

    # --- the board -------------------------------------------------------------
    def _blocked(self) -> bool:
        return len(self._tx_queue) > TX_SIZE + 1

    def _line_time(self) -> int:
        """Machine cycles the main loop takes for a line (line_cycles), in what the steps leave."""
        return round(self.line_cycles / share_left(self.core, self.step_cycles))

    def _main_loop(self) -> None:
        """Run the main loop while it can make progress."""
        core = self.core
        while not self._blocked():
            if not self._lines.may_poll(self.t):
                return
            free = core.rx_free()
            was_running = core.timer_running()
            core.poll()
            self._lines.polled(core.rx_free() == RX_SIZE)
            out = core.transmitted()
            if out:
                if not self._tx_queue:
                    self._tx_done = self.t + self.byte_cycles
                self._tx_queue += out
                self.stats.bytes_from_board += len(out)
            if not was_running and core.timer_running():
                self._tick_at = self.t + core.period()
                self._last_tick = NEVER
            consumed = core.rx_free() != free
            if not consumed and not out:
                return

    def run(self, until: Callable[[], bool], host_poll: Callable[[], None],
            limit: float = 3600.0) -> bool:
        """Advance until `until()` holds (checked after each host poll);
        host_poll is the host's work, called every host period.  False if
        `limit` seconds of board time passed first."""
        core = self.core
        end = round(limit * CYCLES_PER_S)
        stats = self.stats
        while self.t < end:
            blocked_from = self.t if self._blocked() else None
            busy = self._lines.due(self.t) or NEVER
            t = min(self._tick_at, self._rx_done, self._tx_done, self._next_host, busy)
            if blocked_from is not None:
                stats.main_loop_blocked += (t - blocked_from) / CYCLES_PER_S
            self.t = t
            wake = t == busy                  # the main loop may have work now
            if t == self._tick_at:
                queued = core.queue_free
                stepped = core.tick()
                if core.queue_free > queued:
                    gap = t - self._last_tick
                    stats.loads.append((t / CYCLES_PER_S,
                                        CYCLES_PER_S / gap if stepped and gap > 0 else 0.0))
                self._last_tick = t
                if stepped:
                    stats.steps += 1
                    sec = t / CYCLES_PER_S
                    if stats.first_step < 0:
                        stats.first_step = sec
                    stats.last_step = sec
                    if self.record_steps:
                        stats.positions.append((sec, *core.position))
                self._tick_at = t + core.period() if core.timer_running() else NEVER
            if t == self._rx_done:
                byte = bytes(self._to_board[:1])
                del self._to_board[:1]
                if core.rx_free() == 0 and byte not in REALTIME:
                    stats.rx_overflows += 1
                elif byte == b"\n":
                    self._lines.arrived(1)
                core.receive(byte)
                self._rx_done = t + self.byte_cycles if self._to_board else NEVER
                wake = True
            if t == self._tx_done:
                self._to_host += self._tx_queue[:1]
                del self._tx_queue[:1]
                self._tx_done = t + self.byte_cycles if self._tx_queue else NEVER
                wake = True
            if wake:
                self._main_loop()
            if t == self._next_host:
                host_poll()
                self._next_host = t + self.host_cycles
                if until():
                    return True
        return False


class _HostPort:
    """pyserial-like end of the line for BoardLink."""

    def __init__(self, board: SimBoard) -> None:
        self._board = board

    def write(self, data: bytes) -> int:
        self._board._host_write(bytes(data))
        return len(data)

    def read(self, n: int) -> bytes:
        return self._board._host_read(n)


def settle(board: SimBoard, seconds: float, host_poll: Optional[Callable[[], None]] = None) -> None:
    """Let `seconds` of board time pass."""
    end = board.now + seconds
    board.run(lambda: board.now >= end, host_poll or (lambda: None))
