"""Faults on a serial line, for the mock board and the link tests.

A FaultSpec says how the wire misbehaves: each byte may be dropped,
corrupted (one bit flipped), duplicated, or stall the stream for a while
(everything behind it waits too, so order is kept), each at its own rate;
and whole-board events: the port vanishing for some seconds, or the board
resetting, after a given number of steps.  A FaultyChannel applies the byte
faults to one direction of the wire with its own seeded generator, so a run
is reproducible, and counts what it did.

Written as `drop=0.01,corrupt=0.01,dup=0.001,delay=0.001,delay_ms=50,seed=3,
unplug_at=4000,unplug_for=2,reset_at=9000` on the command line and in the
mock board's `faults` parameter.
"""
from __future__ import annotations

import math
import random
from collections import deque
from dataclasses import dataclass, fields
from typing import Deque, Optional, Tuple


@dataclass(frozen=True)
class FaultSpec:
    drop: float = 0.0        # probability that a byte is lost
    corrupt: float = 0.0     # probability that one of its bits is flipped
    dup: float = 0.0         # probability that it arrives twice
    delay: float = 0.0       # probability that the stream stalls before it
    delay_ms: float = 50.0   # length of a stall
    seed: int = 1
    unplug_at: int = 0       # steps into the run at which the port vanishes (0: never)
    unplug_for: float = 2.0  # seconds until it comes back at the same path
    reset_at: int = 0        # steps into the run at which the board resets (0: never)

    @property
    def mangles_bytes(self) -> bool:
        return any((self.drop, self.corrupt, self.dup, self.delay))

    def __str__(self) -> str:
        default = FaultSpec()
        parts = [f"{f.name}={getattr(self, f.name):g}" for f in fields(self)
                 if getattr(self, f.name) != getattr(default, f.name)]
        return ",".join(parts) or "none"


_RATES = ("drop", "corrupt", "dup", "delay")
_INTS = ("seed", "unplug_at", "reset_at")


def parse_faults(text: str) -> FaultSpec:
    """`drop=0.01,corrupt=0.01` -> FaultSpec; ValueError naming the bad item."""
    values = {}
    known = {f.name for f in fields(FaultSpec)}
    for item in filter(None, (s.strip() for s in text.split(","))):
        key, eq, raw = item.partition("=")
        key = key.strip()
        if not eq or key not in known:
            raise ValueError(f"fault '{item}': expected one of {', '.join(sorted(known))} as key=value")
        if key in values:
            raise ValueError(f"fault '{key}' given twice")
        try:
            value = int(raw) if key in _INTS else float(raw)
        except ValueError:
            raise ValueError(f"fault '{key}': '{raw}' is not a number") from None
        if key in _RATES and not (math.isfinite(value) and 0.0 <= value <= 0.5):
            raise ValueError(f"fault '{key}': rate {raw} outside 0..0.5")
        if key in ("delay_ms", "unplug_for") and not (math.isfinite(value) and 0.0 <= value <= 3600e3):
            raise ValueError(f"fault '{key}': {raw} is not a usable duration")
        if key in ("unplug_at", "reset_at") and value < 0:
            raise ValueError(f"fault '{key}': step count must not be negative")
        values[key] = value
    return FaultSpec(**values)


@dataclass
class FaultCounts:
    dropped: int = 0
    corrupted: int = 0
    duplicated: int = 0
    delayed: int = 0
    bytes: int = 0

    @property
    def total(self) -> int:
        return self.dropped + self.corrupted + self.duplicated + self.delayed

    def add(self, other: "FaultCounts") -> "FaultCounts":
        return FaultCounts(*(getattr(self, f.name) + getattr(other, f.name) for f in fields(self)))


class FaultyChannel:
    """One direction of the wire: `send(data, now)` in, `receive(now)` out."""

    def __init__(self, spec: FaultSpec, stream: int = 0) -> None:
        self.spec = spec
        self.counts = FaultCounts()
        self._rng = random.Random(spec.seed * 1_000_003 + stream)
        self._queue: Deque[Tuple[float, bytearray]] = deque()
        self._release = 0.0          # bytes are never released before earlier ones

    def send(self, data: bytes, now: float) -> None:
        spec, rng, counts = self.spec, self._rng, self.counts
        if not spec.mangles_bytes:
            self._push(max(now, self._release), data)
            return
        release = max(now, self._release)
        out = bytearray()
        for b in data:
            counts.bytes += 1
            r = rng.random()
            if r < spec.drop:
                counts.dropped += 1
                continue
            r -= spec.drop
            if r < spec.corrupt:
                counts.corrupted += 1
                b ^= 1 << rng.randrange(8)
            elif r - spec.corrupt < spec.dup:
                counts.duplicated += 1
                out.append(b)
            elif r - spec.corrupt - spec.dup < spec.delay:
                counts.delayed += 1
                self._push(release, out)
                out = bytearray()
                release += spec.delay_ms / 1000.0
            out.append(b)
        self._push(release, out)

    def _push(self, when: float, data) -> None:
        if not data:
            return
        self._release = when
        if self._queue and self._queue[-1][0] == when:
            self._queue[-1][1].extend(data)
        else:
            self._queue.append((when, bytearray(data)))

    def receive(self, now: float) -> bytes:
        out = bytearray()
        while self._queue and self._queue[0][0] <= now:
            out += self._queue.popleft()[1]
        return bytes(out)

    def due(self) -> Optional[float]:
        """When the next bytes on the wire arrive, if any are on it."""
        return self._queue[0][0] if self._queue else None

    def clear(self) -> None:
        """Everything still on the wire is lost (the port vanished)."""
        self._queue.clear()
