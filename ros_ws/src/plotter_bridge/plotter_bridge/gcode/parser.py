"""G-code front end of the plotter: parse a program into moves in machine mm.

The subset (case-insensitive; one block per physical line):

- Motion (modal): G0 rapid travel with the pen up at the rapid rate, G1 line,
  G2/G3 clockwise/counter-clockwise arc with I/J (centre offset from the start,
  always incremental) or R (positive: arc of at most 180 degrees, negative: the
  longer arc). G2/G3 ending where they start with I/J make a full circle.
- G4 P<seconds> dwell; G17 (XY plane; G18/G19 are rejected); G20/G21 inch/mm;
  G90/G91 absolute/incremental; G92 X/Y sets the current position (an offset;
  Z is accepted and has no effect on the pen); G94 units per minute; G28/G30
  go home (pen up, through the point its axis words give, to X0 Y0 of the
  machine; "G28 X" homes X alone); the modal words that do nothing on a
  plotter (G40, G49, G54, G61, G64, G80, G91.1, T) are notes. G4's P unit is
  the dialect's.
- F feed (units per minute, modal; in the units in force after the line's
  G20/G21, and kept as a speed when the units change later); M3 pen down, M5
  pen up, M0/M1 pause, M6 tool change (pen up; once something is drawn a
  pen change, ToolChange: the job waits for the next pen, which the T word
  and the line's comment name; before, a note), M2/M30 end of program (the
  rest of the file is not read).
- Z is the pen: after a Z word the pen is down when Z <= pen_up_z (0 unless
  set) and up when Z > pen_up_z (Z is absolute in G90 and added to the last
  Z, 0 at power-on, in G91). A line
  with Z and X/Y changes the pen first and then moves; with Z alone it only
  changes the pen. G0 always travels with the pen up; the pen state set by the
  program applies again to the following G1/G2/G3 moves.
- With ``z_axis`` (a machine with a third axis: pen height or engraving
  depth), Z is that axis instead, in mm from the power-on origin, starting
  where the board's Z is; G92 Z offsets it like X and Y. A change of Z is a
  ZMove of its own, at the line's feed (G1) or the rapid rate (G0), in the
  pen's order: before the XY part of the line, except that G0 goes down
  after its travel (retract, then travel; travel, then plunge). X and Y stay
  interpolated together; Z never moves with them, so an arc that changes Z
  (a helix) is refused. M3/M5 and G0's pen-up still drive the pen output.
- N words, comments in parentheses and after ';' (of any length and in any
  text, gcode/tokens.py), '%' lines, blank lines.
- Dialects (gcode/dialect.py, ``options``): grbl's S power word and
  M4, M7/M8/M9, its queries; Marlin's M300/M280 pen servo, G4 P in
  milliseconds, M17/M18/M84, messages. What a dialect accepts without acting
  on it is a Note.

Effects of one line happen in LinuxCNC's order: S, M3/M5 (M4, M300), G4, modes (G17,
G20/G21, G90/G91, ...), G92, motion, then M0/M2/M30. The whole program is
read before anything is returned, and a program with bad lines is refused
whole with a GCodeErrors listing every one of them (up to MAX_ERRORS), each
with its physical line. Rejected as well: other letters, G and M codes,
words without a number, numbers without a letter, a letter twice on a line
(G excepted), two G codes of one modal group, characters beyond printable
ASCII outside comments, more than 256 characters outside comments, a
program without moves, and arcs LinuxCNC refuses (see geometry.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

from . import geometry
from .dialect import MAX_SERVO_ANGLE, GCodeOptions, dialect_hint, m_code_reason
from .types import (PEN_DOWN, PEN_UP, Dwell, GCodeError, GCodeErrors, Item, Move, Note, Pause,
                    PenChange, ToolChange, ZMove)
from .limits import WorkArea, check_limits, limit_errors
from .steps import StepMove, to_steps
from .tokens import Word, decode_program, tokenize_line

__all__ = ["GCodeError", "GCodeErrors", "Move", "ZMove", "Dwell", "PenChange", "Pause", "ToolChange", "Note", "Item",
           "WorkArea", "StepMove", "GCodeOptions", "Program", "check_limits", "to_steps", "parse", "parse_program",
           "check_program", "decode_program", "load_program", "moves_of", "DEFAULT_RAPID_RATE"]

DEFAULT_RAPID_RATE = 3000.0  # mm/min
MM_PER_INCH = geometry.MM_PER_INCH
SAME_POINT_MM = 1e-9
MAX_ERRORS = 100             # refused lines listed; the count of the rest follows them

_AXES = ("X", "Y", "Z")

# G codes in tenths (G61 -> 610), with their modal group.
_MOTION, _NONMODAL, _PLANE, _DISTANCE, _FEED_MODE, _UNITS, _PATH = (
    "motion", "non-modal", "plane", "distance", "feed mode", "units", "path control")
_COORDINATE_SYSTEM = "coordinate system"
_G_GROUPS = {0: _MOTION, 10: _MOTION, 20: _MOTION, 30: _MOTION, 800: _MOTION, 40: _NONMODAL,
             280: _NONMODAL, 300: _NONMODAL, 920: _NONMODAL, 170: _PLANE, 180: _PLANE, 190: _PLANE,
             900: _DISTANCE, 910: _DISTANCE, 940: _FEED_MODE, 200: _UNITS, 210: _UNITS, 610: _PATH,
             640: _PATH, 400: "cutter compensation", 490: "tool length offset", 540: _COORDINATE_SYSTEM,
             911: "arc distance"}
# Accepted where the dialect takes them (Dialect.noted_g, drill_cycles), refused elsewhere with why.
_DIALECT_G_GROUPS = {430: "tool length offset", 810: _MOTION, 820: _MOTION, 980: "canned cycle return",
                     990: "canned cycle return"}
_DRILL = (810, 820)
_M_CODES = frozenset((0, 1, 2, 3, 4, 5, 6, 30))
_HOME = (280, 300)           # G28, G30: go home
_TOOL_CHANGE_NOTE = ("M6 tool change before anything is drawn: the pen in the holder is the first; "
                     "the pen is lifted and the job goes on")


@dataclass
class _State:
    """Interpreter state while parsing one program (positions in machine mm)."""

    x: float = 0.0
    y: float = 0.0
    offset_x: float = 0.0
    offset_y: float = 0.0
    z: float = 0.0
    offset_z: float = 0.0
    z_axis: bool = False         # Z is a third axis (ZMove), not the pen
    mm_per_unit: float = 1.0
    absolute: bool = True
    motion: Optional[int] = None
    feed: float = 0.0
    pen: str = PEN_UP
    options: GCodeOptions = GCodeOptions()
    spindle_on: bool = False     # grbl: M3/M4 in force (the pen follows the power)
    power: Optional[float] = None  # grbl: the last S word, None before the first
    pen_by_command: int = 0      # line from which a servo drives the pen (Z no longer does)
    z_note: bool = False         # the note that Z no longer moves the pen is given
    cycle_z: Optional[float] = None  # G81/G82: the hole's bottom and its R plane (program units x mm/unit)
    cycle_r: Optional[float] = None
    cycle_return: int = 980      # G98: back to the Z the cycle started at; G99: to R
    tool: int = 0                # the last T word: the pen an M6 puts in
    comment: str = ""            # the comment of the line being read
    items: List[Item] = field(default_factory=list)   # the line's, until they are handed on
    notes: List[Note] = field(default_factory=list)
    drawn: bool = False          # a drawn move before the line being read


@dataclass(frozen=True)
class Program:
    """A parsed program: what it does, and what it says that has no effect here."""

    items: List[Item]
    notes: List[Note]


def _g_name(code: int) -> str:
    return f"G{code // 10}" + (f".{code % 10}" if code % 10 else "")


_FEATURES = {range(380, 386): "probing: a plotter has no probe",
             range(410, 421): "cutter radius compensation: a pen has no radius",
             range(100, 101): "setting offsets and tool tables",
             range(50, 60): "splines: send the curve as arcs or lines",
             range(330, 332): "threading", range(760, 761): "threading",
             range(730, 900): "canned cycles other than drilling (G81, G82)"}


def _unsupported_feature(code: int, exact: bool) -> str:
    """': <the feature>' for a G code that names one, else ''."""
    for codes, feature in _FEATURES.items():
        if exact and code in codes:
            return f": {feature}, not supported"
    return ""


def _g_group(value: float, line: int, st: _State) -> Tuple[int, str]:
    """A G word's code in tenths and its modal group; GCodeError naming the feature of one
    the dialect does not take."""
    rules = st.options.rules
    code = round(value * 10)
    exact = abs(value * 10 - code) <= 1e-6
    if exact and code in rules.refused_g:
        raise GCodeError(line, rules.refused_g[code])
    group = _G_GROUPS.get(code)
    if group is None and exact and code in _DIALECT_G_GROUPS:
        if code in rules.noted_g or (code in _DRILL and rules.drill_cycles):
            group = _DIALECT_G_GROUPS[code]
        else:
            raise GCodeError(line, f"{_g_name(code)} is refused in the {st.options.dialect} dialect, as its "
                                   f"firmware refuses it" + (" (with --dialect linuxcnc each hole is a dot)"
                                                             if code in _DRILL else ""))
    if not exact or group is None:
        raise GCodeError(line, f"unsupported G code G{value:g}" + _unsupported_feature(code, exact))
    if code in (180, 190):
        raise GCodeError(line, f"{_g_name(code)}: only the XY plane (G17) is supported")
    return code, group


def _split_words(words: List[Word], line: int, st: _State):
    """(G codes by modal group, M code or None, other words by letter, N);
    the words the dialect accepts without effect become notes."""
    rules = st.options.rules
    # The G codes first: "G41 D1" is refused for G41 (what it asks), not for its D word.
    g_codes = [_g_group(w.value, line, st) for w in words if w.letter == "G"]
    unknown = next((w for w in words if not w.known), None)
    if unknown is not None:
        raise GCodeError(line, f"unsupported word letter '{unknown.letter}'"
                               + dialect_hint(unknown.letter, st.options.dialect))
    groups: Dict[str, int] = {}
    others: Dict[str, float] = {}
    n: Optional[int] = None
    for index, w in enumerate(words):
        if w.letter == "N":
            if index != 0:
                raise GCodeError(line, "N word (line number) must come first on the line")
            if w.value < 0 or w.value != int(w.value):
                raise GCodeError(line, "N word must be a whole number")
            n = int(w.value)
        elif w.letter == "G":
            code, group = g_codes.pop(0)
            if code in rules.noted_g:
                st.notes.append(Note(line, rules.noted_g[code]))
            if group in groups:
                what = ("two motion words" if group == _MOTION
                        else f"two G codes of the {group} group")
                raise GCodeError(line, f"{what} on one line: "
                                       f"{_g_name(groups[group])} and {_g_name(code)}")
            groups[group] = code
        else:
            if w.letter in others:
                raise GCodeError(line, f"two {w.letter} words on one line")
            others[w.letter] = w.value
    bare = [a for a in _AXES if a in others and math.isnan(others[a])]
    if bare and groups.get(_NONMODAL) not in _HOME:
        raise GCodeError(line, f"'{bare[0]}' word without a number")
    m_code: Optional[int] = None
    if "M" in others:
        value = others.pop("M")
        code = int(value) if value == int(value) else None
        if code in rules.noted_m:
            st.notes.append(Note(line, rules.noted_m[code]))
        elif code in _M_CODES or code in rules.m_codes:
            m_code = code
        else:
            raise GCodeError(line, m_code_reason(value))
    for letter, why in rules.noted_letters.items():
        if letter == "S" or letter not in others:
            continue                       # S is the pen's or the dwell's first: _pen_words
        if letter == "T" and m_code == 280:
            continue                       # Makelangelo's "M280 P0 S90 T50": the servo's move time
        value = others.pop(letter)
        if letter == "T":
            st.tool = int(value) if value == int(value) and 0 <= value <= 99 else st.tool
        if not (letter == "T" and m_code == 6):   # "T1 M6": the tool change's note says it
            # Values only where they say something: an E on every line is one note, repeated.
            st.notes.append(Note(line, f"T{value:g} {why}" if letter == "T" else f"{letter} word: {why}"))
    return groups, m_code, others, n


def _same_point(x1: float, y1: float, x2: float, y2: float) -> bool:
    return abs(x1 - x2) <= SAME_POINT_MM and abs(y1 - y2) <= SAME_POINT_MM


def _set_pen(st: _State, pen: str, line: int) -> None:
    if pen != st.pen:
        st.pen = pen
        st.items.append(PenChange(line, pen))


def _arc_centre(st: _State, words: Dict[str, float], tx: float, ty: float,
                cw: bool, line: int):
    """Centre (mm) and end point of an arc, validated as LinuxCNC does."""
    u = st.mm_per_unit
    tol = geometry.arc_tolerance(inches=u != 1.0)
    has_ij = "I" in words or "J" in words
    if "R" in words and has_ij:
        raise GCodeError(line, "arc with both R and I/J words (mixed radius and centre format)")
    if not has_ij and "R" not in words:
        raise GCodeError(line, f"{'G2' if cw else 'G3'} arc needs I/J (centre) or R (radius)")
    same = _same_point(tx, ty, st.x, st.y)
    try:
        if has_ij:
            if same:
                tx, ty = st.x, st.y  # full circle
            centre = (st.x + words.get("I", 0.0) * u, st.y + words.get("J", 0.0) * u)
            geometry.check_centre_arc((st.x, st.y), (tx, ty), centre, tol)
        else:
            if same:
                raise geometry.ArcError("R-format arc ends where it starts "
                                        "(use I/J for a full circle)")
            centre = geometry.centre_from_radius((st.x, st.y), (tx, ty), words["R"] * u,
                                                 cw, tol.zero_radius)
    except geometry.ArcError as exc:
        raise GCodeError(line, str(exc)) from None
    return centre, tx, ty


def _motion(st: _State, words: Dict[str, float], line: int, n: Optional[int],
            rapid_rate: float) -> None:
    """Execute the current motion mode with this line's axis words."""
    u = st.mm_per_unit
    code = st.motion
    tx, ty = st.x, st.y
    if "X" in words:
        tx = words["X"] * u + st.offset_x if st.absolute else st.x + words["X"] * u
    if "Y" in words:
        ty = words["Y"] * u + st.offset_y if st.absolute else st.y + words["Y"] * u
    new_pen = None
    z_move: Optional[ZMove] = None
    if "Z" in words and st.z_axis:
        tz = words["Z"] * u + st.offset_z if st.absolute else st.z + words["Z"] * u
        if abs(tz - st.z) > SAME_POINT_MM:
            if code in (20, 30):
                raise GCodeError(line, f"helical arc: {_g_name(code)} with a Z move (Z{st.z:g} to "
                                       f"Z{tz:g} mm) is not supported; Z moves alone, so put the "
                                       f"Z move on a line of its own before the arc")
            z_move = ZMove(line, st.z, tz, rapid_rate if code == 0 else st.feed, rapid=code == 0)
            st.z = tz
    elif "Z" in words:
        st.z = words["Z"] * u if st.absolute else st.z + words["Z"] * u
        if not st.pen_by_command:
            new_pen = PEN_DOWN if st.z <= st.options.pen_up_z else PEN_UP
        elif not st.z_note:
            # Unicorn ends with "G1 Z0 (go up to finished level)": its pen is the servo's, not Z's.
            st.z_note = True
            st.notes.append(Note(line, f"Z does not move the pen: the program drives it with the servo "
                                       f"from line {st.pen_by_command} on"))
    # As the pen: a rapid goes down at its end, anything else changes Z first.
    z_after = z_move is not None and code == 0 and z_move.z < z_move.sz
    if z_move is not None and not z_after:
        st.items.append(z_move)
    lowered_after = code == 0 and new_pen == PEN_DOWN
    if new_pen is not None and not lowered_after:
        _set_pen(st, new_pen, line)
    if code in (20, 30):
        cw = code == 20
        (cx, cy), tx, ty = _arc_centre(st, words, tx, ty, cw, line)
        st.items.append(Move(line, "arc", st.x, st.y, tx, ty, st.feed, st.pen,
                             cx=cx, cy=cy, cw=cw, n=n))
    elif not _same_point(tx, ty, st.x, st.y):
        rapid = code == 0
        st.items.append(Move(line, "line", st.x, st.y, tx, ty,
                             rapid_rate if rapid else st.feed,
                             PEN_UP if rapid else st.pen, rapid=rapid, n=n))
    st.x, st.y = tx, ty
    if lowered_after:
        _set_pen(st, PEN_DOWN, line)
    if z_after:
        st.items.append(z_move)


def _servo(st: _State, m_code: int, o: Dict[str, float], line: int) -> None:
    """Marlin's pen servo: M300 S<angle> (the Unicorn plugin's) or M280 P<servo> S<angle> (Makelangelo's)."""
    options = st.options
    name = f"M{m_code}"
    if m_code == 300 and ("P" in o or "S" not in o or o["S"] > MAX_SERVO_ANGLE):
        # Marlin's own M300 is a beep (S frequency, P duration); Unicorn ends with M300 S255, its servo off.
        words = "".join(f" {k}{o[k]:g}" for k in ("S", "P") if k in o)
        st.notes.append(Note(line, f"M300{words}: not a servo angle (0..{MAX_SERVO_ANGLE:g}), "
                                   f"a beep or servo off: no effect"))
        return
    if m_code == 280 and o.get("P", 0.0) != 0.0:
        st.notes.append(Note(line, f"M280 P{o['P']:g}: servo {o['P']:g} is not the pen's (P0): no effect"))
        return
    if "S" not in o:
        raise GCodeError(line, f"{name} (pen servo) needs an S word: the servo angle")
    if not 0.0 <= o["S"] <= MAX_SERVO_ANGLE:
        raise GCodeError(line, f"{name} S{o['S']:g}: a servo angle is 0..{MAX_SERVO_ANGLE:g} degrees")
    pen = options.servo_pen(o["S"])
    if pen is None:
        raise GCodeError(line, f"{name} S{o['S']:g}: neither the pen-down angle "
                               f"{options.marlin_pen_down:g} nor the pen-up angle "
                               f"{options.marlin_pen_up:g} (--marlin-pen DOWN UP; parameters "
                               f"marlin_pen_down, marlin_pen_up)")
    _pen_by_command(st, line)
    _set_pen(st, pen, line)


def _pen_by_command(st: _State, line: int) -> None:
    if not st.pen_by_command:
        st.pen_by_command = line


def _pen_words(st: _State, m_code: Optional[int], o: Dict[str, float], nonmodal: Optional[int],
               line: int) -> None:
    """The pen from this line's M code and S word.

    In every dialect the pen is down while the spindle runs (M3/M4) at a
    speed or power above 0, or at one never set: LinuxCNC's S0 stops the
    spindle as grbl's S0 switches its laser off.  Marlin's S is the servo's
    angle with M300/M280, the seconds of G4, and the laser's power only once
    M3/M4 has switched one on (gcodeplot's "G00 S1" before that is a note)."""
    rules = st.options.rules
    if m_code in (280, 300):
        _servo(st, m_code, o, line)
        o.pop("S", None)
        o.pop("P", None)
    elif "S" in o and rules.servo_pen and nonmodal != 40 and not (st.spindle_on or m_code in (3, 4)):
        o.pop("S")
        st.notes.append(Note(line, f"S word: {rules.noted_letters['S']}"))
    has_power = "S" in o and not (rules.servo_pen and nonmodal == 40)
    if has_power:
        if o["S"] < 0:
            raise GCodeError(line, f"negative S word (spindle speed or power) S{o['S']:g}")
        st.power = o.pop("S")
    if m_code in (3, 4, 5):
        st.spindle_on = m_code != 5
    if m_code in (3, 4, 5) or (has_power and st.spindle_on):
        on = st.spindle_on and (st.power is None or st.power > 0.0)
        _set_pen(st, PEN_DOWN if on else PEN_UP, line)
    if m_code == 6:
        _set_pen(st, PEN_UP, line)
        drawn = st.drawn or any(isinstance(i, Move) and i.pen == PEN_DOWN and not i.rapid for i in st.items)
        st.items.append(ToolChange(line, st.tool, st.comment, wait=drawn))
        if not drawn:
            st.notes.append(Note(line, _TOOL_CHANGE_NOTE))


def _dwell(st: _State, o: Dict[str, float], line: int) -> Dwell:
    rules = st.options.rules
    unit = "seconds" if rules.dwell_p_seconds == 1.0 else "milliseconds"
    if rules.servo_pen and "S" in o:
        if "P" in o:
            raise GCodeError(line, "G4 dwell with both P (milliseconds) and S (seconds)")
        seconds = o["S"]
    elif "P" not in o:
        raise GCodeError(line, f"G4 dwell needs a P word ({unit})")
    else:
        seconds = o["P"] * rules.dwell_p_seconds
    if seconds < 0:
        raise GCodeError(line, "G4 dwell with a negative time")
    return Dwell(line, seconds)


def _go_home(st: _State, o: Dict[str, float], line: int, n: Optional[int], rapid_rate: float,
             code: int) -> None:
    """G28/G30 as LinuxCNC runs them with its home at the origin: a rapid
    through the point the axis words give, then the named axes (all of them
    when none is named) to 0 of the machine; X and Y travel with the pen up."""
    u = st.mm_per_unit
    named = [a for a in _AXES if a in o] or list(_AXES)
    homed = " ".join(a + "0" for a in named if a != "Z" or st.z_axis)
    what = (f"with the pen up to {homed} of the machine (the origin)" if homed else "the pen up, its home")
    st.notes.append(Note(line, f"{_g_name(code)} go home: {what}; no limit switch is sought"))

    def target(axis: str, here: float, offset: float) -> float:
        value = o.get(axis, math.nan)
        if math.isnan(value):            # not given, or Marlin's bare "G28 X": no intermediate point
            return here
        return value * u + offset if st.absolute else here + value * u

    def travel(tx: float, ty: float) -> None:
        if not _same_point(tx, ty, st.x, st.y):
            st.items.append(Move(line, "line", st.x, st.y, tx, ty, rapid_rate, PEN_UP, rapid=True, n=n))
            st.x, st.y = tx, ty

    def z_to(tz: float) -> None:
        if abs(tz - st.z) > SAME_POINT_MM:
            st.items.append(ZMove(line, st.z, tz, rapid_rate, rapid=True))
            st.z = tz

    if st.z_axis and "Z" in named:
        z_via = target("Z", st.z, st.offset_z)
        z_to(max(z_via, st.z))           # up before the travel, down only after it
    elif "Z" in named:
        _set_pen(st, PEN_UP, line)       # the pen's home is up
    travel(target("X", st.x, st.offset_x), target("Y", st.y, st.offset_y))
    travel(0.0 if "X" in named else st.x, 0.0 if "Y" in named else st.y)
    if st.z_axis and "Z" in named:
        z_to(0.0)


def _drill(st: _State, o: Dict[str, float], line: int, n: Optional[int], rapid_rate: float) -> None:
    """G81/G82 at one hole, as LinuxCNC runs it in G90 (G98: back to the Z it
    started at, when above R; G99: to R): travel there with the pen up, down
    to the bottom Z, up again. On a plotter, a dot."""
    code = st.motion
    u = st.mm_per_unit
    if not st.absolute:
        raise GCodeError(line, f"{_g_name(code)} in incremental mode (G91) is not supported: use G90")
    if "Z" in o:
        st.cycle_z = o["Z"] * u
    if st.cycle_z is None or st.cycle_r is None:
        raise GCodeError(line, f"{_g_name(code)} drilling cycle needs {'R' if st.cycle_z is not None else 'Z'} "
                               f"(its R plane and the hole's bottom Z)")
    if st.cycle_z > st.cycle_r:
        raise GCodeError(line, f"{_g_name(code)}: the hole's bottom Z{st.cycle_z / u:g} is above its R plane "
                               f"R{st.cycle_r / u:g}")
    dwell = 0.0
    if code == 820:
        if "P" not in o or o["P"] < 0:
            raise GCodeError(line, "G82 drilling cycle needs a P word: the dwell at the bottom, in seconds")
        dwell = o.pop("P")
    offset_z = st.offset_z if st.z_axis else 0.0
    bottom, r_plane = st.cycle_z + offset_z, st.cycle_r + offset_z
    start_z = st.z
    clear = max(start_z, r_plane) if st.cycle_return == 980 else r_plane
    tx = o["X"] * u + st.offset_x if "X" in o else st.x
    ty = o["Y"] * u + st.offset_y if "Y" in o else st.y
    if st.z_axis:
        if start_z < r_plane:
            st.items.append(ZMove(line, st.z, r_plane, rapid_rate, rapid=True))
            st.z = r_plane
    if not _same_point(tx, ty, st.x, st.y):
        st.items.append(Move(line, "line", st.x, st.y, tx, ty, rapid_rate, PEN_UP, rapid=True, n=n))
        st.x, st.y = tx, ty
    if st.z_axis:
        for target, rate, rapid in ((r_plane, rapid_rate, True), (bottom, st.feed, False)):
            if abs(target - st.z) > SAME_POINT_MM:
                st.items.append(ZMove(line, st.z, target, rate, rapid=rapid))
                st.z = target
        if dwell:
            st.items.append(Dwell(line, dwell))
        if abs(clear - st.z) > SAME_POINT_MM:
            st.items.append(ZMove(line, st.z, clear, rapid_rate, rapid=True))
            st.z = clear
        return
    if not st.pen_by_command:
        pen_up_z = st.options.pen_up_z
        _set_pen(st, PEN_DOWN if bottom <= pen_up_z else PEN_UP, line)
        if dwell:
            st.items.append(Dwell(line, dwell))
        _set_pen(st, PEN_DOWN if clear <= pen_up_z else PEN_UP, line)
    st.z = clear


def _execute(st: _State, words: List[Word], line: int, rapid_rate: float) -> bool:
    """Apply one line to the state; True when it ends the program."""
    groups, m_code, o, n = _split_words(words, line, st)
    u = st.mm_per_unit
    if "F" in o:
        if o["F"] < 0:
            raise GCodeError(line, "negative feed rate")
    nonmodal = groups.get(_NONMODAL)
    _pen_words(st, m_code, o, nonmodal, line)
    drill_dwell = groups.get(_MOTION, st.motion) == 820
    if "P" in o and nonmodal != 40 and groups.get(_PATH) != 640 and not drill_dwell:
        raise GCodeError(line, "P word without G4 (dwell) to use it")
    if nonmodal == 40:
        st.items.append(_dwell(st, o, line))
    if _UNITS in groups:
        u = st.mm_per_unit = MM_PER_INCH if groups[_UNITS] == 200 else 1.0
    if "F" in o:
        st.feed = o["F"] * u
    if _DISTANCE in groups:
        st.absolute = groups[_DISTANCE] == 900
    if "H" in o:
        if groups.get("tool length offset") != 430:
            raise GCodeError(line, "H word without G43 (tool length offset) to use it")
        o.pop("H")
    if "canned cycle return" in groups:
        st.cycle_return = groups["canned cycle return"]
    has_axis = any(a in o for a in _AXES)
    motion_word = groups.get(_MOTION)
    if "K" in o:
        arc = (motion_word or st.motion) in (20, 30) and st.options.rules.arc_k
        if not arc:
            raise GCodeError(line, "K word without an arc (G2/G3) to use it")
        o.pop("K")
        st.notes.append(Note(line, f"K word: {st.options.rules.arc_k}"))
    drill = (motion_word if motion_word is not None else st.motion) in _DRILL
    if drill and "R" in o:
        st.cycle_r = o.pop("R") * u
    arc_words = [w for w in ("I", "J", "R") if w in o]
    if motion_word == 800:
        if has_axis and nonmodal not in (_HOME + (920,)):
            raise GCodeError(line, "G80 with axis words: G80 cancels the motion mode, it moves nothing")
        st.motion = motion_word = None
    if nonmodal in _HOME:
        if motion_word is not None:
            raise GCodeError(line, f"{_g_name(nonmodal)} and {_g_name(motion_word)} on one line "
                                   f"both use the axis words")
        if arc_words:
            raise GCodeError(line, f"{arc_words[0]} word without an arc (G2/G3) to use it")
        _go_home(st, o, line, n, rapid_rate, nonmodal)
    elif nonmodal == 920:
        if motion_word is not None:
            raise GCodeError(line, f"G92 and {_g_name(motion_word)} on one line "
                                   f"both use the axis words")
        if not has_axis:
            raise GCodeError(line, "G92 without any axis word (X, Y or Z)")
        if arc_words:
            raise GCodeError(line, f"{arc_words[0]} word without an arc (G2/G3) to use it")
        if "X" in o:
            st.offset_x = st.x - o["X"] * u
        if "Y" in o:
            st.offset_y = st.y - o["Y"] * u
        if "Z" in o and st.z_axis:
            st.offset_z = st.z - o["Z"] * u
        elif "Z" in o:
            st.notes.append(Note(line, "G92 Z: no effect, Z is the pen here"))
    else:
        if motion_word is not None:
            st.motion = motion_word
        arc_mode = st.motion in (20, 30)
        runs = motion_word is not None or has_axis or (arc_mode and bool(arc_words))
        if arc_words and not (arc_mode and runs):
            raise GCodeError(line, f"{arc_words[0]} word without an arc (G2/G3) to use it")
        if has_axis and st.motion is None:
            raise GCodeError(line, "axis words without a motion mode (G0, G1, G2 or G3)")
        if runs:
            if st.motion != 0 and st.feed <= 0.0 and st.options.rules.default_feed > 0.0:
                st.feed = st.options.rules.default_feed
                st.notes.append(Note(line, f"no F yet: {_g_name(st.motion)} at {st.feed:g} mm/min, "
                                           f"the firmware's default feed"))
            if st.motion != 0 and st.feed <= 0.0:
                raise GCodeError(line, f"no feed rate for {_g_name(st.motion)}: "
                                       f"set a positive F first")
            if st.motion in _DRILL:
                if has_axis:
                    _drill(st, o, line, n, rapid_rate)
            elif has_axis or arc_mode:
                _motion(st, o, line, n, rapid_rate)
    if m_code in (0, 1):
        st.items.append(Pause(line))
    return m_code in (2, 30)


def parse_program(text: str, rapid_rate: float = DEFAULT_RAPID_RATE,
                  start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False,
                  start_z: float = 0.0, options: GCodeOptions = GCodeOptions()) -> Program:
    """Parse a whole program; raise GCodeErrors listing every bad line.

    The items are the moves, dwells, pen changes and pauses in order, in
    machine coordinates (mm, mm/min) from the power-on origin, starting at
    `start` (where the pen is when the program begins) with the pen up. With
    `z_axis`, Z words are moves of a third axis (ZMove items) that is at
    `start_z` (mm) when the program begins; otherwise they move the pen.
    `options` is the dialect and its pen rules; the notes are the lines it
    accepts without acting on them.  A refused line is left out and the
    reading goes on, so that one run names every refusal; what follows a
    refused line is read in the state the lines before it left.
    """
    program, errors = _read(text, rapid_rate, start, z_axis, start_z, options)
    if errors:
        raise _errors(errors, program.notes)
    return program


def _errors(errors: List[GCodeError], notes: List[Note]) -> GCodeErrors:
    errors = sorted(errors, key=lambda e: e.line)
    return GCodeErrors(errors[:MAX_ERRORS], notes, more=max(0, len(errors) - MAX_ERRORS))


@dataclass
class Reading:
    """What reading a program found besides its items, complete once they are all taken."""
    notes: List[Note] = field(default_factory=list)
    errors: List[GCodeError] = field(default_factory=list)

    def raise_errors(self, more: Sequence[GCodeError] = ()) -> None:
        """GCodeErrors with every refused line, these and `more` (the work area's), if any."""
        if self.errors or more:
            raise _errors(self.errors + list(more), self.notes)


def program_lines(text: str) -> Iterator[Tuple[int, str]]:
    """(number from 1, text) of each line, without its line end; a last empty line is none.
    One at a time: a million-line program is not copied into a list of lines."""
    pos, size, number = 0, len(text), 0
    while pos < size:
        end = text.find("\n", pos)
        if end < 0:
            end = size
        number += 1
        raw = text[pos:end]
        yield number, raw[:-1] if raw.endswith("\r") else raw
        pos = end + 1


def read_items(text: str, reading: Reading, rapid_rate: float = DEFAULT_RAPID_RATE,
               start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False, start_z: float = 0.0,
               options: GCodeOptions = GCodeOptions()) -> Iterator[Item]:
    """The items of a program (see parse_program) one line at a time; the refused lines and the
    notes go into `reading` as they are found, so that none is known complete until the last item
    is taken (Reading.raise_errors then)."""
    if not (math.isfinite(rapid_rate) and rapid_rate > 0.0):
        raise ValueError(f"rapid rate must be positive, not {rapid_rate!r}")
    st = _State(x=float(start[0]), y=float(start[1]), z_axis=z_axis,
                z=float(start_z) if z_axis else 0.0, options=options, notes=reading.notes)
    last_line, blank, moved, ended = 1, True, False, False
    for number, raw in program_lines(text):
        last_line = number
        try:
            tokens = tokenize_line(raw, number, options)
            if tokens.note:
                st.notes.append(Note(number, tokens.note))
            blank = blank and not tokens.words and not tokens.note
            st.comment = tokens.comment
            ended = bool(tokens.words) and _execute(st, tokens.words, number, rapid_rate)
            if tokens.message:
                st.notes.append(Note(number, f"message {tokens.message!r}: shown here, not on the board"))
        except GCodeError as exc:
            reading.errors.append(exc)
            blank = False
        if st.items:
            for item in st.items:
                if isinstance(item, (Move, ZMove)):
                    moved = True
                    st.drawn = st.drawn or (isinstance(item, Move) and item.pen == PEN_DOWN and not item.rapid)
                yield item
            st.items.clear()
        if ended:
            break
    if not reading.errors and not moved:
        reading.errors.append(GCodeError(last_line, "empty program: no G-code words"
                                         if blank else "program makes no moves"))


def _read(text: str, rapid_rate: float, start: Tuple[float, float], z_axis: bool, start_z: float,
          options: GCodeOptions) -> Tuple[Program, List[GCodeError]]:
    reading = Reading()
    items = list(read_items(text, reading, rapid_rate, start, z_axis=z_axis, start_z=start_z, options=options))
    return Program(items, reading.notes), reading.errors


def check_program(text: str, area: Optional[WorkArea], rapid_rate: float = DEFAULT_RAPID_RATE,
                  start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False, start_z: float = 0.0,
                  options: GCodeOptions = GCodeOptions()) -> Program:
    """parse_program and, unless `area` is None, the work area (limits.py):
    one GCodeErrors with every refused line of both, and the notes."""
    program, errors = _read(text, rapid_rate, start, z_axis, start_z, options)
    if area is not None:
        errors += limit_errors(program.items, area)
    if errors:
        raise _errors(errors, program.notes)
    return program


def parse(text: str, rapid_rate: float = DEFAULT_RAPID_RATE,
          start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False,
          start_z: float = 0.0, options: GCodeOptions = GCodeOptions()) -> List[Item]:
    """The items of parse_program."""
    return parse_program(text, rapid_rate, start, z_axis=z_axis, start_z=start_z, options=options).items


def load_program(data: bytes, rapid_rate: float = DEFAULT_RAPID_RATE,
                 start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False,
                 start_z: float = 0.0, options: GCodeOptions = GCodeOptions()) -> List[Item]:
    """decode_program then parse."""
    return parse(decode_program(data), rapid_rate, start, z_axis=z_axis, start_z=start_z,
                 options=options)


def moves_of(items: List[Item]) -> List[Move]:
    return [item for item in items if isinstance(item, Move)]


def program_name(text: str, default: str = "program", limit: int = 60) -> str:
    """A program's name for logs and errors: its leading comment, as the
    shape server and most generators write one ("(star)", "; logo.svg"),
    else `default`."""
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line == "%":
            continue
        if line.startswith("(") and ")" in line:
            name = line[1:line.index(")")]
        elif line.startswith(";"):
            name = line[1:]
        else:
            return default
        name = " ".join(name.split())
        if name and name.isprintable():
            return name[:limit]
        return default
    return default
