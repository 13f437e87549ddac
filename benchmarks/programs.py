"""The programs the benchmark draws, as G-code, and their board commands.

- the seed figures exactly as shape_server writes them for the demo's
  placement (scripts/demo.py), at the default feed;
- a dense polyline: an Archimedean spiral of about 1 mm chords;
- a staircase of short strokes with right-angle corners, where every
  corner brakes to the junction rule;
- polygons of equal short chords around a circle for the link: every
  command the same length and duration, turning so little at each corner
  that the junction rule never slows them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Sequence, Tuple

from plotter_bridge.motion.commands import BoardCommand
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from plotter_shapes.geometry import SEED_FIGURES, goal_program

from bound import Item, Move, Wait

PEN_DELAY_S = 0.150          # the board's $3 at power-on


@dataclass(frozen=True)
class Program:
    name: str
    gcode: str


def figure_programs() -> List[Program]:
    out = []
    for fig in SEED_FIGURES:
        name, lines = goal_program(fig["shape"], fig["x"], fig["y"], fig["size"],
                                   fig.get("clockwise", False), fig.get("reverse", False))
        out.append(Program(name, "\n".join(lines) + "\n"))
    return out


def spiral_program(segments: int = 2000, chord_mm: float = 1.0, feed: float = 6000.0,
                   centre: Tuple[float, float] = (100.0, 100.0), r0: float = 5.0,
                   r1: float = 90.0) -> Program:
    """An Archimedean spiral from radius r0 to about r1 in `segments` chords of chord_mm."""
    # r = r0 + b * theta; its length up to theta is about (r0 + r) / 2 * theta.
    theta_end = segments * chord_mm / ((r0 + r1) / 2)
    b = (r1 - r0) / theta_end
    cx, cy = centre
    lines = ["(spiral)", "G21 G90", "M5", f"G0 X{cx + r0:.4f} Y{cy:.4f}", "M3"]
    theta = 0.0
    for _ in range(segments):
        theta += chord_mm / (r0 + b * theta)
        r = r0 + b * theta
        lines.append(f"G1 X{cx + r * math.cos(theta):.4f} Y{cy + r * math.sin(theta):.4f} F{feed:g}")
    lines += ["M5", "M2"]
    return Program(f"spiral {segments} x {chord_mm:g} mm", "\n".join(lines) + "\n")


def staircase_program(segments: int = 160, step_mm: float = 2.0, feed: float = 6000.0,
                      start: Tuple[float, float] = (20.0, 20.0)) -> Program:
    """Alternating +X and +Y strokes of step_mm: a right-angle corner after each."""
    x, y = start
    lines = ["(staircase)", "G21 G90", "M5", f"G0 X{x:.4f} Y{y:.4f}", "M3"]
    for k in range(segments):
        if k % 2:
            y += step_mm
        else:
            x += step_mm
        lines.append(f"G1 X{x:.4f} Y{y:.4f} F{feed:g}")
    lines += ["M5", "M2"]
    return Program(f"staircase {segments} x {step_mm:g} mm", "\n".join(lines) + "\n")


def polygon_program(segments: int, chord_mm: float, feed: float, radius: float = 80.0,
                    centre: Tuple[float, float] = (100.0, 100.0)) -> Program:
    """`segments` chords of chord_mm on a circle (going round again if needed)."""
    cx, cy = centre
    step = 2 * math.asin(chord_mm / (2 * radius))
    lines = ["G21 G90", "M5", f"G0 X{cx + radius:.4f} Y{cy:.4f}", "M3"]
    for k in range(1, segments + 1):
        a = k * step
        lines.append(f"G1 X{cx + radius * math.cos(a):.4f} Y{cy + radius * math.sin(a):.4f} F{feed:g}")
    lines += ["M5", "M2"]
    return Program(f"{segments} x {chord_mm:g} mm at F{feed:g}", "\n".join(lines) + "\n")


def _chords(name: str, points: Sequence[Tuple[float, float]], feed: float) -> Program:
    x0, y0 = points[0]
    lines = [f"({name})", "G21 G90", "M5", f"G0 X{x0:.4f} Y{y0:.4f}", "M3"]
    lines += [f"G1 X{x:.4f} Y{y:.4f} F{feed:g}" for x, y in points[1:]]
    lines += ["M5", "M2"]
    return Program(name, "\n".join(lines) + "\n")


def _resample(curve, t_end: float, chord_mm: float, samples: int = 200000) -> List[Tuple[float, float]]:
    """Points along a parametric curve about chord_mm apart (by arc length), both ends kept."""
    pts = [curve(t_end * k / samples) for k in range(samples + 1)]
    out, run = [pts[0]], 0.0
    for a, b in zip(pts, pts[1:]):
        run += math.dist(a, b)
        if run >= chord_mm:
            out.append(b)
            run = 0.0
    if out[-1] != pts[-1]:
        out.append(pts[-1])
    return out


def spirograph_program(chord_mm: float = 1.0, feed: float = 6000.0, centre: Tuple[float, float] = (100.0, 100.0),
                       big: float = 50.0, small: float = 30.0, pen: float = 20.0) -> Program:
    """A hypotrochoid (spirograph) as chords of about chord_mm: curvature changing all the way."""
    cx, cy = centre
    k = (big - small) / small
    turns = small / math.gcd(int(big), int(small))

    def curve(t: float) -> Tuple[float, float]:
        return (cx + (big - small) * math.cos(t) + pen * math.cos(k * t),
                cy + (big - small) * math.sin(t) - pen * math.sin(k * t))
    return _chords(f"spirograph, {chord_mm:g} mm chords", _resample(curve, 2 * math.pi * turns, chord_mm), feed)


def lissajous_program(chord_mm: float = 1.0, feed: float = 6000.0, centre: Tuple[float, float] = (100.0, 100.0),
                      a: float = 60.0, b: float = 45.0) -> Program:
    """A 3:4 Lissajous figure as chords of about chord_mm: inflections and crossings."""
    cx, cy = centre

    def curve(t: float) -> Tuple[float, float]:
        return cx + a * math.sin(3 * t + math.pi / 4), cy + b * math.sin(4 * t)
    return _chords(f"Lissajous 3:4, {chord_mm:g} mm chords", _resample(curve, 2 * math.pi, chord_mm), feed)


CHORDS = StreamerConfig(fit_arcs=False)


def compile_for(program: Program, start_steps: Tuple[int, int], lookahead: bool = True,
                config: StreamerConfig = CHORDS) -> List[BoardCommand]:
    """Board commands as gcode_streamer makes them for a pen at start_steps, with its chords as
    written (fit_arcs off: the programs here measure the link and the planner)."""
    from dataclasses import replace
    return compile_program(program.gcode, replace(config, lookahead=lookahead), start_steps)


def bound_items(commands: Sequence[BoardCommand], pen_delay_s: float = PEN_DELAY_S) -> List[Item]:
    """What the bound needs to know of a command list: lengths, cruise rates,
    directions, and how long the board stands still for pens and dwells."""
    items: List[Item] = []
    for c in commands:
        if c.is_motion:
            items.append(Move(c.steps, float(c.rate), c.dir_in, c.dir_out))
        elif c.verb == "P":
            items.append(Wait(pen_delay_s))
        elif c.verb == "D":
            items.append(Wait(c.args[0] / 1000.0))
    return items


def motion_count(commands: Sequence[BoardCommand]) -> int:
    return sum(1 for c in commands if c.is_motion)
