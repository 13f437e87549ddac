"""One direction of a serial line at its baud rate, for boards simulated in
real time.

A byte takes 10 bit times (start, 8 data, stop); bytes handed to the line
while it is busy wait their turn, and time the line stands idle is not saved
up for a later burst.  The caller says what time it is; nothing here sleeps.
"""
from __future__ import annotations

from typing import Iterable, Optional


class PacedLine:
    def __init__(self, baud: int) -> None:
        if baud <= 0:
            raise ValueError("baud must be positive")
        self.byte_time = 10.0 / baud
        self._queue = bytearray()
        self._free_at = 0.0          # when the line can start the next byte

    def __len__(self) -> int:
        return len(self._queue)

    def push(self, data: bytes, now: float) -> None:
        """Bytes handed to the line at `now`."""
        if not data:
            return
        if not self._queue:
            self._free_at = max(self._free_at, now)
        self._queue += data

    def pop_due(self, now: float) -> bytes:
        """The bytes whose last bit has arrived by `now`, in order."""
        n = min(len(self._queue), int((now - self._free_at) / self.byte_time + 1e-9)) if self._queue else 0
        if n <= 0:
            return b""
        out = bytes(self._queue[:n])
        del self._queue[:n]
        self._free_at += n * self.byte_time
        return out

    def due(self, markers: Optional[Iterable[int]] = None) -> Optional[float]:
        """When the first waiting byte (of `markers`, if given) will have
        arrived; None if there is none."""
        if not self._queue:
            return None
        if markers is None:
            k = 0
        else:
            wanted = set(markers)
            k = next((i for i, b in enumerate(self._queue) if b in wanted), -1)
            if k < 0:
                return None
        return self._free_at + (k + 1) * self.byte_time

    def clear(self) -> None:
        """Everything waiting is lost (the port vanished)."""
        self._queue.clear()
