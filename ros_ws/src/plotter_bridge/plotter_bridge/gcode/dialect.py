"""G-code dialects: what a program may say beyond LinuxCNC's subset, and what it means.

The common generators write the pen three ways: LinuxCNC-style M3/M5 or Z,
grbl's spindle or laser power (``M3 S1000``, ``S0``), and the servo of the
Marlin/MakerBot plotter lineage (``M300 S30``, Makelangelo's ``M280 P0 S90``,
with ``G4 P150`` in milliseconds).  A dialect says which of these a program
uses, and it takes what that dialect's firmware takes:

In every dialect the pen is down while the spindle runs (M3 or M4) at a
speed or power above 0, or at one not yet set; M5, ``M3 S0`` and an ``S0``
while it runs lift it (LinuxCNC's spindle at 0 turns no more than grbl's
laser at power 0 burns).

- ``linuxcnc`` (the default): G4 P in seconds; the pen follows M3/M4/M5, S
  and Z; G43 (with H) is a note; G81/G82 drilling cycles (G90, G98/G99)
  draw each hole as a dot; K on an XY arc is refused, as LinuxCNC refuses
  it.
- ``grbl``: S is the laser's power.  G4 P in seconds.  grbl's queries (``$$``,
  ``$I``, ``$G``, ``$#``, ``$N``, ``$X``, ``$C``, ``?``) and K on an XY arc
  are notes; ``$H``, jogging and settings (``$100=80``) are refused with the
  reason.
- ``marlin``: ``M300 S<angle>`` and ``M280 P0 S<angle>`` move the pen servo:
  the down angle lowers the pen, the up angle lifts it, another servo angle
  is refused; ``M300`` without S, with P or above 180 (a beep, or Unicorn's
  servo off) is a note.  G4 P in milliseconds (G4 S in seconds).
  M0/M1/M117 may carry a message to the end of the line.  A G1-G3 before
  any F runs at Marlin's default 1500 mm/min.  S is the laser's power only
  once M3/M4 has switched one on.  M17/M18/M84 (stepper power), M200, M400,
  E (extruder), K on an XY arc and S words with nothing to use them are
  notes.

In every dialect: G40 (cutter compensation off), G49 (tool length offset
off), G54 (the only coordinate system), G61/G64 (path control), G80 (canned
cycles off), G91.1 (arc centres incremental, the only way), T (tool
select: the pen the next M6 asks for) and M7/M8/M9 (coolant) are notes.
M6 (tool change) lifts the pen; once something is drawn it is a pen change
(the job waits, with the pen parked, for the operator to put in the next
pen and resume), before that a note.  M1 (optional
stop) is M0.  G28/G30 go home: with the pen up, to the given point and then
to the origin (X0 Y0 of the machine: where the board was powered on or
set_origin or the homing cycle put it).  The homing cycle (seeking the
board's limit switches) runs between jobs, with ``plotter home``, not from
a program: grbl's ``$H`` in a file is refused, naming it.  Z moves the pen (unless Z is a third axis): Z above
``pen_up_z`` is up, at or below it down; once a program drives the pen with
a servo (M300/M280), Z no longer moves it.  M3 does not stop Z from moving
the pen: CAM programs start the spindle once and draw with Z.  M codes of 100 and above
(a machine maker's own) are refused, naming them as such.  What a dialect
accepts without acting on it becomes a Note.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import FrozenSet, Mapping, Optional

from .types import GCodeError

LINUXCNC, GRBL, MARLIN = "linuxcnc", "grbl", "marlin"
DEFAULT_PEN_UP_Z = 0.0
DEFAULT_MARLIN_PEN_DOWN = 30.0      # degrees, as the MakerBot Unicorn extension writes them
DEFAULT_MARLIN_PEN_UP = 50.0
SERVO_ANGLE_TOLERANCE = 0.5         # degrees: "M300 S30.00" and "S30" are the same angle

_NO_HOME = ("the homing cycle runs between jobs, not from a program: `plotter home` before it (serial_bridge "
            "homing:=true on a machine with its limit switches wired); G28 travels to the origin with the pen up")
_PATH_NOTE = "path control mode: no effect, the planner blends corners by junction_deviation"
MAX_SERVO_ANGLE = 180.0             # degrees: an M300 S above it is not a servo position (a beep)
MARLIN_DEFAULT_FEED = 1500.0        # mm/min: Marlin's feed rate before the first F


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
    servo_pen: bool = False                        # marlin: M300/M280 S<angle> is the pen
    noted_letters: Mapping[str, str] = field(default_factory=dict)   # words with no effect: the note
    message_m: FrozenSet[float] = frozenset()      # M codes whose line may end in a message
    message_hint: str = ""                         # why "M0 Pen In" may be in the file
    arc_k: str = ""                                # a K word on an XY arc: its note ("": refused, as LinuxCNC)
    default_feed: float = 0.0                      # mm/min of G1-G3 before any F (0: none, refused)
    drill_cycles: bool = False                     # G81/G82 and G98/G99: a dot at each hole


_COMMON_NOTED_G = {
    610: "G61 " + _PATH_NOTE, 640: "G64 " + _PATH_NOTE,
    400: "G40 cutter radius compensation off: no effect, a pen has no radius to compensate",
    490: "G49 tool length offset off: no effect, a pen has no length offset",
    540: "G54 work coordinate system 1: the only one, no offset",
    800: "G80 canned cycle off: no effect, the plotter has no canned cycles (the motion mode is cleared)",
    911: "G91.1 arc centres incremental: no effect, I/J are always incremental here",
}
_COMMON_REFUSED_G = {
    901: "G90.1 (absolute arc centres) is refused: I/J are always incremental here (G91.1)",
    281: f"G28.1 (store the home position) is refused: {_NO_HOME}",
    301: f"G30.1 (store the second home position) is refused: {_NO_HOME}",
    530: "G53 (machine coordinates) is refused: the plotter's coordinates are the power-on origin's, "
         "without offsets",
    **{code: f"G{code // 10} (work coordinate system {code // 10 - 53}) is refused: G54 is the only one"
       for code in (550, 560, 570, 580, 590)},
}
_COOLANT = {7: "M7 mist coolant: no effect", 8: "M8 flood coolant: no effect", 9: "M9 coolant off: no effect"}
_COMMON_NOTED_LETTERS = {"T": "tool select: the pen the next M6 (a pen change) asks for"}
_LINUXCNC_NOTED_G = {**_COMMON_NOTED_G, 430: "G43 tool length offset: no effect, a pen has no length offset",
                     980: "G98 canned cycles retract to the Z they started at",
                     990: "G99 canned cycles retract to R"}
_MARLIN_MESSAGE_HINT = " (Marlin writes a message after M0/M1/M117: --dialect marlin)"

DIALECTS: Mapping[str, Dialect] = {
    LINUXCNC: Dialect(
        LINUXCNC, letters=frozenset("SH"), noted_g=_LINUXCNC_NOTED_G, refused_g=_COMMON_REFUSED_G,
        drill_cycles=True, noted_m=_COOLANT,
        noted_letters=_COMMON_NOTED_LETTERS,
        message_hint=_MARLIN_MESSAGE_HINT),
    GRBL: Dialect(
        GRBL, m_codes=frozenset((4,)), noted_g=_COMMON_NOTED_G,
        noted_m=_COOLANT,
        refused_g=_COMMON_REFUSED_G, noted_letters=_COMMON_NOTED_LETTERS,
        message_hint=_MARLIN_MESSAGE_HINT, letters=frozenset("SK"),
        arc_k="K on an arc in the XY plane: no effect, grbl ignores it"),
    MARLIN: Dialect(
        MARLIN, letters=frozenset("SEK"), default_feed=MARLIN_DEFAULT_FEED,
        arc_k="K on an arc in the XY plane: no effect, Marlin ignores it", m_codes=frozenset((280, 300)),
        noted_g=_COMMON_NOTED_G,
        noted_m={**_COOLANT, 17: "M17 stepper motors on: no effect", 18: "M18 stepper motors off: no effect",
                 84: "M84 stepper motors off: no effect", 117: "M117 display message: no effect",
                 118: "M118 serial message: no effect", 200: "M200 filament diameter: no effect",
                 400: "M400 wait for moves to finish: no effect, "
                 "the board finishes each move in order"},
        refused_g=_COMMON_REFUSED_G, dwell_p_seconds=0.001, servo_pen=True,
        noted_letters={**_COMMON_NOTED_LETTERS,
                       "E": "an extruder's, no effect on a plotter",
                       "S": "without a servo (M300/M280), a spindle or laser (M3/M4) or G4 to use it: "
                            "no effect"},
        message_m=frozenset((0.0, 1.0, 117.0, 118.0))),
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
        """"down" or "up" for a servo angle (M300/M280 S), None for neither."""
        if abs(angle - self.marlin_pen_down) <= SERVO_ANGLE_TOLERANCE:
            return "down"
        if abs(angle - self.marlin_pen_up) <= SERVO_ANGLE_TOLERANCE:
            return "up"
        return None


def dialect_hint(letter: str, dialect: str) -> str:
    """Why a word letter the dialect does not take may be in the file, or ""."""
    if letter == "E" and dialect != MARLIN:
        return " (an extruder word of a 3D printer's firmware: --dialect marlin takes it as a note)"
    if letter == "K" and dialect == LINUXCNC:
        return " (K on an arc in the XY plane, as LinuxCNC refuses it; grbl and Marlin ignore it: --dialect grbl)"
    return ""


def m_code_reason(value: float) -> str:
    """Why an M code no dialect takes is refused."""
    if value >= 100:
        return (f"unsupported M code M{value:g}: a machine's own command (a vendor's, or LinuxCNC's user "
                f"M100-M199), with no meaning on a plotter")
    return f"unsupported M code M{value:g}"


_GRBL_QUERIES = {"$$": "settings", "$#": "offsets", "$G": "parser state", "$I": "build info",
                 "$N": "startup blocks", "$X": "alarm unlock", "$C": "check mode", "?": "status"}


def system_line(text: str, line: int) -> str:
    """The note for a whole-line grbl command a sender passes to the board
    (a query, ``$X``); GCodeError naming the command for one that would
    change the machine (``$H``, settings, jogging)."""
    command = text.split()[0]
    upper = command.upper()
    if upper in _GRBL_QUERIES:
        return f"grbl {command} ({_GRBL_QUERIES[upper]}): no effect in a program"
    if upper == "$H" or upper.startswith("$H"):
        raise GCodeError(line, f"grbl's homing cycle {command} is refused: {_NO_HOME}")
    if upper.startswith("$J="):
        raise GCodeError(line, f"grbl jog {command!r} is refused: jogging is not part of a program "
                               f"(jog from the page or the panel's keys)")
    raise GCodeError(line, f"grbl system command {command!r} is refused: settings and system commands "
                           f"are not part of a program")
