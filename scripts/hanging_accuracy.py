#!/usr/bin/env python3
"""The hanging plotter's accuracy over its work area (docs/hanging-accuracy.md):
draws docs/hanging-accuracy.png and prints the figures the page quotes.

Left, from the machine's geometry: what the board's own steps can add to the
pen's deviation at each place (1.5 pen steps: the staircase and the rounding
of cut points, motion/hanging.py), with the edge of the accurate area for
the tolerance.  Right, measured: the sweep of benchmarks/hanging_sweep.py
compiled as gcode_streamer compiles it and stepped by the firmware core,
the largest deviation of a drawn step in each cell of the work area.

    .venv/bin/python scripts/hanging_accuracy.py [--out docs/hanging-accuracy.png] [--tolerance 0.1]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "ros_ws" / "src" / "plotter_bridge")]

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hanging_sweep import HANGING_AREA, draw_cases, hanging_config, summary, sweep_cases  # noqa: E402
from plotter_bridge.motion.hanging import CHORD_SHARE, board_share, holds, largest_pen_step, string_angle  # noqa: E402

CELL = 50.0          # mm: the measured map's cells


def accurate_top(geometry, x: float, tolerance: float) -> float:
    """The highest Y at x (mm) still in the accurate area, to 0.1 mm."""
    lo, hi = 0.0, geometry.left[1] - 1.0
    while hi - lo > 0.1:
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if holds(geometry, (x, mid), tolerance) else (lo, mid)
    return lo


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(ROOT / "docs" / "hanging-accuracy.png"))
    p.add_argument("--tolerance", type=float, default=0.1, help="mm (gcode_streamer's `tolerance`)")
    args = p.parse_args()
    config = hanging_config(tolerance=args.tolerance)
    g, a, tol = config.hanging, HANGING_AREA, args.tolerance

    # The board's share over the board below the pulleys.
    xs = np.linspace(g.left[0] + 5, g.right[0] - 5, 221)
    ys = np.linspace(-150.0, g.left[1] - 5, 261)
    share = np.array([[board_share(g, (x, y)) for x in xs] for y in ys])
    inside = [(g.pen_step((x, y)), (x, y)) for x in np.linspace(a.x_min, a.x_max, 81)
              for y in np.linspace(a.y_min, a.y_max, 101)]

    # The sweep, every drawn step binned into cells.
    nx, ny = math.ceil((a.x_max - a.x_min) / CELL), math.ceil((a.y_max - a.y_min) / CELL)
    worst_cell = np.full((ny, nx), np.nan)

    def seen(case, px, py, dist):
        i = np.clip(((py - a.y_min) / CELL).astype(int), 0, ny - 1)
        j = np.clip(((px - a.x_min) / CELL).astype(int), 0, nx - 1)
        cell = np.nan_to_num(worst_cell, nan=-1.0)
        np.maximum.at(cell, (i, j), dist)
        worst_cell[:] = np.where(cell < 0, np.nan, cell)

    drawn = draw_cases(sweep_cases(), config, seen=seen)
    worst, where, per_metre = summary(drawn)

    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 6.4), constrained_layout=True)
    vmax = tol
    im = left.pcolormesh(xs, ys, np.minimum(share, vmax), cmap="viridis", vmin=0, vmax=vmax, shading="auto")
    limit = left.contour(xs, ys, share, levels=[(1 - CHORD_SHARE) * tol], colors="red", linewidths=1.5)
    left.clabel(limit, fmt={(1 - CHORD_SHARE) * tol: f"edge of the accurate area ({tol:g} mm)"}, fontsize=8,
                manual=[((a.x_min + a.x_max) / 2, accurate_top(g, (a.x_min + a.x_max) / 2, tol))])
    left.plot([a.x_min, a.x_max, a.x_max, a.x_min, a.x_min], [a.y_min, a.y_min, a.y_max, a.y_max, a.y_min],
              "w--", lw=1.2, label="default work area")
    left.plot([g.left[0], g.right[0]], [g.left[1], g.right[1]], "kv", ms=9, label="pulleys")
    left.set_title("What the board's steps add at each place (mm):\n"
                   "1.5 x the pen's move per motor step, worst direction")
    fig.colorbar(im, ax=left, shrink=0.85, extend="max")
    left.legend(loc="lower center", fontsize=8)

    cmap = plt.get_cmap("magma").copy()
    cmap.set_bad("lightgrey")                     # a cell no drawn step reached
    im2 = right.imshow(worst_cell, origin="lower", cmap=cmap, vmin=0, vmax=tol,
                       extent=(a.x_min, a.x_min + nx * CELL, a.y_min, a.y_min + ny * CELL))
    right.set_title(f"Measured on the firmware core: largest deviation of a drawn\n"
                    f"step per {CELL:g} mm cell, {len(drawn)} circles and lines (mm)")
    fig.colorbar(im2, ax=right, shrink=0.85)
    for ax in (left, right):
        ax.set_aspect("equal")
        ax.set_xlabel("X mm")
        ax.set_ylabel("Y mm")
    out = Path(args.out)
    fig.savefig(out, dpi=90)
    print(f"picture: {out}")
    print(f"machine: pulleys X{g.left[0]:g} Y{g.left[1]:g}, X{g.right[0]:g} Y{g.right[1]:g}; "
          f"{g.steps_per_mm:.2f} steps per mm of string; tolerance {tol:g} mm")
    for word, (step, (x, y)) in (("smallest", min(inside)), ("largest", max(inside))):
        print(f"{word} pen step in the default work area: {step:.4f} mm at X{x:g} Y{y:g} (strings at "
              f"{string_angle(g, (x, y)):.0f} degrees), board's share {board_share(g, (x, y)):.4f} mm")
    print(f"the accurate area allows a pen step up to {largest_pen_step(tol):.4f} mm")
    tops = ", ".join(f"X{x:g} Y{accurate_top(g, x, tol):.0f}" for x in (a.x_min, (a.x_min + a.x_max) / 2, a.x_max))
    print(f"top of the accurate area: {tops}")
    print(f"sweep: {len(drawn)} cases, {sum(d.case.length for d in drawn) / 1000:.1f} m drawn, worst "
          f"{worst:.4f} mm at X{where.where[0]:.1f} Y{where.where[1]:.1f} ({where.case.name}), "
          f"{per_metre:.1f} board lines per metre")
    return 0


if __name__ == "__main__":
    sys.exit(main())
