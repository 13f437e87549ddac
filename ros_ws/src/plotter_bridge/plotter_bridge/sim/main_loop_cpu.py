"""The 8051 main loop's time for each line it takes, for the simulated boards.

The host build of the core parses and plans a line in no time; the chip
takes thousands of machine cycles (`make -C firmware plancost`), in what its
step interrupt leaves of the CPU.  `LineCharge` holds a line in the receive
ring until that much board time has passed since the main loop started on
it: the line's queue entry and its reply come at the end, as on the chip,
and the next line waits.  MockBoard (real time, seconds) and SimBoard
(simulated time, machine cycles) both use it; the cost function gives the
time in the board's own unit.
"""
from __future__ import annotations

from typing import Callable, Optional

from .firmware_core import FirmwareCore

# Of the CPU, at least this share is left to the main loop however fast the steps run.
MIN_SHARE_LEFT = 0.05


def share_left(core: FirmwareCore, step_cycles: float) -> float:
    """The share of the CPU the step interrupt leaves at the rate it runs
    now (its period in machine cycles), all of it at rest."""
    if not step_cycles or not core.timer_running():
        return 1.0
    return max(MIN_SHARE_LEFT, 1.0 - step_cycles / max(core.period(), 1))


class LineCharge:
    """Line ends in the receive ring and the one the main loop works on."""

    def __init__(self, cost: Callable[[], float]) -> None:
        self._cost = cost               # the main loop's time for a line, from when it starts on it
        self.waiting = 0                # line ends in the receive ring
        self._parsing = False           # the main loop has started on the first of them ...
        self._done_at = 0.0             # ... and is done with it then

    def arrived(self, lines: int) -> None:
        self.waiting += lines

    def may_poll(self, t: float) -> bool:
        """Whether the main loop's next pass may run at time t: not while it
        is still working on a line; the line it starts on now is charged."""
        if self.waiting and not self._parsing:
            self._parsing = True
            self._done_at = t + self._cost()
        if self._parsing:
            if t < self._done_at:
                return False
            self._parsing = False
            self.waiting -= 1
        return True

    def polled(self, ring_empty: bool) -> None:
        """After a pass: an empty receive ring holds no line (taken, or
        flushed by a reset or an e-stop)."""
        if ring_empty:
            self.waiting = 0

    def clear(self) -> None:
        """The board restarted."""
        self.waiting = 0
        self._parsing = False

    def due(self, after: float) -> Optional[float]:
        """When the main loop is done with the line it works on, if it works
        on one and that is after `after`."""
        return self._done_at if self._parsing and self._done_at > after else None
