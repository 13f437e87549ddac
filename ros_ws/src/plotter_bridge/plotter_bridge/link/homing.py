"""The homing cycle, run by the host from the board's limit alarm.

The board has limit switches at the -X and -Y ends (P1.5, P1.7): its step
interrupt stops the pulses when the switch at the end the machine heads for
closes, and raises alarm 2; a reset clears the alarm and keeps the position,
and moving away from a closed switch is allowed (firmware/README.md,
*Alarms*).  The firmware has no room for a cycle of its own, so the host
runs grbl's, axis by axis (X, then Y), with the pen up:

1. seek: towards the switch at the seek rate, at most `travel` steps, until
   the limit alarm stops it; then a reset;
2. pull off by `pull_off` steps, away from the switch;
3. locate: towards it again at the slow locate rate, until it closes; a
   reset; and pull off once more;

and once both axes are done, that place becomes the origin (`H`).  A seek
that ends without the switch (none within `travel`), any other alarm or
error, or a lost board ends the cycle with the reason; the position is then
unknown to the user, and the cycle can simply be run again.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Tuple

from .board_session import BoardSession, JobResult
from .protocol import MAX_DELTA, MAX_RATE, MIN_RATE

ALARM_LIMIT = 2          # the status report's A code of a limit switch (firmware/PROTOCOL.md)


@dataclass(frozen=True)
class HomingConfig:
    """In the board's units: steps and steps per second."""
    seek_rate: int = 1600          # 20 mm/s at 80 steps/mm
    locate_rate: int = 160         # 2 mm/s
    pull_off: int = 160            # 2 mm
    travel: int = 20000            # 250 mm: longer than the table, shorter than one line command
    move_timeout_s: float = 120.0

    def __post_init__(self) -> None:
        for name, low, high in (("seek_rate", MIN_RATE, MAX_RATE), ("locate_rate", MIN_RATE, MAX_RATE),
                                ("pull_off", 1, MAX_DELTA), ("travel", 1, MAX_DELTA)):
            value = getattr(self, name)
            if not low <= value <= high:
                raise ValueError(f"homing {name} = {value}: must be {low}..{high}")
        if self.pull_off >= self.travel:
            raise ValueError(f"homing pull_off ({self.pull_off} steps) must be shorter than its travel "
                             f"({self.travel} steps)")


class HomingError(Exception):
    """The cycle stopped: why, in words."""


def _move(axis: str, steps: int, rate: int) -> str:
    dx, dy = (steps, 0) if axis == "X" else (0, steps)
    return f"L {dx} {dy} {rate} 0"


class Homing:
    """One run of the cycle over a connected, idle session."""

    def __init__(self, session: BoardSession, config: HomingConfig = HomingConfig(), log=print) -> None:
        self.session, self.config, self.log = session, config, log
        self.found: List[Tuple[str, int]] = []     # (axis, motor position where its switch closed)

    def _job(self, commands: List[str]) -> JobResult:
        job = self.session.start_job(commands, [0] * len(commands), need_origin=False)
        result = self.session.wait_job(job, self.config.move_timeout_s)
        if result is None:
            self.session.cancel(job)
            raise HomingError("the board did not finish a homing move in time")
        return result

    def _to_switch(self, axis: str, steps: int, rate: int, what: str) -> int:
        """Towards the -axis switch until it closes; the reset after it. The position where it stopped."""
        result = self._job(["P 0", _move(axis, -steps, rate)])
        status = self.session.link.status
        if result.success:
            raise HomingError(f"{what} on {axis}: no limit switch within {steps} steps; is it wired "
                              f"(firmware/README.md: {'P1.5' if axis == 'X' else 'P1.7'})?")
        if status is None or status.state != "Alarm" or status.alarm != ALARM_LIMIT:
            raise HomingError(f"{what} on {axis}: {result.message}")
        where = status.x if axis == "X" else status.y
        ok, message = self.session.realtime("reset")
        if not ok:
            raise HomingError(f"{what} on {axis}: the reset after the switch: {message}")
        return where

    def _pull_off(self, axis: str) -> None:
        result = self._job([_move(axis, self.config.pull_off, self.config.seek_rate)])
        if not result.success:
            raise HomingError(f"pull-off on {axis}: {result.message}"
                              + ("; the switch stays closed: is the pull-off long enough?"
                                 if "alarm" in result.message else ""))

    def run(self) -> str:
        """The cycle; its summary. HomingError with the reason when it stops."""
        for axis in ("X", "Y"):
            self._to_switch(axis, self.config.travel, self.config.seek_rate, "seek")
            self._pull_off(axis)
            where = self._to_switch(axis, 2 * self.config.pull_off, self.config.locate_rate, "locate")
            self._pull_off(axis)
            self.found.append((axis, where))
            self.log(f"homing: the {axis} switch closed at {where} steps")
        ok, message = self.session.set_origin()
        if not ok:
            raise HomingError(f"setting the origin: {message}")
        found = ", ".join(f"{a} at {w}" for a, w in self.found)
        return f"homed: the switches closed at {found} steps; the origin is {self.config.pull_off} steps off each"


def home(session: BoardSession, config: HomingConfig = HomingConfig(), log=print) -> Tuple[bool, str]:
    """Run the cycle: (success, message)."""
    try:
        return True, Homing(session, config, log).run()
    except HomingError as exc:
        return False, f"homing stopped: {exc}"


def homing_config(seek_mm_min: float, locate_mm_min: float, pull_off_mm: float, travel_mm: float,
                  steps_per_mm: float) -> HomingConfig:
    """A HomingConfig from the bridge's parameters in mm; ValueError naming a bad one."""
    return HomingConfig(seek_rate=round(seek_mm_min / 60.0 * steps_per_mm),
                        locate_rate=round(locate_mm_min / 60.0 * steps_per_mm),
                        pull_off=round(pull_off_mm * steps_per_mm), travel=round(travel_mm * steps_per_mm))
