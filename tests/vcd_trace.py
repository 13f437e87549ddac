"""What the 8051's pins did, rebuilt from an s51 VCD trace (firmware/tools/s51sim.py).

- steps: the step, direction and pen outputs of port 1 (step/direction build);
- the LCD: the bytes the HD44780 takes on each falling edge of E (P3.4), data
  on P0, RS on P3.3, and the screen they leave;
- the 7-segment display: the pattern on P0 while the 74HC138 on P3.5-P3.7
  selects each digit.

Pin assignments: firmware/README.md and firmware/core/config.h.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Optional

X_STEP, X_DIR, Y_STEP, Y_DIR, PEN = 0x01, 0x02, 0x04, 0x08, 0x10   # P1
LCD_RS, LCD_E, SEG_SELECT = 0x08, 0x10, 0xE0                          # P3
CYCLE_PS = 12 * 10**12 / 11_059_200


@dataclass(frozen=True)
class Step:
    t: int              # ps
    dx: int
    dy: int
    cycles: Optional[float]   # machine cycles since the previous step (None for the first)


@dataclass(frozen=True)
class Pen:
    t: int
    down: bool


def steps(p1: Iterable[tuple[int, int]]) -> list:
    """Steps and pen changes, in order, from port 1's (time, value) events."""
    out: list = []
    prev = last = None
    for t, v in p1:
        if prev is not None:
            if (v ^ prev) & PEN:
                out.append(Pen(t, bool(v & PEN)))
            rising = v & ~prev & (X_STEP | Y_STEP)
            if rising:
                assert rising in (X_STEP, Y_STEP), "one axis per step"
                dx = (-1 if v & X_DIR else 1) if rising == X_STEP else 0
                dy = (-1 if v & Y_DIR else 1) if rising == Y_STEP else 0
                out.append(Step(t, dx, dy, None if last is None else (t - last) / CYCLE_PS))
                last = t
        prev = v
    return out


@dataclass(frozen=True)
class PulseTiming:
    """Shortest times on the step and direction pins of one axis, in ps,
    the figures a driver's data sheet bounds."""
    high: int           # STEP high
    low: int            # STEP low between two pulses
    setup: int          # DIR settled before the STEP's rising edge
    hold: int           # DIR kept after the STEP's rising edge


def pulse_timing(p1: Iterable[tuple[int, int]]) -> dict[str, PulseTiming]:
    """Per axis ("x", "y"), the shortest of each time over the trace
    (None where the trace has no such interval)."""
    out = {}
    for axis, step, direction in (("x", X_STEP, X_DIR), ("y", Y_STEP, Y_DIR)):
        high = low = setup = hold = None
        prev = rise = fall = turn = None

        def least(a, b):
            return b if a is None or b < a else a
        for t, v in p1:
            if prev is not None:
                if (v ^ prev) & direction:
                    turn = t
                    if rise is not None:
                        hold = least(hold, t - rise)
                if v & ~prev & step:
                    if fall is not None:
                        low = least(low, t - fall)
                    if turn is not None:
                        setup = least(setup, t - turn)
                    rise = t
                if prev & ~v & step:
                    high = least(high, t - rise)
                    fall = t
            prev = v
        out[axis] = PulseTiming(high, low, setup, hold)
    return out


def lcd_writes(p0: list[tuple[int, int]], p3: list[tuple[int, int]]) -> list[tuple[int, int, int]]:
    """(time, rs, byte) of every byte the LCD takes: P0 and RS as they are
    when E falls."""
    out = []
    k = 0
    bus = 0xFF
    prev = None
    for t, v in p3:
        while k < len(p0) and p0[k][0] <= t:
            bus = p0[k][1]
            k += 1
        if prev is not None and prev & LCD_E and not v & LCD_E:
            out.append((t, 1 if v & LCD_RS else 0, bus))
        prev = v
    return out


class Lcd:
    """An HD44780 16x2 as far as the firmware drives it: set-address and
    clear commands, data into display RAM."""

    def __init__(self) -> None:
        self.lines = [[" "] * 16, [" "] * 16]
        self.addr = 0

    def write(self, rs: int, b: int) -> None:
        if not rs:
            if b & 0x80:
                self.addr = b & 0x7F
            elif b == 0x01:
                self.lines = [[" "] * 16, [" "] * 16]
                self.addr = 0
            return
        if self.addr < 16:
            self.lines[0][self.addr] = chr(b)
        elif 0x40 <= self.addr < 0x50:
            self.lines[1][self.addr - 0x40] = chr(b)
        self.addr += 1

    def text(self) -> tuple[str, str]:
        return "".join(self.lines[0]), "".join(self.lines[1])


def lcd_screen(writes: Iterable[tuple[int, int, int]], until: Optional[int] = None) -> tuple[str, str]:
    """The two lines after every write up to time `until`."""
    lcd = Lcd()
    for t, rs, b in writes:
        if until is not None and t > until:
            break
        lcd.write(rs, b)
    return lcd.text()


SEGMENTS = {0x3F: "0", 0x06: "1", 0x5B: "2", 0x4F: "3", 0x66: "4", 0x6D: "5",
            0x7D: "6", 0x07: "7", 0x7F: "8", 0x6F: "9", 0x00: " "}


def seven_segment(p0: list[tuple[int, int]], p3: list[tuple[int, int]],
                  until: Optional[int] = None) -> str:
    """The eight digits, left to right, as last shown before time `until`.
    The firmware blanks P0, moves the select (two writes to P3, the first a
    moment's pass through digit 0), then puts the digit's pattern on P0: so
    a digit's pattern is the first P0 value after the select settles on it
    (the unchanged P0 if no write came).  LCD writes move only RS and E."""
    events = sorted([(t, 0, v) for t, v in p0] + [(t, 3, v) for t, v in p3])
    shown = ["?"] * 8
    bus, select, pending, since = 0, None, None, 0
    for t, port, v in events:
        if until is not None and t > until:
            break
        if port == 0:
            bus = v
            if pending is not None:
                shown[pending] = SEGMENTS.get(v, "?")
                pending = None
            continue
        new_select = (v & SEG_SELECT) >> 5
        if new_select == select:
            continue
        if pending is not None and (t - since) / CYCLE_PS > 100:
            shown[pending] = SEGMENTS.get(bus, "?")      # held with P0 unchanged
        select, pending, since = new_select, new_select, t
    return "".join(shown)
