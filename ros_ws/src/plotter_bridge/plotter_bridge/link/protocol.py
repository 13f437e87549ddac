"""Pure functions for the firmware's wire protocol (firmware/PROTOCOL.md).

Formatting of machine lines (sequence number and checksum) and parsing of
the board's replies.  No I/O here, so everything is testable without a port.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Optional, Union

SEQ_MOD = 1 << 16


def nearest_seq(ref: int, wire: int) -> int:
    """The unwrapped number nearest `ref` whose 16 bits on the wire are `wire`."""
    d = (wire - ref) % SEQ_MOD
    return ref + (d - SEQ_MOD if d >= SEQ_MOD // 2 else d)


# The default image's UART (firmware/hal/mcs51/main.c, Timer 1): every host default is this
# rate, so that a board flashed with `make flash` answers a bridge started without options.
DEFAULT_BAUD = 9600
BANNER_PREFIX = "PLOTTER 8051"

# What the firmware accepts in a motion command (PROTOCOL.md, commands and settings).
MAX_DELTA = 32767          # the firmware's coordinate range per command
MIN_RATE = 15              # steps/s: the firmware's slowest feed
MAX_RATE = 12850           # steps/s: the top of the firmware's ramp table ($I field T)
MAX_ARC_RATE = 5000        # steps/s: the firmware caps an arc's feed here (core/ramp.h ARC_TOP)
FIRMWARE_ACCEL = 100000    # steps/s^2: the firmware's ramp at divisor $0=1 ($I field A)

# A pen change in a job ("M6 k": the job's k-th, from 0): not a board command.  The
# bridge sends the board a 1 ms dwell in its place and holds the rest of the job
# until the operator, having put in the next pen, says resume.
PEN_CHANGE = "M6"
PEN_CHANGE_STANDIN = "D 1"


def pen_change_number(text: str) -> Optional[int]:
    """k of a job's pen change "M6 k"; None for any other command."""
    parts = text.split()
    if len(parts) == 2 and parts[0] == PEN_CHANGE and parts[1].isdigit():
        return int(parts[1])
    return None


# Real-time commands as they go on the wire.  Hold, resume and reset are a
# pair of the same byte, acted on between lines only: one flipped bit makes
# a line's '1' a '!' and its '8' a Ctrl-X, and a single one must not act.
RT_STATUS = b"?"
RT_HOLD = b"!!"
RT_RESUME = b"~~"
RT_RESET = b"\x18\x18"
RT_ESTOP = b"\x1b"

ERROR_TEXT = {
    1: "unknown command", 2: "checksum", 3: "bad number", 4: "line too long",
    5: "queue full", 6: "argument count", 7: "sequence gap", 8: "bad arc",
    9: "alarm, reset first", 10: "busy, wait for idle", 11: "out of range",
}


def _crc16_table() -> tuple:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return tuple(table)


_CRC16_TABLE = _crc16_table()


def crc16(data: bytes) -> int:
    """The protocol's check, as the firmware computes it: CRC-16/CCITT-FALSE
    (polynomial 0x1021, start 0xFFFF, not reflected, no final xor;
    crc16(b"123456789") == 0x29B1)."""
    crc = 0xFFFF
    for b in data:
        crc = ((crc << 8) & 0xFFFF) ^ _CRC16_TABLE[(crc >> 8) ^ b]
    return crc


def checksum(text: str) -> int:
    """Checksum of a line's text (non-ASCII characters count as '?')."""
    return crc16(text.encode("ascii", "replace"))


# Coordinates before the optional feed and exit of each motion command.
MOTION_COORDS = {"L": 2, "C": 4, "A": 4, "Z": 1}


def compact_command(command: str) -> str:
    """The shortest text the firmware reads as the same command: trailing
    feed and exit of 0 left out (PROTOCOL.md: 0 and omitted mean the same),
    no separator between the command letter and its first argument (its
    parser skips separators there but needs none; between arguments it
    does).  Link bytes bound the drawing speed of short segments, and the
    shorter a line, the more lines fit in the board's 64-byte receive ring
    at once."""
    parts = command.split()
    if not parts:
        return ""
    verb, args = parts[0], parts[1:]
    coords = MOTION_COORDS.get(verb)
    if coords is not None:
        while len(args) > coords and args[-1] == "0":
            args.pop()
    return verb + " ".join(args)


def machine_line(seq: int, command: str) -> bytes:
    """`N<seq><command>*<checksum>\\n` for a command like `L 10 -4`, the
    command compacted (`N17L10 -4*7700`).  The firmware skips spaces after
    the number and ends the last argument at the `*`, so neither needs a
    separator; the checksum covers every byte before the `*`."""
    body = f"N{seq % SEQ_MOD}{compact_command(command)}"
    return f"{body}*{checksum(body)}\n".encode("ascii")


@dataclass(frozen=True)
class Ok:
    seq: Optional[int]     # None for a typed line
    queue_free: int


@dataclass(frozen=True)
class Err:
    seq: Optional[int]
    code: int
    text: str


@dataclass(frozen=True)
class Resend:
    expected: int
    code: int


@dataclass(frozen=True)
class Status:
    state: str             # Idle, Run, Hold, Alarm
    x: int
    y: int
    queue_free: int
    next_seq: int
    seq: int               # command executing or last executed
    pen_down: bool
    underruns: int
    alarm: int
    z: Optional[int] = None  # Z axis position in steps; None from a board without one (ZAXIS=0)
    # Line following (FOLLOW=1; None from a board without it): the sensors on black (bit i: sensor i),
    # the follow's state (link/follow.py FOLLOW_STATES) and the steps it followed.
    sensors: Optional[int] = None
    follow: Optional[int] = None
    followed: Optional[int] = None


@dataclass(frozen=True)
class Banner:
    text: str


@dataclass(frozen=True)
class Message:
    """A bracketed notice such as `[alarm estop]` or `[reset]`, or `$` output."""
    text: str


Reply = Union[Ok, Err, Resend, Status, Banner, Message]

_OK = re.compile(r"ok(?: N(\d+))? Q(\d+)$")
_ERR = re.compile(r"err(?: N(\d+))? E(\d+)(?: (.*))?$")
_RS = re.compile(r"rs N(\d+) E(\d+)$")
_STATUS = re.compile(
    r"<(Idle|Run|Hold|Alarm) X(-?\d+) Y(-?\d+)(?: Z(-?\d+))? Q(\d+) N(\d+) S(\d+) P([01]) U(\d+) A(\d+)"
    r"(?: B([0-7]) F(\d) W(\d+))?>$")


def verify_reply(line: str) -> Optional[str]:
    """The text of a reply line whose ` *<checksum>` matches, else None."""
    line = line.rstrip("\r\n")
    body, star, tail = line.rpartition("*")
    if not star or not tail.isdigit() or len(tail) > 5 or checksum(body) != int(tail):
        return None
    return body.rstrip(" ")


def parse_reply(raw: str) -> Optional[Reply]:
    """One line from the board, without its line ending; None if damaged (the
    checksum fails) or unrecognised: the caller ignores it and relies on
    time-outs and later replies."""
    line = verify_reply(raw)
    if line is None:
        return None
    m = _OK.match(line)
    if m:
        return Ok(int(m.group(1)) if m.group(1) else None, int(m.group(2)))
    m = _STATUS.match(line)
    if m:
        g = m.groups()
        follow = (None, None, None) if g[10] is None else (int(g[10]), int(g[11]), int(g[12]))
        return Status(g[0], int(g[1]), int(g[2]), int(g[4]), int(g[5]), int(g[6]),
                      g[7] == "1", int(g[8]), int(g[9]), None if g[3] is None else int(g[3]), *follow)
    m = _RS.match(line)
    if m:
        return Resend(int(m.group(1)), int(m.group(2)))
    m = _ERR.match(line)
    if m:
        code = int(m.group(2))
        # The board sends the code only (8 KB of flash); the text is ours.
        return Err(int(m.group(1)) if m.group(1) else None, code,
                   m.group(3) or ERROR_TEXT.get(code, "unknown error"))
    if line.startswith(BANNER_PREFIX) and line.endswith("ready"):
        return Banner(line)
    if line.startswith("[") and line.endswith("]") or line.startswith("$"):
        return Message(line)
    return None


def seq_after(a: int, b: int) -> bool:
    """True if 16-bit sequence number a comes after b (within half the range)."""
    d = (a - b) % SEQ_MOD
    return 0 < d < SEQ_MOD // 2
