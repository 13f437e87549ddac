#!/usr/bin/env python3
"""Generate the built-in figures of the board's panel (build/figure_table.c).

The figures are the host's own shapes (ros_ws/src/plotter_shapes, module
geometry), so the board and the ROS graph draw the same diamond, star, cone
and car; the car reversed is geometry.reverse(car), the same picture drawn
backwards.  Each figure is centred on the pen, sized in motor steps at
STEPS_PER_MM, and its points rounded to a grid of GRID steps, so that every
number fits a signed byte (the 8 KB part has no room for more).  Arcs stay
exact: the figures' arcs are symmetric about their centres, so the rounded
start and end keep one radius (checked here).  A figure is stored as the
commands the protocol would send, in a byte stream that core/figures.c
expands into the planner's arguments (times GRID): a code byte, then the
numbers of a line or an arc,

    FC_LINE  dx dy          a line
    FC_CW    dx dy i j      an arc about the centre (i, j) from the pen
    FC_CCW   dx dy i j

with a pen change folded into the code byte of the move it comes before
(FC_UP, pen up; FC_DOWN, pen down) and FC_END on the last move.  Bits
FC_ZERO << k (k = 0..2: dx, dy, i) stand for a number that is 0 and left
out.  A figure starts and ends with the pen up at its centre.  fig_stream
begins with the index of each figure's first move, a byte each.

usage: tools/gen_figures.py build/figure_table.c       write the C table
       tools/gen_figures.py --json                       the commands, for tests
"""
import json
import struct
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "ros_ws" / "src" / "plotter_shapes"))
from plotter_shapes import geometry  # noqa: E402

STEPS_PER_MM = 80
GRID = 32              # steps per unit of the stored numbers (FIG_GRID_SHIFT in core/figures.h)
FIGURES = [            # C name, figure (centred on 0, 0; sizes in mm)
    ("FIG_DIAMOND", lambda: geometry.diamond(0.0, 0.0, 32.0)),
    ("FIG_STAR", lambda: geometry.star(0.0, 0.0, 40.0)),
    ("FIG_CONE", lambda: geometry.cone(0.0, 0.0, 32.0)),
    ("FIG_CAR", lambda: geometry.car(0.0, 0.0, 40.0)),
    ("FIG_CAR_REV", lambda: geometry.reverse(geometry.car(0.0, 0.0, 40.0))),
]
MOVES = {"line": 0x00, "ccw": 0x02, "cw": 0x03}     # core/figures.h: FC_LINE, FC_CCW, FC_CW
FC_UP, FC_DOWN, FC_END, FC_ZERO = 0x04, 0x08, 0x10, 0x20


def steps(v: float) -> int:
    """mm to steps, on the grid."""
    return GRID * int(round(v * STEPS_PER_MM / GRID))


def figure_commands(fig):
    """[(code, args...)] in steps: every stroke reached with the pen up from
    where the last one ended, and the pen back at the centre at the end."""
    out, x, y = [], 0, 0

    def move(kind, tx, ty, *centre):
        nonlocal x, y
        args = [tx - x, ty - y] + [c - p for c, p in zip(centre, (x, y))]
        out.append((kind, *args))
        x, y = tx, ty

    for stroke in fig.strokes:
        sx, sy = (steps(v) for v in stroke.start)
        out.append(("up",))
        if (sx, sy) != (x, y):
            move("line", sx, sy)
        out.append(("down",))
        for seg in stroke.segments:
            ex, ey = (steps(v) for v in seg.end)
            if isinstance(seg, geometry.Arc):
                cx, cy = steps(seg.cx), steps(seg.cy)
                assert (x - cx) ** 2 + (y - cy) ** 2 == (ex - cx) ** 2 + (ey - cy) ** 2, \
                    "an arc whose rounded ends are not on one circle"
                move("cw" if seg.cw else "ccw", ex, ey, cx, cy)
            else:
                move("line", ex, ey)
    out.append(("up",))
    if (x, y) != (0, 0):
        move("line", 0, 0)
    out.append(("end",))
    return out


def all_figures():
    return {name: figure_commands(make()) for name, make in FIGURES}


def encode(commands) -> bytes:
    """The stream: each move with the pen change before it in its code byte,
    and its numbers but those of the first three that are 0."""
    moves = []              # [code, numbers]
    pen = 0
    for kind, *args in commands:
        if kind in MOVES:
            assert all(a % GRID == 0 and -128 <= a // GRID <= 127 for a in args), (kind, args)
            moves.append([MOVES[kind] | pen, [a // GRID for a in args]])
            pen = 0
        elif kind in ("up", "down"):
            assert not pen, "one pen change before a move"
            pen = FC_UP if kind == "up" else FC_DOWN
        else:
            assert kind == "end" and not pen and moves, "a figure ends after a move"
            moves[-1][0] |= FC_END
    assert moves and moves[-1][0] & FC_END
    data = b""
    for code, numbers in moves:
        kept = []
        for k, v in enumerate(numbers):
            if k < 3 and v == 0:
                code |= FC_ZERO << k
            else:
                kept.append(v)
        data += bytes([code]) + struct.pack(f"<{len(kept)}b", *kept)
    assert decode(data) == commands
    return data


def decode(data: bytes):
    """The commands of a stream, as core/figures.c plays them."""
    out, k = [], 0
    kinds = {v: n for n, v in MOVES.items()}
    while True:
        code = data[k]
        k += 1
        numbers = []
        for n in range(4 if code & 2 else 2):
            if n < 3 and code & FC_ZERO << n:
                numbers.append(0)
            else:
                numbers.append(GRID * struct.unpack("<b", data[k:k + 1])[0])
                k += 1
        if code & FC_UP:
            out.append(("up",))
        if code & FC_DOWN:
            out.append(("down",))
        out.append((kinds[code & 3], *numbers))
        if code & FC_END:
            out.append(("end",))
            return out


def c_table(figs) -> str:
    """fig_stream: where each figure starts (a byte each, in FIG_* order),
    then the figures' streams; a move is never at index 0, which
    core/figures.c keeps for "no figure"."""
    assert list(figs) == ["FIG_DIAMOND", "FIG_STAR", "FIG_CONE", "FIG_CAR", "FIG_CAR_REV"], \
        "core/figures.h numbers the figures in this order"
    streams = [encode(commands) for commands in figs.values()]
    first, offset = [], len(figs)
    for data in streams:
        first.append(offset)
        offset += len(data)
    assert offset <= 256, "the player indexes fig_stream with a byte"
    lines = ["/* Generated by tools/gen_figures.py from plotter_shapes.geometry. Do not edit. */",
             '#include "figures.h"', "#ifdef PANEL", "", "FIGURE_ROM uint8_t fig_stream[] = {",
             "    " + " ".join(f"{k}," for k in first) + "    /* where each figure starts */"]
    for (name, commands), data in zip(figs.items(), streams):
        lines.append(f"    /* {name}: {len(commands)} commands */")
        for k in range(0, len(data), 16):
            lines.append("    " + " ".join(f"0x{b:02x}," for b in data[k:k + 16]))
    lines += ["};", "", "#endif", ""]
    return "\n".join(lines)


def main(argv):
    figs = all_figures()
    if argv[1:] == ["--json"]:
        json.dump(figs, sys.stdout)
        return
    Path(argv[1]).write_text(c_table(figs))


if __name__ == "__main__":
    main(sys.argv)
