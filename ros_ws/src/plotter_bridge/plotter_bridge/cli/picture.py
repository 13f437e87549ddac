"""Pictures of what the plotter drew: SVG or PNG, drawn with matplotlib.

What was drawn comes either from the mock board's step trace or from the
bridge's reported positions. The trace has no pen column, so there a step
counts as drawn when it lies within a tolerance of the programmed path and
as pen-up travel otherwise (``runs_near_path``); reported positions carry the
pen state (``runs_by_pen``). The programmed path (the figures, or the pen-down
moves of a G-code program) is drawn underneath in another colour, on axes in
millimetres over the work area.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, List, Sequence, Tuple

# program_polylines is this module's too for its callers (cli/run.py, the web page's jobs).
from plotter_bridge.gcode.polylines import Point, Polyline, SegmentGrid, arc_points, program_polylines  # noqa: F401

DRAWN_COLOUR = "black"
PROGRAMMED_COLOUR = "#8ec5ff"
TRAVEL_COLOUR = "#999999"
FORMATS = ("svg", "png")


@dataclass(frozen=True)
class Run:
    """Consecutive pen positions, all drawn (pen down) or all travel."""
    drawn: bool
    points: Tuple[Point, ...]


@dataclass(frozen=True)
class Area:
    """The axes' extent in mm."""
    x_min: float = 0.0
    x_max: float = 200.0
    y_min: float = 0.0
    y_max: float = 200.0

    def including(self, points: Iterable[Point], margin: float = 5.0) -> "Area":
        """This area grown to show every point."""
        pts = list(points)
        if not pts:
            return self
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        grow = lambda v, limit, out: v if not out else v + (-margin if v < limit else margin)  # noqa: E731
        return Area(min(self.x_min, grow(min(xs), self.x_min, min(xs) < self.x_min)),
                    max(self.x_max, grow(max(xs), self.x_max, max(xs) > self.x_max)),
                    min(self.y_min, grow(min(ys), self.y_min, min(ys) < self.y_min)),
                    max(self.y_max, grow(max(ys), self.y_max, max(ys) > self.y_max)))


# --- programmed paths ---------------------------------------------------------------

def segment_points(seg) -> Polyline:
    """A plotter_shapes Line or Arc as a polyline (mm)."""
    if hasattr(seg, "cx"):
        return arc_points(seg.x0, seg.y0, seg.x1, seg.y1, seg.cx, seg.cy, seg.cw)
    return [(seg.x0, seg.y0), (seg.x1, seg.y1)]


def figure_polylines(figure) -> List[Polyline]:
    """The strokes of a plotter_shapes Figure as polylines (mm)."""
    out = []
    for stroke in figure.strokes:
        pts: Polyline = []
        for seg in stroke.segments:
            pts.extend(segment_points(seg)[1 if pts else 0:])
        out.append(pts)
    return out


# --- what was drawn ------------------------------------------------------------------

def _thin(points: Iterable[Point], spacing: float) -> List[Point]:
    """Every point at least `spacing` (taxicab) from the one kept before it, and the last."""
    out: List[Point] = []
    last = None
    for p in points:
        if last is not None and abs(p[0] - last[0]) + abs(p[1] - last[1]) < spacing:
            continue
        out.append(p)
        last = p
    return out


def _split(flags_points: Iterable[Tuple[bool, Point]]) -> List[Run]:
    """Runs of equal flags; the piece between a travel point and a drawn one is travel."""
    runs: List[Tuple[bool, List[Point]]] = []
    for drawn, p in flags_points:
        if runs and runs[-1][0] == drawn:
            runs[-1][1].append(p)
        elif runs and drawn:
            runs[-1][1].append(p)
            runs.append((True, [p]))
        else:
            runs.append((drawn, ([runs[-1][1][-1]] if runs else []) + [p]))
    return [Run(d, tuple(pts)) for d, pts in runs]


def runs_near_path(trace_mm: Iterable[Point], programmed: Sequence[Polyline],
                   tol_mm: float = 0.05, spacing_mm: float = 0.2) -> List[Run]:
    """Trace points (every spacing_mm) split into drawn (on the programmed path) and travel."""
    grid = SegmentGrid(programmed)
    return _split((grid.near(p, tol_mm), p) for p in _thin(trace_mm, spacing_mm))


def runs_by_pen(samples: Iterable[Tuple[float, float, bool]]) -> List[Run]:
    """Reported positions (x_mm, y_mm, pen_down) split by the pen state."""
    return _split((bool(down), (x, y)) for x, y, down in samples)


# --- the picture ---------------------------------------------------------------------

def picture_format(path: str) -> str:
    """'svg' or 'png' from the file name; ValueError otherwise."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        raise ValueError(f"{path}: a picture is .svg or .png")
    return suffix


def _joined(polylines: Iterable[Sequence[Point]]) -> Tuple[List[float], List[float]]:
    """Polylines as one x list and one y list, broken by NaN (one artist for all)."""
    xs: List[float] = []
    ys: List[float] = []
    for line in polylines:
        if len(line) < 2:
            continue
        if xs:
            xs.append(math.nan)
            ys.append(math.nan)
        xs.extend(p[0] for p in line)
        ys.extend(p[1] for p in line)
    return xs, ys


def draw(runs: Sequence[Run], programmed: Sequence[Polyline], area: Area = Area(),
         title: str = "plotter", scale_px_per_mm: float = 4.0):
    """A matplotlib Figure: programmed path light blue, drawn path black, travel dashed grey.

    The axes are in mm with equal scale; the drawn lines have the gid
    'drawn', the travel 'travel' and the programmed path 'programmed' (the
    ids of their groups in an SVG).
    """
    from matplotlib.lines import Line2D

    every = [p for line in programmed for p in line] + [p for r in runs for p in r.points]
    fig, ax = _axes(every, area, title, scale_px_per_mm)
    ax.plot(*_joined(programmed), color=PROGRAMMED_COLOUR, linewidth=4.5, solid_capstyle="round",
            solid_joinstyle="round", gid="programmed", snap=False)
    ax.plot(*_joined(r.points for r in runs if r.drawn), color=DRAWN_COLOUR, linewidth=1.1,
            gid="drawn", snap=False)
    ax.plot(*_joined(r.points for r in runs if not r.drawn), color=TRAVEL_COLOUR, linewidth=0.8,
            linestyle=(0, (4, 3)), gid="travel", snap=False)
    handles = [Line2D([], [], color=PROGRAMMED_COLOUR, linewidth=4.5, label="programmed"),
               Line2D([], [], color=DRAWN_COLOUR, linewidth=1.1, label="drawn"),
               Line2D([], [], color=TRAVEL_COLOUR, linewidth=0.8, linestyle=(0, (4, 3)), label="pen-up travel")]
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def _axes(points: Sequence[Point], area: Area, title: str, scale_px_per_mm: float = 4.0):
    """A matplotlib Figure and its axes in mm over the area grown to hold the points."""
    from matplotlib.figure import Figure
    area = area.including(points)
    w_mm, h_mm = area.x_max - area.x_min, area.y_max - area.y_min
    dpi = 100.0
    margin_px = 60.0
    # Room on the left for the Y tick labels ("-110" is wider than "200") and the Y label beside them.
    digits = max(len(f"{area.y_min:.0f}"), len(f"{area.y_max:.0f}"))
    left_px = 36.0 + 9.0 * digits
    w_px, h_px = w_mm * scale_px_per_mm + left_px + margin_px, h_mm * scale_px_per_mm + 2 * margin_px
    fig = Figure(figsize=(w_px / dpi, h_px / dpi), dpi=dpi)
    ax = fig.add_axes((left_px / w_px, margin_px / h_px, 1 - (left_px + margin_px) / w_px, 1 - 2 * margin_px / h_px))
    ax.set_xlim(area.x_min, area.x_max)
    ax.set_ylim(area.y_min, area.y_max)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, color="#eeeeee", linewidth=0.8)
    ax.set_axisbelow(True)
    return fig, ax


def draw_preview(preview, area: Area = Area(), title: str = "plotter"):
    """A matplotlib Figure of a job's plan (motion/preview.py Preview): each pen's paths in its colour
    (gid layer-1, layer-2, ...), the pen-up travel dashed grey (gid travel), the figures in the title."""
    from matplotlib.lines import Line2D
    every = [p for layer in preview.layers for line in layer.lines for p in line] + \
        [p for line in preview.travel for p in line]
    fig, ax = _axes(every, area, f"{title}\n{preview.summary()}")
    ax.title.set_fontsize(9)
    ax.plot(*_joined(preview.travel), color=TRAVEL_COLOUR, linewidth=0.8, linestyle=(0, (4, 3)), gid="travel",
            snap=False)
    handles = []
    for k, layer in enumerate(preview.layers, start=1):
        ax.plot(*_joined(layer.lines), color=layer.colour, linewidth=1.3, gid=f"layer-{k}", snap=False)
        handles.append(Line2D([], [], color=layer.colour, linewidth=1.3,
                              label=f"{k}: {layer.name} ({layer.length_mm:.0f} mm)"))
    handles.append(Line2D([], [], color=TRAVEL_COLOUR, linewidth=0.8, linestyle=(0, (4, 3)),
                          label=f"pen-up travel ({preview.travel_mm:.0f} mm)"))
    ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    return fig


def write_picture(path: str, runs: Sequence[Run], programmed: Sequence[Polyline],
                  area: Area = Area(), title: str = "plotter") -> None:
    """Write the picture as SVG or PNG (from the file name's suffix)."""
    save(lambda: draw(runs, programmed, area, title), path)


def write_preview(path: str, preview, area: Area = Area(), title: str = "plotter") -> None:
    """Write a job's preview (draw_preview) as SVG or PNG."""
    save(lambda: draw_preview(preview, area, title), path)


def save(make_figure, path: str) -> None:
    """The figure make_figure() draws, as SVG or PNG (from the file name's suffix), the same file for
    the same input.  The figure is drawn inside the settings: a line takes path.simplify when it is
    made, and a simplified path would drop the trace's points."""
    from matplotlib import rc_context
    fmt = picture_format(path)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    metadata = {"Date": None} if fmt == "svg" else {"Software": "plotter"}
    # Same input, same file: fixed ids in the SVG, text kept as text; every point kept.
    with rc_context({"svg.hashsalt": "plotter", "svg.fonttype": "none", "path.simplify": False}):
        make_figure().savefig(path, format=fmt, metadata=metadata)


def mm_to_pixel(fig, p: Point) -> Tuple[float, float]:
    """Where a point in mm lands in the image (pixels from the top left)."""
    ax = fig.axes[0]
    ax.apply_aspect()
    x, y = ax.transData.transform(p)
    return float(x), float(fig.bbox.height - y)
