"""What the page sends to be drawn, checked before anything moves.

An uploaded file is G-code or an SVG drawing; either becomes a G-code
program, checked the way the streamer checks it (the parser, then the work
area from where the pen is), with every refused line and its text, and
a preview of its pen-down path for the page, and the plan (motion/preview.py:
each pen's paths in its colour, the pen-up travel, the lengths and the
board's time, as the streamer with its defaults would plan it).  Jog moves and shapes are
checked the same way.  No ROS here: the node sends what passes to the
streamer, which checks it once more against the board.
"""
from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.gcode.parser import decode_program, program_name
from plotter_bridge.motion.compiler import MAX_PROGRAM_BYTES
from plotter_bridge.gcode.types import GCodeError, all_errors
from plotter_bridge.link.protocol import DEFAULT_BAUD

MAX_UPLOAD = MAX_PROGRAM_BYTES    # bytes: what the streamer takes
JOG_STEPS = (0.1, 1.0, 10.0)      # mm, the page's jog buttons
Point = Tuple[float, float]


@dataclass
class Checked:
    """A job as the page shows it before it runs."""
    name: str
    program: str = ""                                        # G-code, "" when the file could not be read
    errors: List[dict] = field(default_factory=list)         # {"line", "message", "text"}; line 0: the file
    preview: List[List[Point]] = field(default_factory=list)  # pen-down polylines, mm
    plan: Optional[dict] = None                               # motion/preview.py Preview.as_json()

    @property
    def ok(self) -> bool:
        return bool(self.program) and not self.errors

    def as_json(self) -> dict:
        # the plan has the pen-down paths too, each pen's in its colour: the page draws these without one
        preview = [] if self.plan else self.preview
        return {"name": self.name, "ok": self.ok, "errors": self.errors, "lines": self.program.count("\n"),
                "preview": [[[round(x, 3), round(y, 3)] for x, y in line] for line in preview],
                "plan": self.plan}


def is_svg(filename: str, data: bytes) -> bool:
    head = data.lstrip()[:200].lower()
    return filename.lower().endswith(".svg") or head.startswith(b"<?xml") or head.startswith(b"<svg")


def svg_to_program(data: bytes, name: str, area: WorkArea, width: Optional[float], feed: float,
                   layers: str = "", optimize: bool = False) -> str:
    """An SVG drawing placed in the middle of the work area, as G-code: its layers in file order, or
    those numbered in `layers` ("3,1", as `plotter svg --layers`) in that order; with `optimize` each
    layer's paths merged and sorted."""
    from plotter_shapes.svg_input import Placement, parse_layer_order, svg_program
    order = parse_layer_order(layers) if layers.strip() else None
    centre = ((area.x_min + area.x_max) / 2, (area.y_min + area.y_max) / 2)
    fd, path = tempfile.mkstemp(suffix=".svg")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        lines = svg_program(path, Placement(width, centre), feed, optimize, order)
    finally:
        os.unlink(path)
    return "\n".join([f"({name})", *[line for line in lines if not line.startswith("(")]]) + "\n"


def check_program(text: str, name: str, area: WorkArea, start: Point, steps_per_mm: float = 80.0,
                  link_baud: int = DEFAULT_BAUD) -> Checked:
    """Check a G-code program for a pen now at `start` (mm) and plan it, in one reading of it: the
    streamer's compiler, with the work area; the paths within motion/preview.py's budget of points."""
    from plotter_bridge.motion.compiler import StreamerConfig
    from plotter_bridge.motion.preview import preview_program
    job = Checked(name, text)
    try:
        config = StreamerConfig(steps_per_mm, area=area, link_baud=link_baud)
        plan = preview_program(text, config, (round(start[0] * steps_per_mm), round(start[1] * steps_per_mm)))
        job.preview = [line for layer in plan.layers for line in layer.lines]
        job.plan = plan.as_json()
    except GCodeError as exc:
        lines = text.splitlines()
        for error in all_errors(exc):
            source = lines[error.line - 1].strip() if 0 < error.line <= len(lines) else ""
            job.errors.append({"line": error.line, "message": error.message, "text": source[:120]})
    return job


def check_upload(filename: str, data: bytes, area: WorkArea, start: Point,
                 width: Optional[float] = None, feed: float = 1500.0, link_baud: int = DEFAULT_BAUD,
                 layers: str = "", optimize: bool = False) -> Checked:
    """An uploaded file, read and checked; `layers` and `optimize` (svg_to_program) for an SVG drawing."""
    name = os.path.basename(filename or "upload")[:80] or "upload"
    if len(data) > MAX_UPLOAD:
        return Checked(name, errors=[{"line": 0, "message": f"file too large: {len(data)} bytes "
                                                            f"(limit {MAX_UPLOAD})", "text": ""}])
    if is_svg(filename, data):
        from plotter_shapes.svg_input import VectorError
        try:
            text = svg_to_program(data, name, area, width, feed, layers, optimize)
        except (VectorError, ValueError) as exc:
            return Checked(name, errors=[{"line": 0, "message": str(exc).replace(tempfile.gettempdir(), ""),
                                          "text": ""}])
    else:
        try:
            text = decode_program(data)
        except GCodeError as exc:
            return Checked(name, errors=[{"line": exc.line, "message": exc.message, "text": ""}])
        name = program_name(text, name)
    return check_program(text, name, area, start, link_baud=link_baud)


def jog_program(dx: float, dy: float) -> str:
    """A pen-up move by (dx, dy) mm from where the pen is."""
    if not all(math.isfinite(v) and abs(v) <= max(JOG_STEPS) for v in (dx, dy)) or (dx, dy) == (0, 0):
        raise ValueError(f"jog by ({dx}, {dy}) mm: each of X and Y at most {max(JOG_STEPS):g} mm, not both 0")
    return f"(jog)\nG21 G91\nG0 X{dx:.4f} Y{dy:.4f}\nG90\nM2\n"


def journal_jobs(journal, limit: int) -> List[dict]:
    """The newest `limit` jobs of a journal (link/journal.py job_summaries) as the page lists them."""
    from plotter_bridge.link.journal import job_summaries
    return [{"id": j.job_id, "name": j.name, "when": j.when, "state": j.state, "completed": j.completed,
             "total": j.total, "resumable": j.resumable,
             "note": j.note(id_chars=8)}            # the page is narrow: the id's first 8 characters
            for j in job_summaries(journal, limit)]
