"""Programs and command streams on the simulated board (simboard.SimBoard),
driven by the host's own BoardLink exactly as serial_bridge drives it."""
from __future__ import annotations

import statistics
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

from plotter_bridge.motion.commands import BoardCommand
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.link.board_link import BoardLink, Command
from plotter_bridge.link.protocol import Status, machine_line

from simboard import SimBoard, settle

BRIDGE_STATUS_HZ = 25.0      # serial_bridge's default status_hz
BRIDGE_ACK_TIMEOUT = 0.5     # serial_bridge's default ack_timeout
# serial_bridge's I/O thread waits on the port (select) and acts on a reply
# when it arrives; polling every 0.2 ms stands for the time it takes to wake.
HOST_PERIOD = 0.0002
START_RATE = 250             # the ramp's level 0: an exit of 0 means this rate
LEVEL_STEP = 200             # trapezoid: steps/s between two ramp levels


@dataclass
class StreamResult:
    board_time: float            # first to last step, seconds
    steps: int
    underruns: int
    end: Tuple[int, int]         # position after the program, steps
    commands: int
    ack_times: List[float] = field(default_factory=list)   # host time of each acknowledgement
    wire_bytes: List[int] = field(default_factory=list)    # bytes of each command on the wire
    retransmissions: int = 0
    timeouts: int = 0
    rx_overflows: int = 0
    main_loop_blocked: float = 0.0
    bytes_to_board: int = 0
    bytes_from_board: int = 0
    duration: float = 0.0        # first command sent to the board at rest, seconds
    exits_checked: int = 0       # motion commands whose exit rate the board showed
    exits_over: int = 0          # ... left more than two ramp levels faster than planned
    exit_over_max: float = 0.0   # worst board exit rate / planned exit rate
    load_times: List[float] = field(default_factory=list)  # board time each command started


class SimSession:
    """One simulated board with its link, kept across programs."""

    def __init__(self, baud: int = 115200, settings: Sequence[str] = (),
                 status_hz: float = BRIDGE_STATUS_HZ, line_cycles: int = 0,
                 host_period: float = HOST_PERIOD, record_steps: bool = False,
                 scale_status: bool = True, step_cycles: float = 0.0) -> None:
        self.core = FirmwareCore()
        self.board = SimBoard(self.core, baud=baud, line_cycles=line_cycles, host_period=host_period,
                              record_steps=record_steps, step_cycles=step_cycles)
        self.statuses: List[Tuple[float, int, int]] = []    # (host time, x, y) of each status report
        settle(self.board, 0.01)
        for s in settings:                     # typed `$k=v` lines, before the link starts
            self.board.port.write(f"${s}\n".encode())
            settle(self.board, 0.2)
            reply = self.board.port.read(4096)
            if b"ok" not in reply:
                raise RuntimeError(f"${s}: {reply!r}")
        self._acks: List[float] = []
        self.link = BoardLink(self.board.port, clock=self.board.clock,
                              ack_timeout=BRIDGE_ACK_TIMEOUT,
                              status_interval=1.0 / status_hz, baud=baud if scale_status else 0,
                              on_ack=self._on_ack, on_status=self._on_status)
        self.link.request_status()
        if not self.board.run(lambda: self.link.status is not None, self.link.poll, limit=self.board.now + 2):
            raise RuntimeError("no status from the simulated board")
        self.link.sync(self.link.status.next_seq, self.link.status.queue_free)

    def _on_status(self, st: Status) -> None:
        self.statuses.append((self.board.now, st.x, st.y))

    def _on_ack(self, cmd: Command) -> None:
        self._acks.append(self.board.now)

    @property
    def position(self) -> Tuple[int, int]:
        return self.core.position

    def close(self) -> None:
        self.core.close()

    def stream(self, commands: Sequence[BoardCommand], limit: float = 600.0) -> StreamResult:
        """Send the commands through the link and wait until the board is at rest."""
        board, link, core = self.board, self.link, self.core
        board.stats.first_step = -1.0
        board.stats.loads = []
        steps0, under0 = board.stats.steps, core.underruns
        stats0 = (link.stats.retransmissions, link.stats.timeouts, board.stats.rx_overflows,
                  board.stats.main_loop_blocked, board.stats.bytes_to_board, board.stats.bytes_from_board)
        self._acks = []
        sent = [link.submit(c.text) for c in commands]
        t0 = board.now

        def done() -> bool:
            return link.outstanding == 0 and not core.running and core.queue_free == 6

        if not board.run(done, link.poll, limit=board.now + limit):
            raise RuntimeError(f"the board did not finish within {limit} s")
        s = board.stats
        exits = exit_pairs(commands, [rate for _, rate in s.loads])
        return StreamResult(
            board_time=max(0.0, s.last_step - s.first_step) if s.first_step >= 0 else 0.0,
            steps=s.steps - steps0, underruns=core.underruns - under0, end=core.position,
            commands=len(commands), ack_times=list(self._acks),
            wire_bytes=[len(c.data) for c in sent],
            retransmissions=link.stats.retransmissions - stats0[0],
            timeouts=link.stats.timeouts - stats0[1],
            rx_overflows=s.rx_overflows - stats0[2],
            main_loop_blocked=s.main_loop_blocked - stats0[3],
            bytes_to_board=s.bytes_to_board - stats0[4],
            bytes_from_board=s.bytes_from_board - stats0[5],
            duration=board.now - t0,
            exits_checked=len(exits),
            exits_over=sum(1 for board_rate, planned in exits if exit_too_fast(board_rate, planned)),
            exit_over_max=max((b / p for b, p in exits), default=0.0),
            load_times=[t for t, _ in s.loads])


def exit_pairs(commands: Sequence[BoardCommand], exit_rates: Sequence[float]) -> List[Tuple[float, float]]:
    """(rate of its last step on the board, exit rate it was sent with; 0 is
    the ramp's start rate) per motion command followed by another command.
    exit_rates[k] is what the interrupt that loaded command k saw, so the
    exit of command k is exit_rates[k + 1]."""
    out = []
    for k, c in enumerate(commands[:-1]):
        if c.is_motion and k + 1 < len(exit_rates) and exit_rates[k + 1] > 0:
            out.append((exit_rates[k + 1], float(max(c.exit_rate, START_RATE))))
    return out


def exit_too_fast(board_rate: float, planned: float) -> bool:
    """More than two ramp levels above the plan.  The board rounds an exit
    down to a level, takes a period in whole machine cycles, and holds the
    lowest levels for one step each, so the last step before a stop comes at
    level 2 (650 steps/s)."""
    return board_rate > 1.01 * planned + 2 * LEVEL_STEP


def sustained_rate(times: Sequence[float], skip: float = 0.25) -> Optional[float]:
    """Events per second over the middle of a run (the first and last `skip`
    fraction left out: start-up and the queue draining)."""
    n = len(times)
    if n < 8:
        return None
    a, b = int(n * skip), int(n * (1 - skip)) - 1
    if times[b] <= times[a]:
        return None
    return (b - a) / (times[b] - times[a])


def mean_wire_bytes(texts: Sequence[str], first_seq: int = 1000) -> float:
    """Mean bytes per command on the wire (N, checksum and newline included)."""
    return statistics.mean(len(machine_line(first_seq + k, t)) for k, t in enumerate(texts))
