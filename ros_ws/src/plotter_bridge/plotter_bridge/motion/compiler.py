"""A G-code program compiled to board commands, before anything moves.

Parsing, the work-area check and the conversion to steps and board commands
all happen here, completely, so that a bad program is refused whole.
"""
from __future__ import annotations

import math
from array import array
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

from .commands import (FIRMWARE_ACCEL, MAX_ARC_RATE, MAX_RATE, BoardCommand, cartesian_motion, iter_commands,
                       z_axis_motion)
from plotter_bridge.link.command_store import CommandStore
from plotter_bridge.link.protocol import DEFAULT_BAUD, PEN_CHANGE
from plotter_bridge.gcode.dialect import (DEFAULT_MARLIN_PEN_DOWN, DEFAULT_MARLIN_PEN_UP, DEFAULT_PEN_UP_Z,
                                          LINUXCNC, GCodeOptions)
from plotter_bridge.gcode.arcfit import FitConfig, iter_fit_arcs
from plotter_bridge.gcode.parser import Reading, decode_program, read_items
from plotter_bridge.gcode.limits import WorkArea, within_limits
from plotter_bridge.gcode.pens import iter_park_for_changes
from plotter_bridge.gcode.steps import MAX_OFFSET, iter_steps
from plotter_bridge.gcode.types import GCodeError, Item, Move, ToolChange
from .hanging import hanging_motion
from .kinematics import DEFAULT_Z_STEPS_PER_MM, HangingGeometry, check_z
from .planner import BOARD_CPU, LINK_SHARE, BoardCpu, PlannerLimits, iter_cap_for_link, iter_plan

MAX_PROGRAM_BYTES = 64 * 1024 * 1024   # a 20 MB drawing of a million short lines fits three times
LINE_WIRE_BYTES = 27     # a short line command on the wire (benchmarks/RESULTS.md: 27.3-27.7 a command)


@dataclass(frozen=True)
class StreamerConfig:
    steps_per_mm: float = 80.0
    rapid_feed: float = 6000.0
    area: WorkArea = WorkArea()
    acceleration: float = 1000.0       # mm/s^2
    junction_deviation: float = 0.05   # mm
    lookahead: bool = True             # False: stop at the end of every command
    machine: str = "cartesian"         # or "hanging" (seed 003's two-string plotter)
    hanging: HangingGeometry = HangingGeometry()
    tolerance: float = 0.1             # hanging: largest pen deviation from the path, mm
    link_baud: int = 0                 # > 0: slow commands down to what a link of this baud can feed
    link_seq: int = -1                 # link_baud: the first command's sequence number on the wire (-1: unknown)
    z_mode: str = "pen"                # G-code Z: the pen, or "axis": a third axis (firmware ZAXIS=1)
    z_steps_per_mm: float = DEFAULT_Z_STEPS_PER_MM   # z_mode axis: steps per mm of Z
    dialect: str = LINUXCNC            # G-code dialect: linuxcnc, grbl or marlin (gcode/dialect.py)
    pen_up_z: float = DEFAULT_PEN_UP_Z                # z_mode pen: Z above this lifts the pen
    marlin_pen_down: float = DEFAULT_MARLIN_PEN_DOWN  # marlin: M300 S<angle> that lowers the pen
    marlin_pen_up: float = DEFAULT_MARLIN_PEN_UP      # marlin: M300 S<angle> that lifts it
    fit_arcs: bool = True              # runs of drawn chords on a circle or a line go as one arc or line
    arc_tolerance: float = 0.02        # fit_arcs: the fitted path's greatest distance from the chords (mm)
    board_cpu: bool = True             # link_baud: also slow commands down to what the board's CPU parses
    park: Optional[Tuple[float, float]] = (0.0, 0.0)  # where the pen waits at a pen change (None: where it is)

    def __post_init__(self) -> None:
        check_z(self.z_mode, self.z_steps_per_mm)
        self.gcode_options()  # a bad dialect or angle is refused when the node starts

    def gcode_options(self) -> GCodeOptions:
        return GCodeOptions(self.dialect, self.pen_up_z, self.marlin_pen_down, self.marlin_pen_up)

    def motor_steps_per_mm(self) -> float:
        return self.hanging.steps_per_mm if self.machine == "hanging" else self.steps_per_mm

    def limits(self) -> PlannerLimits:
        """Planner limits in the board's units, inside what its ramp can do."""
        k = self.motor_steps_per_mm()
        return PlannerLimits(min(self.acceleration * k, 0.8 * FIRMWARE_ACCEL), self.junction_deviation * k)


def arc_pays(steps_per_mm: float, link_baud: int,
             cpu: Optional[BoardCpu] = BOARD_CPU) -> Callable[[Sequence[Move], Move], bool]:
    """Whether an arc draws a run of chords no slower than the chords themselves on this board.

    The board steps an arc at most MAX_ARC_RATE (its interrupt's cost, firmware/README.md) and a line
    at MAX_RATE; a chord also waits for its bytes on the link (link_baud, 0: the board's default).
    Each at its feed, as fast as those allow (the ramps aside), and no faster than the board's CPU
    parses and plans them (`cpu`, BoardCpu: a command costs its main loop about 20 ms): the arc is taken
    when it is not slower, which for short chords is nearly always, at any baud."""
    bytes_per_s = (link_baud or DEFAULT_BAUD) / 10.0 * LINK_SHARE

    def pays(chords: Sequence[Move], arc: Move) -> bool:
        length = sum(math.dist((m.sx, m.sy), (m.x, m.y)) for m in chords)
        steps = steps_per_mm * sum(abs(m.x - m.sx) + abs(m.y - m.sy) for m in chords)
        by_feed = length / (arc.feed / 60.0)
        as_arc = max(by_feed, steps / MAX_ARC_RATE)
        as_chords = max(by_feed, steps / MAX_RATE, len(chords) * LINE_WIRE_BYTES / bytes_per_s)
        if cpu is not None:
            as_arc = max(as_arc, cpu.time(steps, arc=True))
            as_chords = max(as_chords, len(chords) * cpu.time(steps / len(chords), arc=False))
        return as_arc <= as_chords
    return pays


def board_fit(tolerance: float, area: Optional[WorkArea], steps_per_mm: float, link_baud: int = 0,
              cpu: Optional[BoardCpu] = BOARD_CPU) -> FitConfig:
    """The arc fit for this board: no flatter arcs than it takes in one command (they would go as
    chords again, gcode/steps.py), and no arc where the chords draw faster (arc_pays)."""
    return FitConfig(tolerance=tolerance, area=area, max_radius=MAX_OFFSET / steps_per_mm,
                     arc_pays=arc_pays(steps_per_mm, link_baud, cpu))


def compile_program(text: str, config: StreamerConfig,
                    start_steps: Tuple[int, int] = (0, 0), start_z_steps: int = 0) -> List[BoardCommand]:
    """G-code text to board commands for a pen now at start_steps (and, with
    z_mode axis, a Z axis at start_z_steps); raises GCodeError naming the line (GCodeErrors, every
    refused line of the program at once)."""
    return compile_job(text, config, start_steps, start_z_steps)[1]


@dataclass
class CompiledJob:
    """A program's board commands as few objects as they can be: a million-line job is one text and
    an array of their source lines, not a million command objects."""
    texts: CommandStore                # each command as sent (BoardCommand.text)
    lines: "array[int]"                # the program's line each comes from
    pens: List[str]                    # what each pen change ("M6 k") tells the operator, in order
    z_line: Optional[int] = None       # the first Z command's line (None: no Z axis needed)


def compile_texts(text: Union[str, bytes], config: StreamerConfig, start_steps: Tuple[int, int] = (0, 0),
                  start_z_steps: int = 0) -> CompiledJob:
    """compile_program, kept as CompiledJob: each command is planned and formatted as the program is
    read, so that no stage holds more of the program than its own window (iter_plan, iter_fit_arcs);
    the program is still refused whole, before anything of it is sent."""
    lines = array("I")              # uint32, as StreamCommands.lines: the goal takes it as it is
    pens: List[str] = []
    z_line: List[int] = []

    def texts() -> Iterator[str]:
        for cmd in compile_stream(text, config, start_steps, start_z_steps):
            lines.append(cmd.line)
            if cmd.verb == PEN_CHANGE:
                pens.append(cmd.note)
            elif not z_line and cmd.verb == "Z":
                z_line.append(cmd.line)
            yield cmd.text
    return CompiledJob(CommandStore(texts()), lines, pens, z_line[0] if z_line else None)


def compile_stream(text: Union[str, bytes], config: StreamerConfig, start_steps: Tuple[int, int] = (0, 0),
                   start_z_steps: int = 0, observe: Optional[Callable[[Item], None]] = None) -> Iterator[BoardCommand]:
    """compile_program one command at a time.  The program's refusals are known only when it has been
    read to its end, so the GCodeError comes after the last command: a caller sends nothing before.
    `observe` sees each item (compile_job's) as it goes on to become commands."""
    reading, outside, park = Reading(), [], []
    checked = _checked_items(text, config, start_steps, start_z_steps, reading, outside)
    items = _board_items(checked, config, park)
    if observe is not None:
        items = _observed(items, observe)
    try:
        yield from _commands(items, config)
    except (GCodeError, ValueError):
        for _ in checked:            # a later stage's complaint about a line the reading refuses
            pass
        if not reading.errors and not outside:
            raise
    for _ in checked:
        pass
    _raise_refusals(reading, outside, park)


def _observed(items: Iterable[Item], observe: Callable[[Item], None]) -> Iterator[Item]:
    for item in items:
        observe(item)
        yield item


def compile_job(text: str, config: StreamerConfig, start_steps: Tuple[int, int] = (0, 0),
                start_z_steps: int = 0) -> Tuple[List[Item], List[BoardCommand]]:
    """compile_program, with the program's items as they were turned into the commands
    (the park travel added, arcs fitted; machine mm): what a preview draws."""
    reading, outside, park = Reading(), [], []
    items = list(_checked_items(text, config, start_steps, start_z_steps, reading, outside))
    _raise_refusals(reading, outside, [])
    items = list(_board_items(items, config, park))
    _raise_refusals(reading, outside, park)
    return items, list(_commands(items, config))


def _checked_items(text: Union[str, bytes], config: StreamerConfig, start_steps: Tuple[int, int],
                   start_z_steps: int, reading: Reading, outside: List[GCodeError]) -> Iterator[Item]:
    if isinstance(text, str) and text.isascii():
        size, source = len(text), text           # as it is: no copies of a big program to read it
    else:
        data = text.encode("utf-8", "surrogateescape") if isinstance(text, str) else text
        size, source = len(data), None
    if size > MAX_PROGRAM_BYTES:
        raise GCodeError(0, f"program too large: {size} bytes (limit {MAX_PROGRAM_BYTES})")
    if source is None:
        source = decode_program(data)
    if config.machine == "hanging":
        start = config.hanging.forward(start_steps)
    else:
        start = (start_steps[0] / config.steps_per_mm, start_steps[1] / config.steps_per_mm)
    items = read_items(source, reading, rapid_rate=config.rapid_feed, start=start,
                       z_axis=config.z_mode == "axis", start_z=start_z_steps / config.z_steps_per_mm,
                       options=config.gcode_options())
    return within_limits(items, config.area, outside) if config.area is not None else items


def _raise_refusals(reading: Reading, outside: List[GCodeError], park: List[GCodeError]) -> None:
    reading.raise_errors(outside)
    if park:
        raise park[0]


def _board_items(items: Iterable[Item], config: StreamerConfig, park: List[GCodeError]) -> Iterator[Item]:
    """The checked items as the board draws them: the travel to the park position and back around each
    pen change, runs of chords fitted as arcs.  A park position outside the work area is put in `park`."""
    def parked(items: Iterable[Item]) -> Iterator[Item]:
        for item in items:
            if isinstance(item, ToolChange) and item.wait and not park and config.park is not None \
                    and config.area is not None and not config.area.contains(*config.park):
                park.append(GCodeError(item.line, f"pen change: the pen would wait at the park position "
                                                  f"X{config.park[0]:g} Y{config.park[1]:g}, outside the work area"))
            yield item

    items = iter_park_for_changes(parked(items), config.park)
    if config.fit_arcs and config.machine == "cartesian":
        # (the hanging machine's moves go as short lines whatever they were)
        items = iter_fit_arcs(items, board_fit(config.arc_tolerance, config.area, config.motor_steps_per_mm(),
                                               config.link_baud, BOARD_CPU if config.board_cpu else None))
    return items


def _commands(items: Iterable[Item], config: StreamerConfig) -> Iterator[BoardCommand]:
    z_motion = z_axis_motion(config.z_steps_per_mm) if config.z_mode == "axis" else None
    if config.machine == "hanging":
        commands = iter_commands(items, hanging_motion(config.hanging, config.tolerance), config.rapid_feed,
                                 z_motion)
    else:
        commands = iter_commands(iter_steps(items, config.steps_per_mm),
                                 cartesian_motion(config.steps_per_mm), config.rapid_feed, z_motion)
    if config.link_baud > 0:
        commands = iter_cap_for_link(commands, config.link_baud / 10.0,
                                     first_seq=None if config.link_seq < 0 else config.link_seq,
                                     cpu=BOARD_CPU if config.board_cpu else None)
    return iter_plan(commands, config.limits()) if config.lookahead else commands
