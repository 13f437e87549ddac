"""One line of G-code into words: comments, characters, numbers, and the file's text.

A comment is not a command, and the board never sees one: comments (in
parentheses, or after ';') may be of any length and hold any text (UTF-8, as
Italian or Chinese generators write them).  What a line commands, its words
without the comments, is printable ASCII of at most MAX_COMMAND_LENGTH
characters.  Whole-line commands of grbl's (``$$``, ``$I``, ``?``) are judged
by the dialect (gcode/dialect.py): a query is a note, a setting is refused.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import List, Optional

from .dialect import GCodeOptions, dialect_hint, system_line
from .types import GCodeError

MAX_COMMAND_LENGTH = 256          # characters of a line outside its comments
MAX_ABS_VALUE = 1e6
BARE_AXIS_LETTERS = frozenset("XYZ")   # may stand alone after G28/G30 (Marlin's "G28 X Y")

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")
LETTERS = frozenset("GMXYZIJRFPNT")    # every dialect's; gcode/dialect.py adds others
_HINTS = {"[": "expressions in brackets are not supported",
          "#": "parameters (#) and macros are not supported",
          "*": "checksums (*) are not supported",
          "/": "block delete (/) is not supported"}


@dataclass(frozen=True)
class Word:
    letter: str
    value: float          # NaN: an axis letter without a number (only G28/G30 take one)
    known: bool = True    # a letter of the dialect (an unknown one is refused after the line's G codes)

    @property
    def bare(self) -> bool:
        return math.isnan(self.value)


@dataclass
class TokenLine:
    """The words of one line, and what else it says: a note for a line the
    dialect takes without acting on it, a message (Marlin's ``M0 Pen In``)."""

    words: List[Word] = field(default_factory=list)
    note: Optional[str] = None
    message: str = ""
    comment: str = ""          # the line's first comment, stripped (an M6's says which pen comes next)


def _bad_character(ch: str) -> str:
    if not (ch == "\t" or " " <= ch <= "~"):
        return f"invalid character U+{ord(ch):04X} outside a comment (only printable ASCII is allowed there)"
    return _HINTS.get(ch, f"unexpected character {ch!r}")


def _command_length(text: str) -> int:
    """Characters of a line outside its comments (an unclosed '(' counts to the end)."""
    n, depth = 0, False
    for ch in text:
        if ch == ";" and not depth:
            break
        if ch == "(" and not depth:
            depth = True
        elif ch == ")" and depth:
            depth = False
        elif not depth:
            n += 1
    return n


def tokenize_line(text: str, line: int, options: GCodeOptions = GCodeOptions()) -> TokenLine:
    """The words of one physical line; comments and blanks are dropped."""
    length = _command_length(text)
    if length > MAX_COMMAND_LENGTH:
        raise GCodeError(line, f"line too long ({length} characters outside comments, "
                               f"at most {MAX_COMMAND_LENGTH})")
    stripped = text.strip()
    if stripped == "%":
        return TokenLine()
    if stripped.startswith(("$", "?")):
        return TokenLine(note=system_line(stripped, line))
    rules = options.rules
    letters = LETTERS | rules.letters
    out = TokenLine()
    i = 0
    while i < len(text):
        ch = text[i]
        if ch in " \t":
            i += 1
        elif ch == ";":
            out.comment = out.comment or text[i + 1:].strip()
            break
        elif ch == "(":
            close = text.find(")", i + 1)
            if close < 0:
                raise GCodeError(line, "unclosed comment: '(' without ')'")
            if "(" in text[i + 1:close]:
                raise GCodeError(line, "nested comment: '(' inside a comment")
            out.comment = out.comment or text[i + 1:close].strip()
            i = close + 1
        elif ch == ")":
            raise GCodeError(line, "')' without a comment to close")
        elif "A" <= ch.upper() <= "Z":
            letter = ch.upper()
            known = letter in letters
            if letter == "O":
                raise GCodeError(line, "unsupported word letter 'O' (O-words: subroutines, loops and "
                                       "conditions are not supported)")
            j = i + 1
            while j < len(text) and text[j] in " \t":
                j += 1
            m = _NUMBER.match(text, j)
            if m is None and not known:
                raise GCodeError(line, f"unsupported word letter '{letter}'" + dialect_hint(letter, options.dialect))
            if m is None:
                if letter in BARE_AXIS_LETTERS:
                    out.words.append(Word(letter, math.nan))
                    i = j
                    continue
                hint = _HINTS.get(text[j]) if j < len(text) else None
                raise GCodeError(line, f"'{letter}' word without a number" + (f" ({hint})" if hint else "")
                                 + (rules.message_hint if out.words and out.words[-1].letter == "M" else ""))
            value = float(m.group())
            if abs(value) > MAX_ABS_VALUE:
                raise GCodeError(line, f"number out of range in '{letter}{m.group()}' (at most {MAX_ABS_VALUE:g})")
            out.words.append(Word(letter, value, known))
            i = m.end()
            if letter == "M" and value in rules.message_m:
                rest = text[i:].strip()
                if rest and not _starts_with_word(rest, letters):
                    out.message = rest     # Marlin's M0/M1/M117 text runs to the end of the line
                    break
        elif ch.isdigit() or ch in "+-.":
            m = _NUMBER.match(text, i)
            shown = m.group() if m else ch
            raise GCodeError(line, f"number {shown!r} without a word letter")
        else:
            raise GCodeError(line, _bad_character(ch))
    return out


def _starts_with_word(text: str, letters: frozenset) -> bool:
    """Whether text goes on with G-code words (``P500``, ``(comment)``) rather than a message."""
    if text[0] in "(;":
        return True
    if text[0].upper() not in letters:
        return False
    rest = text[1:].lstrip(" \t")
    return bool(rest) and _NUMBER.match(rest) is not None


def decode_program(data: bytes) -> str:
    """The text of a program file.  UTF-8, as most generators write their
    comments (a byte-order mark is dropped); a file that is not UTF-8 is read
    byte for byte as Latin-1, since older Windows tools write their comments in
    their code page: either way only comments may hold characters beyond ASCII,
    and the tokenizer refuses one in a command with its line."""
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")
