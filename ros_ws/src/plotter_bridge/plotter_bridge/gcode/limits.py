"""Soft limits: check that a parsed program stays inside the work area."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Iterator, List, Optional

from .types import GCodeError, GCodeErrors, Item, Move, ZMove
from .geometry import arc_extreme_points

# Points this close outside the area (mm) still count as inside: rounding noise.
LIMIT_EPSILON = 1e-9


@dataclass(frozen=True)
class WorkArea:
    """Reachable area in mm, in machine coordinates from the power-on origin;
    z_min..z_max is the travel of a Z axis (ZMove items; a pen has none)."""

    x_min: float = 0.0
    x_max: float = 200.0
    y_min: float = 0.0
    y_max: float = 200.0
    z_min: float = -50.0
    z_max: float = 50.0

    def contains(self, x: float, y: float) -> bool:
        return (self.x_min - LIMIT_EPSILON <= x <= self.x_max + LIMIT_EPSILON
                and self.y_min - LIMIT_EPSILON <= y <= self.y_max + LIMIT_EPSILON)

    def describe(self) -> str:
        return (f"X {self.x_min:g}..{self.x_max:g} mm, "
                f"Y {self.y_min:g}..{self.y_max:g} mm")


def check_limits(items: Iterable[Item], limits: WorkArea = WorkArea()) -> None:
    """Raise GCodeErrors naming every line whose move leaves the work area
    (or the Z axis' travel)."""
    errors = limit_errors(items, limits)
    if errors:
        raise GCodeErrors(errors)


def limit_error(item: Item, limits: WorkArea) -> Optional[str]:
    """Why a move leaves the work area (or the Z axis' travel), or None (see limit_errors)."""
    if isinstance(item, ZMove) and not (limits.z_min - LIMIT_EPSILON <= item.z <= limits.z_max + LIMIT_EPSILON):
        return f"Z move to Z{item.z:.4f} is outside the Z axis' travel (Z {limits.z_min:g}..{limits.z_max:g} mm)"
    if not isinstance(item, Move):
        return None
    if not limits.contains(item.x, item.y):
        return f"move to X{item.x:.4f} Y{item.y:.4f} is outside the work area ({limits.describe()})"
    if item.kind != "arc":
        return None
    for px, py in arc_extreme_points((item.sx, item.sy), (item.x, item.y), (item.cx, item.cy), bool(item.cw)):
        if not limits.contains(px, py):
            return f"arc leaves the work area at X{px:.4f} Y{py:.4f} ({limits.describe()})"
    return None


def within_limits(items: Iterable[Item], limits: WorkArea, errors: List[GCodeError]) -> Iterator[Item]:
    """The items, unchanged, one at a time; a GCodeError added to `errors` for each line with a move
    that leaves the work area, for its first such move."""
    refused = None
    for item in items:
        why = limit_error(item, limits)
        if why is not None and item.line != refused:
            errors.append(GCodeError(item.line, why))
            refused = item.line
        yield item


def limit_errors(items: Iterable[Item], limits: WorkArea = WorkArea()) -> List[GCodeError]:
    """One GCodeError for each line with a move that leaves the work area (or
    the Z axis' travel), for its first such move.

    Lines are checked at their end points (each start is the previous end, or
    the origin); arcs at their end points and at the extreme points of the
    quadrants they cross, so an arc bulging outside is caught even when both
    its ends are inside.
    """
    errors: List[GCodeError] = []
    for _ in within_limits(items, limits, errors):
        pass
    return errors
