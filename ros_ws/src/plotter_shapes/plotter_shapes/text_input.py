"""Text in Hershey fonts (vpype's single-stroke fonts) to a plotter program."""
from __future__ import annotations

from typing import List

import numpy as np

from plotter_shapes.svg_input import Drawing, Placement, VectorError, drawing_program

DEFAULT_FONT = "futural"


def text_drawing(text: str, font: str = DEFAULT_FONT, size_mm: float = 10.0) -> Drawing:
    """One line of text, size_mm the font size, in vpype's frame (y down)."""
    import vpype as vp
    if font not in vp.FONT_NAMES:
        raise VectorError(f"unknown font {font!r}; one of {', '.join(vp.FONT_NAMES)}")
    if not text.strip() or not text.isprintable():
        raise VectorError("the text must be one line of printable characters")
    if not size_mm > 0:
        raise VectorError(f"size must be a positive number of mm, not {size_mm}")
    lc = vp.text_line(text, font, size=size_mm)
    return Drawing(tuple(np.asarray(line) for line in lc))


def text_program(text: str, font: str = DEFAULT_FONT, size_mm: float = 10.0,
                 placement: Placement = Placement(), feed: float = 1500.0,
                 optimize_paths: bool = False) -> List[str]:
    """G-code that writes the text, centred on placement.centre (placement.width: scale to it)."""
    return drawing_program(text_drawing(text, font, size_mm), placement, 1.0, feed, text, optimize_paths)
