"""G-code front end of the plotter: parse a program into moves in machine mm.

The subset (case-insensitive; one block per physical line):

- Motion (modal): G0 rapid travel with the pen up at the rapid rate, G1 line,
  G2/G3 clockwise/counter-clockwise arc with I/J (centre offset from the start,
  always incremental) or R (positive: arc of at most 180 degrees, negative: the
  longer arc). G2/G3 ending where they start with I/J make a full circle.
- G4 P<seconds> dwell; G17 (XY plane; G18/G19 are rejected); G20/G21 inch/mm;
  G90/G91 absolute/incremental; G92 X/Y sets the current position (an offset;
  Z is accepted and has no effect on the pen); G94 units per minute; G61/G64 (path
  control) are accepted and have no effect (notes). G4's P unit is the dialect's.
- F feed (units per minute, modal; in the units in force after the line's
  G20/G21, and kept as a speed when the units change later); M3 pen down, M5
  pen up, M0 pause, M2/M30 end of program (the rest of the file is not read).
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
- N words, comments in parentheses and after ';', '%' lines, blank lines.
- Dialects (gcode/dialect.py, ``options``): grbl's S power word and
  M4, M7/M8/M9, G54; Marlin's M300 pen servo, G4 P in milliseconds,
  M17/M18/M84. What a dialect accepts without acting on it is a Note.

Effects of one line happen in LinuxCNC's order: S, M3/M5 (M4, M300), G4, modes (G17,
G20/G21, G90/G91, ...), G92, motion, then M0/M2/M30. The whole program is
parsed before anything is returned, so a bad line rejects the whole program
with a GCodeError naming its physical line. Rejected as well: other letters,
G and M codes, words without a number, numbers without a letter, a letter
twice on a line (G excepted), two G codes of one modal group, non-ASCII or
control characters, lines over 256 characters, a program without moves, and
arcs LinuxCNC refuses (see geometry.py).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Tuple, Dict, List, Optional

from . import geometry
from .dialect import GCodeOptions, dialect_hint, system_command_reason
from .types import (PEN_DOWN, PEN_UP, Dwell, GCodeError, Item, Move, Note, Pause,
                    PenChange, ZMove)
from .limits import WorkArea, check_limits
from .steps import StepMove, to_steps

__all__ = ["GCodeError", "Move", "ZMove", "Dwell", "PenChange", "Pause", "Note", "Item", "WorkArea",
           "StepMove", "GCodeOptions", "Program", "check_limits", "to_steps", "parse", "parse_program",
           "decode_program", "load_program", "moves_of", "DEFAULT_RAPID_RATE"]

MAX_LINE_LENGTH = 256
MAX_ABS_VALUE = 1e6
DEFAULT_RAPID_RATE = 3000.0  # mm/min
MM_PER_INCH = geometry.MM_PER_INCH
SAME_POINT_MM = 1e-9

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")
_LETTERS = frozenset("GMXYZIJRFPN")   # every dialect's; gcode/dialect.py adds others
_AXES = ("X", "Y", "Z")

# G codes in tenths (G61 -> 610), with their modal group.
_MOTION, _NONMODAL, _PLANE, _DISTANCE, _FEED_MODE, _UNITS, _PATH = (
    "motion", "non-modal", "plane", "distance", "feed mode", "units", "path control")
_G_GROUPS = {0: _MOTION, 10: _MOTION, 20: _MOTION, 30: _MOTION, 40: _NONMODAL,
             920: _NONMODAL, 170: _PLANE, 180: _PLANE, 190: _PLANE, 900: _DISTANCE,
             910: _DISTANCE, 940: _FEED_MODE, 200: _UNITS, 210: _UNITS, 610: _PATH,
             640: _PATH}
_M_CODES = frozenset((0, 2, 3, 5, 30))
_COORDINATE_SYSTEM = "coordinate system"


@dataclass(frozen=True)
class Word:
    letter: str
    value: float


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
    items: List[Item] = field(default_factory=list)
    notes: List[Note] = field(default_factory=list)


@dataclass(frozen=True)
class Program:
    """A parsed program: what it does, and what it says that has no effect here."""

    items: List[Item]
    notes: List[Note]


def _g_name(code: int) -> str:
    return f"G{code // 10}" + (f".{code % 10}" if code % 10 else "")


_HINTS = {"[": "expressions in brackets are not supported",
          "#": "parameters (#) are not supported",
          "*": "checksums (*) are not supported",
          "/": "block delete (/) is not supported"}


def _bad_character(ch: str) -> str:
    return _HINTS.get(ch, f"unexpected character {ch!r}")


def tokenize_line(text: str, line: int, options: GCodeOptions = GCodeOptions()) -> List[Word]:
    """The words of one physical line; comments and blanks are dropped."""
    if len(text) > MAX_LINE_LENGTH:
        raise GCodeError(line, f"line too long ({len(text)} characters, "
                               f"at most {MAX_LINE_LENGTH})")
    for ch in text:
        if not (ch == "\t" or " " <= ch <= "~"):
            raise GCodeError(line, f"invalid character U+{ord(ch):04X} "
                                   f"(only printable ASCII is allowed)")
    if text.strip() == "%":
        return []
    if text.lstrip().startswith("$"):
        raise GCodeError(line, system_command_reason(text))
    letters = _LETTERS | options.rules.letters
    words: List[Word] = []
    i = 0
    while i < len(text):
        ch = text[i]
        if ch in " \t":
            i += 1
        elif ch == ";":
            break
        elif ch == "(":
            close = text.find(")", i + 1)
            if close < 0:
                raise GCodeError(line, "unclosed comment: '(' without ')'")
            if "(" in text[i + 1:close]:
                raise GCodeError(line, "nested comment: '(' inside a comment")
            i = close + 1
        elif ch == ")":
            raise GCodeError(line, "')' without a comment to close")
        elif ch.isalpha():
            letter = ch.upper()
            if letter not in letters:
                raise GCodeError(line, f"unsupported word letter '{letter}'"
                                       + dialect_hint(letter, options.dialect))
            j = i + 1
            while j < len(text) and text[j] in " \t":
                j += 1
            m = _NUMBER.match(text, j)
            if m is None:
                hint = _HINTS.get(text[j]) if j < len(text) else None
                raise GCodeError(line, f"'{letter}' word without a number"
                                       + (f" ({hint})" if hint else ""))
            value = float(m.group())
            if abs(value) > MAX_ABS_VALUE:
                raise GCodeError(line, f"number out of range in '{letter}{m.group()}' "
                                       f"(at most {MAX_ABS_VALUE:g})")
            words.append(Word(letter, value))
            i = m.end()
        elif ch.isdigit() or ch in "+-.":
            m = _NUMBER.match(text, i)
            shown = m.group() if m else ch
            raise GCodeError(line, f"number {shown!r} without a word letter")
        else:
            raise GCodeError(line, _bad_character(ch))
    return words


def _split_words(words: List[Word], line: int, st: _State):
    """(G codes by modal group, M code or None, other words by letter, N);
    the words the dialect accepts without effect become notes."""
    rules = st.options.rules
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
            code = round(w.value * 10)
            exact = abs(w.value * 10 - code) <= 1e-6
            if exact and code in rules.refused_g:
                raise GCodeError(line, rules.refused_g[code])
            group = _G_GROUPS.get(code) or (_COORDINATE_SYSTEM if code in rules.noted_g else None)
            if not exact or group is None:
                raise GCodeError(line, f"unsupported G code G{w.value:g}")
            if code in (180, 190):
                raise GCodeError(line, f"{_g_name(code)}: only the XY plane (G17) "
                                       f"is supported")
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
    m_code: Optional[int] = None
    if "M" in others:
        value = others.pop("M")
        code = int(value) if value == int(value) else None
        if code in rules.noted_m:
            st.notes.append(Note(line, rules.noted_m[code]))
        elif code in _M_CODES or code in rules.m_codes:
            m_code = code
        else:
            raise GCodeError(line, f"unsupported M code M{value:g}")
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
        new_pen = PEN_DOWN if st.z <= st.options.pen_up_z else PEN_UP
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


def _pen_words(st: _State, m_code: Optional[int], o: Dict[str, float], nonmodal: Optional[int],
               line: int) -> None:
    """The pen from this line's M code and, in grbl and marlin, its S word."""
    rules, options = st.options.rules, st.options
    if rules.power_word:
        if "S" in o:
            if o["S"] < 0:
                raise GCodeError(line, f"negative S word (power) S{o['S']:g}")
            st.power = o["S"]
        if m_code in (3, 4, 5):
            st.spindle_on = m_code != 5
        if m_code in (3, 4, 5) or ("S" in o and st.spindle_on):
            # A power never set counts as on: "M3" alone draws, as in LinuxCNC.
            on = st.spindle_on and (st.power is None or st.power > 0.0)
            _set_pen(st, PEN_DOWN if on else PEN_UP, line)
        return
    if rules.servo_pen and "S" in o and m_code != 300 and nonmodal != 40:
        raise GCodeError(line, "S word without M300 (pen servo) or G4 (dwell) to use it")
    if m_code == 300:
        if "S" not in o:
            raise GCodeError(line, "M300 (pen servo) needs an S word: the servo angle")
        pen = options.servo_pen(o["S"])
        if pen is None:
            raise GCodeError(line, f"M300 S{o['S']:g}: neither the pen-down angle "
                                   f"{options.marlin_pen_down:g} nor the pen-up angle "
                                   f"{options.marlin_pen_up:g} (marlin_pen_down, marlin_pen_up)")
        _set_pen(st, pen, line)
    elif m_code == 3:
        _set_pen(st, PEN_DOWN, line)
    elif m_code == 5:
        _set_pen(st, PEN_UP, line)


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


def _execute(st: _State, words: List[Word], line: int, rapid_rate: float) -> bool:
    """Apply one line to the state; True when it ends the program."""
    groups, m_code, o, n = _split_words(words, line, st)
    u = st.mm_per_unit
    if "F" in o:
        if o["F"] < 0:
            raise GCodeError(line, "negative feed rate")
    nonmodal = groups.get(_NONMODAL)
    _pen_words(st, m_code, o, nonmodal, line)
    if "P" in o and nonmodal != 40 and groups.get(_PATH) != 640:
        raise GCodeError(line, "P word without G4 (dwell) to use it")
    if nonmodal == 40:
        st.items.append(_dwell(st, o, line))
    if _UNITS in groups:
        u = st.mm_per_unit = MM_PER_INCH if groups[_UNITS] == 200 else 1.0
    if "F" in o:
        st.feed = o["F"] * u
    if _DISTANCE in groups:
        st.absolute = groups[_DISTANCE] == 900
    has_axis = any(a in o for a in _AXES)
    arc_words = [w for w in ("I", "J", "R") if w in o]
    motion_word = groups.get(_MOTION)
    if nonmodal == 920:
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
            if st.motion != 0 and st.feed <= 0.0:
                raise GCodeError(line, f"no feed rate for {_g_name(st.motion)}: "
                                       f"set a positive F first")
            if has_axis or arc_mode:
                _motion(st, o, line, n, rapid_rate)
    if m_code == 0:
        st.items.append(Pause(line))
    return m_code in (2, 30)


def parse_program(text: str, rapid_rate: float = DEFAULT_RAPID_RATE,
                  start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False,
                  start_z: float = 0.0, options: GCodeOptions = GCodeOptions()) -> Program:
    """Parse a whole program; raise GCodeError for the first bad line.

    The items are the moves, dwells, pen changes and pauses in order, in
    machine coordinates (mm, mm/min) from the power-on origin, starting at
    `start` (where the pen is when the program begins) with the pen up. With
    `z_axis`, Z words are moves of a third axis (ZMove items) that is at
    `start_z` (mm) when the program begins; otherwise they move the pen.
    `options` is the dialect and its pen rules; the notes are the lines it
    accepts without acting on them.
    """
    if not (math.isfinite(rapid_rate) and rapid_rate > 0.0):
        raise ValueError(f"rapid rate must be positive, not {rapid_rate!r}")
    st = _State(x=float(start[0]), y=float(start[1]), z_axis=z_axis,
                z=float(start_z) if z_axis else 0.0, options=options)
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    last_line = max(len(lines), 1)
    blank = True
    for number, raw in enumerate(lines, start=1):
        if raw.endswith("\r"):
            raw = raw[:-1]
        words = tokenize_line(raw, number, options)
        blank = blank and not words
        if words and _execute(st, words, number, rapid_rate):
            last_line = number
            break
    if not any(isinstance(item, (Move, ZMove)) for item in st.items):
        raise GCodeError(last_line, "empty program: no G-code words"
                         if blank else "program makes no moves")
    return Program(st.items, st.notes)


def parse(text: str, rapid_rate: float = DEFAULT_RAPID_RATE,
          start: Tuple[float, float] = (0.0, 0.0), *, z_axis: bool = False,
          start_z: float = 0.0, options: GCodeOptions = GCodeOptions()) -> List[Item]:
    """The items of parse_program."""
    return parse_program(text, rapid_rate, start, z_axis=z_axis, start_z=start_z, options=options).items


def decode_program(data: bytes) -> str:
    """The text of a program file; non-ASCII bytes are a GCodeError."""
    try:
        return data.decode("ascii")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise GCodeError(line, f"invalid byte 0x{data[exc.start]:02x} "
                               f"(only printable ASCII is allowed)") from None


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
