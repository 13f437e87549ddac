"""G-code dialects: what a program may say beyond LinuxCNC's subset, and what it means.

The common generators write the pen three ways: LinuxCNC-style M3/M5 or Z,
grbl's spindle or laser power (``M3 S1000``, ``S0``), and the servo of the
Marlin/MakerBot plotter lineage (``M300 S30``, with ``G4 P150`` in
milliseconds).  A dialect says which of these a program uses:

- ``linuxcnc`` (the default): the strict subset of gcode/parser.py; G4 P in
  seconds; no S word.
- ``grbl``: S is the power word.  The pen is down while the spindle runs (M3
  or M4) at a power above 0, or at a power not yet set; M5, ``M3 S0`` and an
  ``S0`` while it runs lift it.  G4 P in seconds.  G54 (the only coordinate
  system), M7/M8/M9 (coolant) are accepted without effect; ``$H`` homing,
  other ``$`` commands, G28/G30 and G55..G59 are refused with the reason.
- ``marlin``: ``M300 S<angle>`` moves the pen servo: the down angle lowers the
  pen, the up angle lifts it, another angle is refused.  G4 P in
  milliseconds (G4 S in seconds).  M17/M18/M84 (stepper power) are accepted
  without effect.

In every dialect G61/G64 (path control) are accepted without effect, and Z
moves the pen (unless Z is a third axis): Z above ``pen_up_z`` is up, at or
below it down.  What a dialect accepts without acting on it becomes a Note.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import FrozenSet, Mapping, Optional

LINUXCNC, GRBL, MARLIN = "linuxcnc", "grbl", "marlin"
DEFAULT_PEN_UP_Z = 0.0
DEFAULT_MARLIN_PEN_DOWN = 30.0      # degrees, as the MakerBot Unicorn extension writes them
DEFAULT_MARLIN_PEN_UP = 50.0
SERVO_ANGLE_TOLERANCE = 0.5         # degrees: "M300 S30.00" and "S30" are the same angle

_NO_HOME = ("the plotter has no homing cycle; its origin is where the board was powered on "
            "(or where set_origin put it)")
_PATH_NOTE = "path control mode: no effect, the planner blends corners by junction_deviation"


@dataclass(frozen=True)
class Dialect:
    """The words one dialect adds to the common subset (G codes in tenths: G61 -> 610)."""

    name: str
    letters: FrozenSet[str] = frozenset()          # word letters beyond the common ones
    m_codes: FrozenSet[int] = frozenset()          # M codes that act, beyond M0/M2/M3/M5/M30
    noted_g: Mapping[int, str] = field(default_factory=dict)   # accepted without effect: the note
    noted_m: Mapping[int, str] = field(default_factory=dict)
    refused_g: Mapping[int, str] = field(default_factory=dict)  # refused: the reason
    dwell_p_seconds: float = 1.0                   # G4 P is in these many seconds
    power_word: bool = False                       # grbl: S with M3/M4 is the pen
    servo_pen: bool = False                        # marlin: M300 S<angle> is the pen


_COMMON_NOTED_G = {610: "G61 " + _PATH_NOTE, 640: "G64 " + _PATH_NOTE}
_COMMON_REFUSED_G = {280: f"G28 (go home) is refused: {_NO_HOME}",
                     300: f"G30 (go to the second home) is refused: {_NO_HOME}"}

DIALECTS: Mapping[str, Dialect] = {
    LINUXCNC: Dialect(LINUXCNC, noted_g=_COMMON_NOTED_G, refused_g=_COMMON_REFUSED_G),
    GRBL: Dialect(
        GRBL, letters=frozenset("S"), m_codes=frozenset((4,)),
        noted_g={**_COMMON_NOTED_G, 540: "G54 work coordinate system 1: the only one, no offset"},
        noted_m={7: "M7 mist coolant: no effect", 8: "M8 flood coolant: no effect",
                 9: "M9 coolant off: no effect"},
        refused_g={**_COMMON_REFUSED_G, 530: "G53 (machine coordinates) is refused: the plotter's "
                                             "coordinates are the power-on origin's, without offsets",
                   **{code: f"G{code // 10} (work coordinate system {code // 10 - 53}) is refused: "
                      f"G54 is the only one" for code in (550, 560, 570, 580, 590)}},
        power_word=True),
    MARLIN: Dialect(
        MARLIN, letters=frozenset("S"), m_codes=frozenset((300,)), noted_g=_COMMON_NOTED_G,
        noted_m={17: "M17 stepper motors on: no effect", 18: "M18 stepper motors off: no effect",
                 84: "M84 stepper motors off: no effect"},
        refused_g=_COMMON_REFUSED_G, dwell_p_seconds=0.001, servo_pen=True),
}


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, not {value!r}")
    return value


@dataclass(frozen=True)
class GCodeOptions:
    """How a program is read: its dialect and the pen rules that have numbers."""

    dialect: str = LINUXCNC
    pen_up_z: float = DEFAULT_PEN_UP_Z               # Z above this: pen up; at or below: down
    marlin_pen_down: float = DEFAULT_MARLIN_PEN_DOWN  # marlin: M300 S<this> lowers the pen
    marlin_pen_up: float = DEFAULT_MARLIN_PEN_UP      # marlin: M300 S<this> lifts it

    def __post_init__(self) -> None:
        if self.dialect not in DIALECTS:
            raise ValueError(f"unknown G-code dialect {self.dialect!r} (one of {', '.join(DIALECTS)})")
        _finite("pen_up_z", self.pen_up_z)
        down = _finite("marlin_pen_down", self.marlin_pen_down)
        up = _finite("marlin_pen_up", self.marlin_pen_up)
        if abs(down - up) <= 2 * SERVO_ANGLE_TOLERANCE:
            raise ValueError(f"marlin_pen_down ({down:g}) and marlin_pen_up ({up:g}) must differ "
                             f"by more than {2 * SERVO_ANGLE_TOLERANCE:g} degrees")

    @property
    def rules(self) -> Dialect:
        return DIALECTS[self.dialect]

    def servo_pen(self, angle: float) -> Optional[str]:
        """"down" or "up" for an M300 angle, None for neither."""
        if abs(angle - self.marlin_pen_down) <= SERVO_ANGLE_TOLERANCE:
            return "down"
        if abs(angle - self.marlin_pen_up) <= SERVO_ANGLE_TOLERANCE:
            return "up"
        return None


def dialect_hint(letter: str, dialect: str) -> str:
    """Why a word letter the dialect does not take may be in the file, or ""."""
    if letter == "S" and dialect == LINUXCNC:
        return (" (spindle speed or laser power: with --dialect grbl M3 S>0 lowers the pen, "
                "S0 lifts it; with --dialect marlin M300 S<angle> moves the pen servo)")
    return ""


def system_command_reason(text: str) -> str:
    """Why a line of grbl's ``$`` commands is refused."""
    command = text.strip().split()[0]
    if command.upper() == "$H":
        return f"grbl's homing cycle $H is refused: {_NO_HOME}"
    return (f"grbl system command {command!r} is refused: settings and system commands "
            f"are not part of a program")
