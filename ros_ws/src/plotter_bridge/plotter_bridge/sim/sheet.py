"""A virtual sheet for line following: black lines of one width on white
paper, and the three reflective sensors round the pen that read it.

The lines are polylines in machine millimetres: a G-code file's pen-down
moves (`from_gcode`), or an SVG drawing placed as `plotter svg` places it
(plotter_shapes.svg_input.sheet_lines).  A sensor reads black when its spot
is within half the line's width of a line's centre.

The firmware's steering (firmware/core/follow.h) asks for a line wider than
the sensors' ring (`SensorRing.min_width_mm`): with the pen on the line's
centre all three sensors then read black, and one that reads white says
which way the pen has drifted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import List, Sequence, Tuple

from plotter_bridge.gcode.polylines import SegmentGrid, program_polylines

Point = Tuple[float, float]


class SheetError(ValueError):
    """A sheet or sensor geometry that cannot be followed."""


@dataclass(frozen=True)
class SensorRing:
    """The sensors' spots round the pen: at radius_mm from it, at these
    angles (degrees, counter-clockwise from +X).  The firmware's steering is
    written for the seed's three sensors 120 degrees apart, the first at +Y."""
    radius_mm: float = 3.0
    angles_deg: Tuple[float, float, float] = (90.0, 210.0, 330.0)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.radius_mm) and self.radius_mm > 0):
            raise SheetError(f"sensor radius must be a positive number of mm, not {self.radius_mm}")
        if len(self.angles_deg) != 3 or not all(math.isfinite(a) for a in self.angles_deg):
            raise SheetError(f"three sensor angles in degrees, not {self.angles_deg}")

    @property
    def min_width_mm(self) -> float:
        """The narrowest line the steering follows: wider than the ring, so
        that with the pen on its centre every sensor is on black."""
        return 2.0 * self.radius_mm

    def spots(self, x: float, y: float) -> List[Point]:
        r = self.radius_mm
        return [(x + r * math.cos(math.radians(a)), y + r * math.sin(math.radians(a))) for a in self.angles_deg]


class Sheet:
    """Black lines of width_mm along these polylines (mm)."""

    def __init__(self, lines: Sequence[Sequence[Point]], width_mm: float) -> None:
        if not (math.isfinite(width_mm) and width_mm > 0):
            raise SheetError(f"line width must be a positive number of mm, not {width_mm}")
        self.lines = [[(float(x), float(y)) for x, y in line] for line in lines if len(line) >= 2]
        if not self.lines:
            raise SheetError("the sheet has no lines")
        self.width_mm = width_mm
        self._grid = SegmentGrid(self.lines, cell=max(0.5, width_mm / 2))  # the smallest exact for black()

    @classmethod
    def from_gcode(cls, path: str, width_mm: float) -> "Sheet":
        """The pen-down moves of a G-code file as the sheet's lines."""
        lines = program_polylines(Path(path).read_text())
        if not lines:
            raise SheetError(f"{path}: no pen-down moves to make lines of")
        return cls(lines, width_mm)

    def black(self, p: Point) -> bool:
        return self._grid.near(p, self.width_mm / 2)

    def sensor_bits(self, x: float, y: float, ring: SensorRing) -> int:
        """The sensors' bits with the pen at (x, y) mm: bit i set when sensor i is on black."""
        bits = 0
        for i, spot in enumerate(ring.spots(x, y)):
            if self.black(spot):
                bits |= 1 << i
        return bits

    def sensor_bits_from(self, start_mm: Point, steps: Tuple[int, int], steps_per_mm: float, ring: SensorRing) -> int:
        """The sensors' bits with the pen `steps` (a board's count) from the sheet's point start_mm."""
        return self.sensor_bits(start_mm[0] + steps[0] / steps_per_mm, start_mm[1] + steps[1] / steps_per_mm, ring)

    def check_ring(self, ring: SensorRing) -> None:
        if self.width_mm <= ring.min_width_mm:
            raise SheetError(f"a line {self.width_mm:g} mm wide is too narrow for sensors {ring.radius_mm:g} mm "
                             f"from the pen: it must be wider than {ring.min_width_mm:g} mm")
