"""The firmware's line following (core/follow.c, host build) run on a virtual
sheet: at every step period the sensors read the sheet where the pen is, and
the core's answer moves the pen one step or stops it.

Units: the command's distances in mm, turned into steps as the host does;
the trace in steps from the machine origin.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from plotter_bridge.link.follow import MAX_GATE, MAX_STEPS, FollowError, heading_notch, mm_to_steps

from .firmware_core import FirmwareCore
from .sheet import Sheet, SensorRing

__all__ = ["FollowArgs", "FollowError", "FollowRun", "follow"]

STEPS = {0: (1, 0), 1: (-1, 0), 2: (0, 1), 3: (0, -1)}
STOPS = {0x80: "home", 0x81: "lost", 0x82: "distance"}


@dataclass(frozen=True)
class FollowArgs:
    start_mm: Tuple[float, float]       # the pen on the line
    heading_deg: float = 0.0            # the way to set out along it (counter-clockwise from +X)
    lost_mm: float = 5.0                # no sensor on black for this far: the line is lost
    max_mm: float = 0.0                 # stop after this far (0: go round to the start)
    home_mm: Optional[float] = None     # the start gate's half width (default: half the line's width)

    def heading_notch(self) -> int:
        return heading_notch(self.heading_deg)


@dataclass
class FollowRun:
    reason: str                                  # home, lost, distance, or "cap" (the harness gave up)
    trace: List[Tuple[int, int]] = field(default_factory=list)   # pen in steps, the start first
    bits: List[int] = field(default_factory=list)                # the sensors at each step period

    def trace_mm(self, steps_per_mm: float) -> List[Tuple[float, float]]:
        return [(x / steps_per_mm, y / steps_per_mm) for x, y in self.trace]

    def length_mm(self, steps_per_mm: float) -> float:
        return (len(self.trace) - 1) / steps_per_mm


def _steps(mm: float, steps_per_mm: float, what: str, limit: int) -> int:
    problems: List[str] = []
    n = mm_to_steps(mm, steps_per_mm, what, limit, problems)
    if problems:
        raise FollowError("; ".join(problems))
    return n


def follow(core: FirmwareCore, sheet: Sheet, ring: SensorRing, args: FollowArgs,
           steps_per_mm: float = 80.0, cap_steps: int = 2_000_000) -> FollowRun:
    """Follow the sheet's line from args.start_mm until the core stops."""
    sheet.check_ring(ring)
    lost = _steps(args.lost_mm, steps_per_mm, "lost distance", MAX_STEPS)
    if lost == 0:
        raise FollowError("lost distance must be at least one step")
    home_mm = sheet.width_mm / 2 if args.home_mm is None else args.home_mm
    home = _steps(home_mm, steps_per_mm, "home gate", MAX_GATE)
    most = _steps(args.max_mm, steps_per_mm, "distance", MAX_STEPS)
    core.follow_start(args.heading_notch(), lost, most, home)
    x, y = round(args.start_mm[0] * steps_per_mm), round(args.start_mm[1] * steps_per_mm)
    run = FollowRun("cap", [(x, y)])
    for _ in range(cap_steps):
        bits = sheet.sensor_bits(x / steps_per_mm, y / steps_per_mm, ring)
        run.bits.append(bits)
        answer = core.follow_tick(bits)
        if answer in STOPS:
            run.reason = STOPS[answer]
            return run
        dx, dy = STEPS[answer]
        x, y = x + dx, y + dy
        run.trace.append((x, y))
    return run
