"""Line following on the board built with FOLLOW=1 (firmware/PROTOCOL.md,
*Build options*): a follow goal in millimetres and degrees as the board's
command `F`, and the names of what its status report says of the follow.

Pure functions; the wire's units are steps and notches of 15 degrees.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Tuple

HEADINGS = 24                    # core/follow.h FOLLOW_DIRS: notches of 15 degrees
MAX_RATE = 250                   # steps/s: the ramp's start rate, the most F runs at
MIN_RATE = 15                    # steps/s: the board's slowest feed
MAX_GATE = 16383                 # steps: F's gate argument
MAX_STEPS = 65535                # steps: F's lost and distance arguments
# The status report's F field (core/follow.h FOLLOW_STATE_*).
FOLLOW_STATES = ("none", "running", "home", "lost", "distance", "stopped", "reversed")
RUNNING = 1
# The stops after which a follow did what was asked.
FINISHED = ("home", "distance")


class FollowError(ValueError):
    """A follow goal the board would refuse; the message names every reason."""


def mm_to_steps(mm: float, steps_per_mm: float, what: str, limit: int, problems: List[str]) -> int:
    """mm as whole steps; a problem (what, the value, the limit) added to problems if it is not
    a distance of 0 or more within limit steps."""
    if not (isinstance(mm, (int, float)) and math.isfinite(mm) and mm >= 0):
        problems.append(f"{what} must be a distance in mm of 0 or more, not {mm}")
        return 0
    n = round(mm * steps_per_mm)
    if n > limit:
        problems.append(f"{what} {mm:g} mm is {n} steps, more than the board's {limit} "
                        f"({limit / steps_per_mm:g} mm at {steps_per_mm:g} steps/mm)")
    return n


@dataclass(frozen=True)
class FollowGoal:
    heading_deg: float = 0.0     # the way to set out along the line, counter-clockwise from +X
    feed_mm_s: float = 0.0       # 0: the most the board follows at (MAX_RATE)
    lost_mm: float = 5.0         # no sensor on black for this far: the line is lost
    # Stop after this many mm of steps (along a slant the pen gets less far along the line, down to
    # 1/sqrt(2) of it); 0: once round to the start, or lost.
    distance_mm: float = 0.0
    gate_mm: float = 3.5         # the start gate's half width: half the line's width suits


def heading_notch(heading_deg: float) -> int:
    """The nearest of the board's 24 headings."""
    return round(heading_deg / (360.0 / HEADINGS)) % HEADINGS


def follow_command(goal: FollowGoal, steps_per_mm: float) -> str:
    """The board's `F` for this goal; FollowError with every reason if the board would refuse it."""
    problems: List[str] = []
    if not (math.isfinite(steps_per_mm) and steps_per_mm > 0):
        raise FollowError(f"steps per mm must be a positive number, not {steps_per_mm}")
    if not (isinstance(goal.heading_deg, (int, float)) and math.isfinite(goal.heading_deg)):
        problems.append(f"heading must be a number of degrees, not {goal.heading_deg}")
    lost = mm_to_steps(goal.lost_mm, steps_per_mm, "lost distance", MAX_STEPS, problems)
    if lost == 0 and not problems:
        problems.append(f"lost distance {goal.lost_mm:g} mm is less than a step")
    distance = mm_to_steps(goal.distance_mm, steps_per_mm, "distance", MAX_STEPS, problems)
    gate = mm_to_steps(goal.gate_mm, steps_per_mm, "gate", MAX_GATE, problems)
    rate = 0
    if not (isinstance(goal.feed_mm_s, (int, float)) and math.isfinite(goal.feed_mm_s) and goal.feed_mm_s >= 0):
        problems.append(f"feed must be a speed in mm/s of 0 or more, not {goal.feed_mm_s}")
    elif goal.feed_mm_s:
        rate = round(goal.feed_mm_s * steps_per_mm)
        if not MIN_RATE <= rate <= MAX_RATE:
            problems.append(f"feed {goal.feed_mm_s:g} mm/s is {rate} steps/s: the board follows at "
                            f"{MIN_RATE} to {MAX_RATE} steps/s ({MIN_RATE / steps_per_mm:g} to "
                            f"{MAX_RATE / steps_per_mm:g} mm/s at {steps_per_mm:g} steps/mm)")
    if problems:
        raise FollowError("; ".join(problems))
    heading = heading_notch(goal.heading_deg)
    return f"F {heading} {lost} {distance} {gate}" + (f" {rate}" if rate else "")


def goal_or_defaults(heading_deg: float, feed_mm_s: float, lost_mm: float, distance_mm: float,
                     gate_mm: float) -> FollowGoal:
    """A goal from a message whose unset (0) lost distance and gate mean the defaults."""
    default = FollowGoal()
    return FollowGoal(heading_deg, feed_mm_s, lost_mm or default.lost_mm, distance_mm,
                      gate_mm or default.gate_mm)


@dataclass
class FollowTrack:
    """The pen's path while the board follows, from the positions reported meanwhile (the bridge's
    feedback, a few a second): before the follow runs the last position is its start, after it the
    path ends at the end the job reports."""
    length_mm: float = 0.0
    steps: int = 0
    began: bool = False
    last: Optional[Tuple[float, float]] = None

    def add(self, state: int, steps: int, xy: Tuple[float, float]) -> None:
        if state == RUNNING:
            self.began = True
            self.steps = steps
            if self.last is not None:
                self.length_mm += math.dist(self.last, xy)
        elif self.began:          # stopped: only the end is still to come
            return
        self.last = xy

    def end(self, steps: int, xy: Tuple[float, float]) -> None:
        """The job's end: the follow took `steps` and the pen is at xy."""
        if steps and self.last is not None:
            self.length_mm += math.dist(self.last, xy)
        self.steps, self.last, self.began = steps, xy, True


def follow_state_name(code: int) -> str:
    return FOLLOW_STATES[code] if 0 <= code < len(FOLLOW_STATES) else f"unknown ({code})"
