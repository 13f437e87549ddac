"""Vector drawings (SVG) to plotter figures, with vpype.

vpype reads the file (every shape and curve flattened to polylines), scales
and places it, and with ``optimize`` merges paths that meet (``linemerge``)
and orders them to shorten the pen-up travel (``linesort``). Its polylines
are then turned back into lines and circular arcs: the circles and circular
arcs of the input (read with svgelements, the parser vpype itself uses) are
carried through the same transform, and a run of polyline points lying on
one of them, turning steadily one way, becomes one arc (G2/G3 in the
program) instead of hundreds of short lines. Cubic and quadratic curves,
elliptical arcs and the strokes of Hershey text become circular arcs and
lines fitted to vpype's points within ARC_TOLERANCE_MM (gcode/arcfit.py, the
fit the streamer applies to chords): each arc passes through points of the
curve and strays from it by less than a step, so a curve goes to the board
as a few arcs, not hundreds of chords its 9600-baud link cannot feed.

A drawing in several pens keeps its layers (read_layers): Inkscape's layers
(top-level groups with inkscape:groupmode="layer", as vpype's
read_multilayer_svg reads them), or else one layer per stroke colour (vpype's
read_svg_by_attributes on "stroke", equal colours together).  Each layer is
drawn whole, optimised within itself, and between two layers the program
has a pen change, ``T<k> M6 (layer <k> "<name>" #rrggbb)``: the job waits
there with the pen up for the next pen (plotter_bridge/gcode/pens.py).  The
first layer's M6, before anything is drawn, only names the first pen.  All
layers are placed together, as one drawing.

Coordinates here are millimetres in the plotter's frame (+y away from the
operator, where SVG's +y points down); vpype's documents are in CSS pixels
(96 per inch) until scaled.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

PX_PER_MM = 96.0 / 25.4
QUANTIZATION_PX = 0.1          # vpype's flattening step when reading
SIMPLIFY_MM = 0.002            # polyline simplification before fitting: fewer points, no shape lost
ARC_TOLERANCE_MM = 0.01        # fitted arcs and lines within this of the curve (with SIMPLIFY_MM): under a step
FIT_MAX_RADIUS_MM = 400.0      # flatter is a line: the board's arcs reach 32767 steps (409 mm at 80 steps/mm)
MERGE_MM = 0.05                # paths whose ends are this close are joined (optimize)
MAX_ARC_STEP = 0.35            # rad between polyline points taken as one arc
MIN_ARC_RADIUS_MM = 0.1


class VectorError(ValueError):
    """A drawing that cannot be turned into a program."""


@dataclass(frozen=True)
class Circle:
    centre: complex
    radius: float


@dataclass(frozen=True)
class Placement:
    """Scale and place a drawing: width in mm (None: its own size), centre in mm."""
    width: Optional[float] = None
    centre: Tuple[float, float] = (100.0, 100.0)


@dataclass(frozen=True)
class Drawing:
    """Polylines (complex numpy arrays, mm, plotter frame) and the circles they may follow."""
    lines: Tuple[np.ndarray, ...]
    circles: Tuple[Circle, ...] = ()


@dataclass(frozen=True)
class Layer:
    """One pen's part of a drawing: its number in the file (from 1), name and colour (#rrggbb or "")."""
    number: int
    name: str
    colour: str
    drawing: Drawing

    def describe(self) -> str:
        return f"{self.number} {self.name!r}" + (f" {self.colour}" if self.colour else "")


# --- reading ------------------------------------------------------------------------------

def svg_circles(path: str) -> List[Circle]:
    """Circles and circular arcs of an SVG file, in vpype's pixel frame (transforms applied)."""
    import svgelements as se
    found = {}
    for element in se.SVG.parse(path).elements():
        if not isinstance(element, se.Shape):
            continue
        for seg in se.Path(element).segments():
            if isinstance(seg, se.Arc) and seg.center is not None and \
                    math.isclose(seg.rx, seg.ry, rel_tol=1e-9, abs_tol=1e-9) and seg.rx > 0:
                c = Circle(complex(seg.center.x, seg.center.y), float(seg.rx))
                found[(round(c.centre.real, 6), round(c.centre.imag, 6), round(c.radius, 6))] = c
    return list(found.values())


def read_svg(path: str) -> Drawing:
    """The file's paths as vpype reads them, and its circles (pixels, SVG frame)."""
    import vpype as vp
    try:
        lc, _, _ = vp.read_svg(path, quantization=QUANTIZATION_PX, crop=False)
    except Exception as exc:  # svgelements/xml errors: a file that is not an SVG drawing
        raise VectorError(f"{path}: cannot read as SVG: {exc}") from exc
    return Drawing(tuple(np.asarray(line) for line in lc), tuple(svg_circles(path)))


def _colour(metadata: dict) -> str:
    color = metadata.get("vp_color")
    return f"#{color.red:02x}{color.green:02x}{color.blue:02x}" if color is not None else ""


def _mentions(path: str, pattern: bytes) -> bool:
    import re
    with open(path, "rb") as f:
        return re.search(pattern, f.read()) is not None


# What may hold a circle or a circular arc (svg_circles): a file without any has none to look for.
_ROUND_SHAPES = rb"<(?:\w+:)?(?:circle|ellipse|rect)\b|\sd\s*=\s*[\"'][^\"']*[Aa]"
_INKSCAPE_LAYER = rb"groupmode\s*=\s*[\"']layer"


def read_layers(path: str) -> List[Layer]:
    """The file's layers in file order: its Inkscape layers, or else its stroke colours (one layer
    when it has a single colour).  The file is parsed once for each of these it may have (a big
    drawing takes svgelements seconds and hundreds of MB to parse), and once for its circles."""
    import vpype as vp
    try:
        circles = tuple(svg_circles(path)) if _mentions(path, _ROUND_SHAPES) else ()
        if _mentions(path, _INKSCAPE_LAYER):
            doc = vp.read_multilayer_svg(path, quantization=QUANTIZATION_PX, crop=False)
            layers = [lc for lc in doc.layers.values() if not lc.is_empty()]
            if len(layers) > 1 and any(lc.metadata.get("svg_inkscape_groupmode") == "layer" for lc in layers):
                return [Layer(k, str(lc.metadata.get("vp_name") or f"layer {k}"), _colour(lc.metadata),
                              Drawing(tuple(np.asarray(line) for line in lc), circles))
                        for k, lc in enumerate(layers, start=1)]
            del doc, layers
        by_stroke = vp.read_svg_by_attributes(path, ["stroke"], quantization=QUANTIZATION_PX, crop=False)
    except Exception as exc:  # svgelements/xml errors: a file that is not an SVG drawing
        raise VectorError(f"{path}: cannot read as SVG: {exc}") from exc
    colours: dict = {}
    names: dict = {}
    for lc in by_stroke.layers.values():
        colour = _colour(lc.metadata)
        colours.setdefault(colour, []).extend(np.asarray(line) for line in lc)
        names.setdefault(colour, str(lc.metadata.get("svg_stroke") or colour or "no colour"))
    if len(colours) <= 1:
        lines = tuple(next(iter(colours.values()), ()))
        return [Layer(1, "drawing", next(iter(colours), ""), Drawing(lines, circles))]
    return [Layer(k, names[colour], colour, Drawing(tuple(lines), circles))
            for k, (colour, lines) in enumerate(colours.items(), start=1)]


def order_layers(layers: Sequence[Layer], order: Optional[Sequence[int]]) -> List[Layer]:
    """The layers to draw: all in file order, or those numbered in `order`, in that order."""
    if not order:
        return list(layers)
    by_number = {layer.number: layer for layer in layers}
    bad = [f"{n} is not a layer" for n in order if n not in by_number]
    bad += [f"{n} is given twice" for k, n in enumerate(order) if n in order[:k]]
    if bad:
        raise VectorError(f"layers {','.join(map(str, order))}: {'; '.join(dict.fromkeys(bad))} (the file's layers: "
                          f"{', '.join(layer.describe() for layer in layers)})")
    return [by_number[n] for n in order]


def parse_layer_order(text: str) -> List[int]:
    """--layers 2,1: layer numbers, in the order to draw them."""
    try:
        numbers = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise VectorError(f"--layers {text!r}: give layer numbers separated by commas, e.g. 2,1") from None
    if not numbers:
        raise VectorError(f"--layers {text!r}: no layer numbers")
    return numbers


# --- scaling, placing, merging, sorting (vpype) ------------------------------------------------

def _transform(d: Drawing, scale: float, offset: complex) -> Drawing:
    """Scale, flip y (SVG down to plotter up) and translate, polylines and circles alike."""
    import vpype as vp
    lc = vp.LineCollection(list(d.lines))
    lc.scale(scale, -scale)
    lc.translate(offset.real, offset.imag)
    circles = tuple(Circle(complex(c.centre.real * scale, -c.centre.imag * scale) + offset, c.radius * scale)
                    for c in d.circles)
    return Drawing(tuple(np.asarray(line) for line in lc), circles)


def place(d: Drawing, placement: Placement, units_per_mm: float) -> Drawing:
    """In mm, width placement.width (or natural size), bounding box centred on placement.centre."""
    scale, offset = placing(d.lines, placement, units_per_mm)
    return _transform(Drawing(tuple(line for line in d.lines if len(line) >= 2), d.circles), scale, offset)


def placing(all_lines: Sequence[np.ndarray], placement: Placement, units_per_mm: float) -> Tuple[float, complex]:
    """The scale and offset that place these polylines (place)."""
    lines = [line for line in all_lines if len(line) >= 2]
    if not lines:
        raise VectorError("the drawing has no paths")
    pts = np.concatenate(lines)
    x0, x1, y0, y1 = pts.real.min(), pts.real.max(), pts.imag.min(), pts.imag.max()
    natural = (x1 - x0) / units_per_mm
    if placement.width is not None:
        if not (math.isfinite(placement.width) and placement.width > 0):
            raise VectorError(f"width must be a positive number of mm, not {placement.width}")
        if natural <= 0:
            raise VectorError("the drawing has no width to scale")
    scale = (placement.width / (x1 - x0)) if placement.width is not None else 1.0 / units_per_mm
    mid = complex((x0 + x1) / 2 * scale, -(y0 + y1) / 2 * scale)
    return scale, complex(*placement.centre) - mid


def optimize(d: Drawing) -> Drawing:
    """vpype's linemerge and linesort: fewer pen lifts, shorter travel."""
    import vpype as vp
    import vpype_cli
    doc = vp.Document(vp.LineCollection(list(d.lines)))
    doc = vpype_cli.execute(f"linemerge --tolerance {MERGE_MM} linesort", doc)
    return Drawing(tuple(np.asarray(line) for line in doc.layers[1]), d.circles)


# --- polylines back to lines and arcs --------------------------------------------------------------

def _on_circle(p: complex, c: Circle) -> bool:
    return abs(abs(p - c.centre) - c.radius) <= 1e-6 * max(1.0, c.radius)


def _arc_run(pts: Sequence[complex], i: int, c: Circle) -> Tuple[int, float]:
    """Last index j of points i..j on circle c turning one way in small steps, and the sweep."""
    j, sweep, sign = i, 0.0, 0.0
    while j + 1 < len(pts) and _on_circle(pts[j + 1], c):
        step = cmath.phase((pts[j + 1] - c.centre) / (pts[j] - c.centre))
        if abs(step) > MAX_ARC_STEP or step == 0.0 or (sign and math.copysign(1.0, step) != sign) \
                or abs(sweep + step) > 2 * math.pi + 1e-9:
            break
        sign = math.copysign(1.0, step)
        sweep += step
        j += 1
    return j, sweep


def split_arcs(pts: Sequence[complex], circles: Sequence[Circle]) -> list:
    """A polyline as plotter_shapes Arcs where its points follow a circle, and lists of the
    points between them (each list at least two points, sharing its ends with its neighbours)."""
    from plotter_shapes.geometry import Arc
    pts = [complex(p) for k, p in enumerate(pts) if k == 0 or p != pts[k - 1]]
    pieces: list = []
    run: List[complex] = [pts[0]] if pts else []
    i = 0
    while i + 1 < len(pts):
        best = (i, 0.0, None)
        for c in circles:
            if c.radius >= MIN_ARC_RADIUS_MM and _on_circle(pts[i], c):
                j, sweep = _arc_run(pts, i, c)
                if j - i >= 3 and j > best[0]:
                    best = (j, sweep, c)
        j, sweep, c = best
        if c is None:
            run.append(pts[i + 1])
            i += 1
            continue
        a = pts[i]
        full = abs(abs(sweep) - 2 * math.pi) < 1e-6
        end = a if full else pts[j]
        # the end exactly on the start's radius, so the arc is consistent to the last bit
        end = c.centre + (end - c.centre) * (abs(a - c.centre) / abs(end - c.centre))
        if len(run) >= 2:
            pieces.append(run)
        pieces.append(Arc(a.real, a.imag, end.real, end.imag, c.centre.real, c.centre.imag, sweep < 0))
        pts[j] = end
        run = [end]
        i = j
    if len(run) >= 2:
        pieces.append(run)
    return pieces


def fitted_segments(points: Sequence[complex]) -> list:
    """A polyline of a curve as plotter_shapes Lines and Arcs within ARC_TOLERANCE_MM of it."""
    from plotter_bridge.gcode.arcfit import FitConfig, fit_polyline
    from plotter_shapes.geometry import Arc, Line
    pts = [(p.real, p.imag) for p in points]
    config = FitConfig(tolerance=ARC_TOLERANCE_MM - SIMPLIFY_MM, max_radius=FIT_MAX_RADIUS_MM)
    segs: list = []
    for first, last, centre, cw in fit_polyline(pts, config):
        (x0, y0), (x1, y1) = pts[first], pts[last]
        if centre is None:
            if (x0, y0) != (x1, y1):
                segs.append(Line(x0, y0, x1, y1))
        else:
            segs.append(Arc(x0, y0, x1, y1, centre[0], centre[1], bool(cw)))
    return segs


def to_figure(d: Drawing, name: str = ""):
    """The drawing as a plotter_shapes Figure, one stroke per polyline: arcs where it follows
    a circle of the input, arcs and lines fitted to the rest (simplified by vpype's linesimplify
    first, which only drops points)."""
    import vpype as vp
    import vpype_cli
    from plotter_shapes.geometry import Figure, Stroke
    split = [split_arcs(list(line), d.circles) for line in d.lines]
    runs = [piece for pieces in split for piece in pieces if isinstance(piece, list)]
    if runs:
        doc = vpype_cli.execute(f"linesimplify --tolerance {SIMPLIFY_MM}",
                                vp.Document(vp.LineCollection([np.array(r) for r in runs])))
        simplified = iter([list(line) for line in doc.layers[1]])
        assert len(doc.layers[1]) == len(runs)
    strokes = []
    for pieces in split:
        segs: list = []
        for piece in pieces:
            if isinstance(piece, list):
                segs += fitted_segments(next(simplified))
            else:
                segs.append(piece)
        if segs:
            strokes.append(Stroke(tuple(segs)))
    if not strokes:
        raise VectorError("the drawing has no paths")
    return Figure(tuple(strokes), name)


def drawing_program(d: Drawing, placement: Placement, units_per_mm: float, feed: float,
                    name: str, optimize_paths: bool = False) -> List[str]:
    """G-code for a drawing: placed, optionally merged and sorted, arcs kept, lines simplified."""
    from plotter_shapes.geometry import figure_to_gcode
    placed = place(d, placement, units_per_mm)
    if optimize_paths:
        placed = optimize(placed)
    return figure_to_gcode(to_figure(placed, name), feed, name)


def layers_program(layers: Sequence[Layer], placement: Placement, units_per_mm: float, feed: float,
                   name: str, optimize_paths: bool = False, whole: Sequence[Layer] = ()) -> List[str]:
    """G-code for layers placed as the drawing of all of `whole` (default: these layers) is placed,
    so that some of its layers land where they are in the whole; each optimised within itself,
    with a pen change (T<k> M6 and a comment naming the layer) before every layer after the first."""
    from plotter_shapes.geometry import figure_to_gcode
    whole = whole or layers
    if len(whole) == 1:
        return drawing_program(layers[0].drawing, placement, units_per_mm, feed, name, optimize_paths)
    scale, offset = placing([line for layer in whole for line in layer.drawing.lines], placement, units_per_mm)
    out: List[str] = []
    for k, layer in enumerate(layers, start=1):
        placed = _transform(Drawing(tuple(line for line in layer.drawing.lines if len(line) >= 2),
                                    layer.drawing.circles), scale, offset)
        if optimize_paths:
            placed = optimize(placed)
        program = figure_to_gcode(to_figure(placed, name), feed, name)
        body = program[program.index("G21 G90") + 1:-2]          # its strokes, without header and M5 M2
        label = "".join(ch for ch in layer.name if ch.isprintable() and ch not in "()")[:60]
        # The first layer's M6 names the pen in the holder (no stop): a preview shows its colour.
        out += program[:program.index("G21 G90") + 1] if k == 1 else ["M5"]
        out += [f"T{k} M6 (layer {layer.number} \"{label}\"{' ' + layer.colour if layer.colour else ''})"]
        out += body
    return out + ["M5", "M2"]


def svg_program(path: str, placement: Placement = Placement(), feed: float = 1500.0,
                optimize_paths: bool = False, order: Optional[Sequence[int]] = None) -> List[str]:
    """G-code that draws an SVG file, layer by layer with pen changes between (read_layers)."""
    layers = read_layers(path)
    return layers_program(order_layers(layers, order), placement, PX_PER_MM, feed, path, optimize_paths, layers)


def sheet_lines(path: str) -> List[List[Tuple[float, float]]]:
    """An SVG file's paths as polylines in machine mm, placed as `plotter svg` places a drawing by default
    (its own size, centred on (100, 100)): the black lines of a sheet for `plotter follow`."""
    placed = place(read_svg(path), Placement(), PX_PER_MM)
    return [[(float(p.real), float(p.imag)) for p in line] for line in placed.lines]
