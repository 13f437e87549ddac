"""The firmware's line following (core/follow.c, host build) run on a virtual
sheet: at every step period the sensors read the sheet where the pen is, and
the core's answer moves the pen one step or stops it.

Units: the command's distances in mm, turned into steps as the host does;
the trace in steps from the machine origin.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from plotter_bridge.link.follow import FollowError, FollowGoal, follow_command

from .firmware_core import FirmwareCore
from .sheet import Sheet, SensorRing

__all__ = ["FollowError", "FollowGoal", "FollowRun", "follow"]

STEPS = {0: (1, 0), 1: (-1, 0), 2: (0, 1), 3: (0, -1)}
STOPS = {0x80: "home", 0x81: "lost", 0x82: "distance", 0x84: "reversed"}  # core/follow.h FOLLOW_HOME...


@dataclass
class FollowRun:
    reason: str                                  # home, lost, distance, or "cap" (the harness gave up)
    trace: List[Tuple[int, int]] = field(default_factory=list)   # pen in steps, the start first
    bits: List[int] = field(default_factory=list)                # the sensors at each step period

    def trace_mm(self, steps_per_mm: float) -> List[Tuple[float, float]]:
        return [(x / steps_per_mm, y / steps_per_mm) for x, y in self.trace]

    def length_mm(self, steps_per_mm: float) -> float:
        return (len(self.trace) - 1) / steps_per_mm


def follow(core: FirmwareCore, sheet: Sheet, ring: SensorRing, start_mm: Tuple[float, float],
           goal: Optional[FollowGoal] = None, steps_per_mm: float = 80.0, cap_steps: int = 2_000_000) -> FollowRun:
    """Follow the sheet's line from start_mm (the pen on it) until the core stops.  The goal is checked as
    the board's F is (FollowError with every reason); by default it sets out along +X with a start gate
    half the line's width."""
    sheet.check_ring(ring)
    goal = goal or FollowGoal(gate_mm=sheet.width_mm / 2)
    heading, lost, most, home = (int(v) for v in follow_command(goal, steps_per_mm).split()[1:5])
    core.follow_start(heading, lost, most, home)
    x, y = round(start_mm[0] * steps_per_mm), round(start_mm[1] * steps_per_mm)
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
