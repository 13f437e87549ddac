"""G-code made by the generators plotter users already use, from our own SVGs.

tests/data/corpus/svg/ holds the drawings (shapes, curves, text). Each CASE
is one program: which generator made it from which drawing with which
settings, the dialect and pen rule it needs, and how far from the drawing
the generator may put the path (its tolerance, mm).

- vpype-gcode and svg-to-gcode install from the package index with the
  project (requirements.txt): their programs are made in the tests.
- svg2gcode (a Rust program, built with cargo) and Inkscape's gcodetools
  (Debian's inkscape) take minutes to build or install: their programs are
  committed in tests/data/corpus/generated/ with VERSIONS.txt, and
  ``python tests/generator_corpus.py`` makes them again (see its --help).
  It also remakes svg/text.svg (vpype's Hershey font) and svg/paths/, the
  drawings with every shape turned into a path by Inkscape (gcodetools and
  svg-to-gcode read only paths).

No ROS.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

CORPUS = Path(__file__).resolve().parent / "data" / "corpus"
SVG_DIR = CORPUS / "svg"
PATHS_DIR = SVG_DIR / "paths"
GENERATED = CORPUS / "generated"
VPYPE_PROFILES = CORPUS / "vpype-gcode.toml"
DRAWINGS = ("shapes", "curves", "text")
INKSCAPE_EXTENSIONS = Path("/usr/share/inkscape/extensions")
SVG2GCODE = "svg2gcode"            # cargo install svg2gcode-cli --version 0.0.18 --locked


@dataclass(frozen=True)
class Case:
    name: str                     # the program's file name
    drawing: str                  # the SVG it is made from (svg/NAME.svg)
    generator: str                # vpype-gcode, svg-to-gcode, svg2gcode, gcodetools
    settings: str                 # the vpype-gcode profile, or a word for the settings below
    dialect: str = "linuxcnc"
    tolerance: float = 0.05       # mm: the generator's own tolerance (curves to lines or arcs)
    pen_up_z: float = 0.0
    marlin_pen: Tuple[float, float] = (30.0, 50.0)
    refused: Optional[Tuple[int, str]] = None   # (line, reason) when the plotter must refuse it
    arguments: Tuple[str, ...] = field(default=(), compare=False)   # the generator's own arguments

    @property
    def committed(self) -> bool:
        return self.generator in ("svg2gcode", "gcodetools")

    def check_args(self) -> List[str]:
        """The plotter check / stream options the program needs."""
        return ["--dialect", self.dialect, "--pen-up-z", f"{self.pen_up_z:g}",
                "--marlin-pen", *(f"{a:g}" for a in self.marlin_pen)]


# vpype reads curves into segments at most this long (vpype read --quantization, mm); the
# tests allow the sagitta of such a segment on a curve of 1 mm radius, q^2 / 8 mm = 0.011 mm.
VPYPE_QUANTIZATION = 0.3
VPYPE_TOLERANCE = VPYPE_QUANTIZATION ** 2 / 8
# svg2gcode: --tolerance, curves to lines and arcs.
SVG2GCODE_TOLERANCE = 0.02
# gcodetools: biarc tolerance (mm in a mm document) of curves to arcs.
GCODETOOLS_TOLERANCE = 0.05
# ... which it keeps only down to this depth of splitting a curve (its default, 4, stops short).
GCODETOOLS_SPLIT_DEPTH = 10
GCODETOOLS_FEED = 3000.0          # mm/min: the tool's feed (its default cutter has 400)
# svg-to-gcode: TOLERANCES["approximation"], curves to lines, set before it runs.
SVG_TO_GCODE_TOLERANCE = 0.02

_SVG2GCODE_SETTINGS = {
    # grbl servo or laser: power word on, M5 off; G2/G3 where the drawing has arcs
    "grbl": ("grbl", ["--on", "M3 S1000", "--off", "M5", "--circular-interpolation", "true"]),
    # the pen servo of the Marlin/MakerBot lineage, with its 150 ms settling dwell
    "marlin": ("marlin", ["--on", "M300 S30\nG4 P150", "--off", "M300 S50\nG4 P150",
                          "--circular-interpolation", "false"]),
}


def cases() -> List[Case]:
    out: List[Case] = []
    for drawing in DRAWINGS:
        tol = VPYPE_TOLERANCE + 0.001   # the profiles print 3 decimals
        out += [Case(f"{drawing}.vpype-grbl.gcode", drawing, "vpype-gcode", "plotter_grbl", "grbl", tol),
                Case(f"{drawing}.vpype-laser.gcode", drawing, "vpype-gcode", "plotter_laser", "grbl", tol),
                Case(f"{drawing}.vpype-marlin.gcode", drawing, "vpype-gcode", "plotter_marlin", "marlin", tol),
                Case(f"{drawing}.vpype-z.gcode", drawing, "vpype-gcode", "plotter_z", "linuxcnc", tol),
                Case(f"{drawing}.vpype-z-high.gcode", drawing, "vpype-gcode", "plotter_z_high", "linuxcnc", tol,
                     pen_up_z=2.5),
                Case(f"{drawing}.vpype-inch.gcode", drawing, "vpype-gcode", "plotter_inch", "linuxcnc",
                     VPYPE_TOLERANCE + 0.0001 * 25.4)]
        for settings, (dialect, arguments) in _SVG2GCODE_SETTINGS.items():
            out.append(Case(f"{drawing}.svg2gcode-{settings}.gcode", drawing, "svg2gcode", settings, dialect,
                            SVG2GCODE_TOLERANCE + 1e-6, arguments=tuple(arguments)))
        out.append(Case(f"{drawing}.gcodetools.ngc", drawing, "gcodetools", "default", "linuxcnc",
                        GCODETOOLS_TOLERANCE + 1e-5))
        if drawing != "curves":   # svg-to-gcode 1.5.4 puts a relative s after an s at the wrong point
            out.append(Case(f"{drawing}.svg-to-gcode.gcode", drawing, "svg-to-gcode", "laser", "grbl",
                            SVG_TO_GCODE_TOLERANCE + 1e-5))
    # vpype-gcode's own profiles: written for machines without a pen, or with homing switches ($H).
    # (Its "ninja" profile homes with G28 and lowers its pen by raising Z: tests/test_generator_corpus.py.)
    out += [Case("shapes.vpype-gcodemm.gcode", "shapes", "vpype-gcode", "gcodemm",
                 refused=(5, "no feed rate for G1")),
            Case("shapes.vpype-gcode.gcode", "shapes", "vpype-gcode", "gcode", "grbl",
                 refused=(5, "no feed rate for G1")),
            Case("shapes.vpype-step_motor.gcode", "shapes", "vpype-gcode", "step_motor", "grbl",
                 refused=(1, "grbl's homing cycle $H is refused"))]
    return out


CASES = cases()


# --------------------------------------------------------------- the drawings

def text_svg() -> str:
    """svg/text.svg: "Plot 20" in vpype's futural Hershey font, as paths, 60 x 30 mm."""
    import vpype as vp
    lc = vp.text_line("Plot 20", "futural", size=10.0)
    x0, y0, x1, y1 = lc.bounds()
    scale = 52.0 / (x1 - x0)
    paths = []
    for line in lc:
        pts = [((p.real - x0) * scale + 4.0, (p.imag - y0) * scale + 8.0) for p in line]
        paths.append("    <path d=\"M " + " L ".join(f"{x:.4f} {y:.4f}" for x, y in pts) + "\"/>")
    return ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            "<!-- \"Plot 20\" in vpype's futural Hershey font (tests/generator_corpus.py text_svg), 60 x 30 mm. -->\n"
            "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:inkscape=\"http://www.inkscape.org/namespaces/inkscape\"\n"
            "     width=\"60mm\" height=\"30mm\" viewBox=\"0 0 60 30\">\n"
            "  <g inkscape:groupmode=\"layer\" inkscape:label=\"drawing\" id=\"drawing\" fill=\"none\" "
            "stroke=\"black\" stroke-width=\"0.3\">\n" + "\n".join(paths) + "\n  </g>\n</svg>\n")


def reference_polylines(drawing: str, quantization: float = 0.005) -> List[List[Tuple[float, float]]]:
    """The drawing's paths as polylines in plotter mm: the SVG's mm with y up from the page's bottom."""
    import vpype as vp
    px_per_mm = 96.0 / 25.4
    lc, _width, height = vp.read_svg(str(SVG_DIR / f"{drawing}.svg"), quantization=quantization * px_per_mm)
    page_height = height / px_per_mm
    return [[(p.real / px_per_mm, page_height - p.imag / px_per_mm) for p in line] for line in lc]


# --------------------------------------------------------------- the generators

def vpype_gcode(case: Case, out: Path) -> None:
    """vpype read -> gwrite with the case's profile (vpype-gcode)."""
    subprocess.run([str(Path(sys.executable).parent / "vpype"), "--config", str(VPYPE_PROFILES),
                    "read", "--quantization", f"{VPYPE_QUANTIZATION}mm", str(SVG_DIR / f"{case.drawing}.svg"),
                    "gwrite", "--profile", case.settings, str(out)],
                   check=True, capture_output=True, text=True, timeout=300)


def svg_to_gcode(case: Case, out: Path) -> None:
    """svg-to-gcode's laser compiler: M3 S255 on, M5 off, G1 with the feed."""
    from svg_to_gcode import TOLERANCES
    from svg_to_gcode.compiler import Compiler, interfaces
    from svg_to_gcode.svg_parser import parse_file
    TOLERANCES["approximation"] = SVG_TO_GCODE_TOLERANCE
    compiler = Compiler(interfaces.Gcode, movement_speed=6000, cutting_speed=6000, pass_depth=0)
    compiler.append_curves(parse_file(str(PATHS_DIR / f"{case.drawing}.svg")))
    compiler.compile_to_file(str(out), passes=1)


def svg2gcode(case: Case, out: Path) -> None:
    subprocess.run([SVG2GCODE, str(SVG_DIR / f"{case.drawing}.svg"), "--feedrate", "6000",
                    "--tolerance", f"{SVG2GCODE_TOLERANCE}", *case.arguments, "-o", str(out)],
                   check=True, capture_output=True, text=True, timeout=300)


def gcodetools(case: Case, out: Path) -> None:
    """Inkscape's gcodetools run as Inkscape runs an extension (its script, the options,
    the SVG): Tools library adds a cylinder cutter, its feed is set as a user edits
    that text in the drawing, then Path to Gcode."""
    script = INKSCAPE_EXTENSIONS / "other" / "gcodetools" / "gcodetools.py"
    env = dict(os.environ, PYTHONPATH=str(INKSCAPE_EXTENSIONS))

    def run(*args: str) -> str:
        return subprocess.run(["/usr/bin/python3", str(script), *args], check=True, capture_output=True,
                              text=True, timeout=300, stdin=subprocess.DEVNULL, env=env).stdout

    with tempfile.TemporaryDirectory() as tmp:
        with_tool = run("--active-tab=tools_library", "--tools-library-type=cylinder cutter",
                        str(PATHS_DIR / f"{case.drawing}.svg"))
        with_tool, edits = re.subn(r"(>feed</tspan></text><text[^>]*><tspan[^>]*>)400(</tspan>)",
                                   rf"\g<1>{GCODETOOLS_FEED:g}\g<2>", with_tool)
        assert edits == 1, "gcodetools' tool definition has changed: no feed field"
        drawing = Path(tmp) / "drawing.svg"
        drawing.write_text(with_tool)
        # What Inkscape passes for the defaults of the Path to Gcode dialog, the biarc fit aside.
        run("--active-tab=path-to-gcode", f"--directory={tmp}", "--filename=out.ngc",
            "--add-numeric-suffix-to-filename=false", "--unit=G21 (All units in mm)",
            "--path-to-gcode-depth-function=d", f"--biarc-tolerance={GCODETOOLS_TOLERANCE}",
            f"--biarc-max-split-depth={GCODETOOLS_SPLIT_DEPTH}", "--postprocessor= ", str(drawing))
        shutil.copy(Path(tmp) / "out.ngc", out)


GENERATORS = {"vpype-gcode": vpype_gcode, "svg-to-gcode": svg_to_gcode, "svg2gcode": svg2gcode,
              "gcodetools": gcodetools}


def program(case: Case, workdir: Path) -> Path:
    """The case's program: the committed file, or made now by its generator in workdir."""
    if case.committed:
        return GENERATED / case.name
    out = workdir / case.name
    if not out.exists():
        GENERATORS[case.generator](case, out)
    return out


# --------------------------------------------------------------- regeneration

def _version(command: Sequence[str]) -> str:
    proc = subprocess.run(list(command), capture_output=True, text=True, check=False)
    return (proc.stdout or proc.stderr).strip().splitlines()[0] if (proc.stdout or proc.stderr).strip() else "?"


def regenerate(only: Sequence[str] = ()) -> None:
    """Make svg/text.svg, svg/paths/ and the committed programs again."""
    (SVG_DIR / "text.svg").write_text(text_svg())
    PATHS_DIR.mkdir(exist_ok=True)
    GENERATED.mkdir(exist_ok=True)
    for drawing in DRAWINGS:
        # Inkscape's Object to Path, headless: what a gcodetools user does before Path to Gcode.
        subprocess.run(["inkscape", "--actions=select-all:all;object-to-path", "--export-type=svg",
                        f"--export-filename={PATHS_DIR / f'{drawing}.svg'}", str(SVG_DIR / f"{drawing}.svg")],
                       check=True, capture_output=True, text=True, timeout=300)
    for case in CASES:
        if case.committed and (not only or case.generator in only):
            GENERATORS[case.generator](case, GENERATED / case.name)
    versions: Dict[str, str] = {
        "svg2gcode": _version([SVG2GCODE, "--version"]),
        "inkscape (gcodetools, Object to Path)": _version(["inkscape", "--version"]),
        "python3 running gcodetools": _version(["/usr/bin/python3", "--version"]),
    }
    (GENERATED / "VERSIONS.txt").write_text(
        "The tools that made these files (python tests/generator_corpus.py):\n"
        + "".join(f"{name}: {version}\n" for name, version in versions.items()))


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        description="Make the committed corpus again: svg/text.svg (vpype), svg/paths/ (inkscape Object to "
                    "Path), generated/ (svg2gcode and gcodetools). Needs: `cargo install svg2gcode-cli "
                    "--version 0.0.18 --locked` on PATH, Debian 12's inkscape 1.2.2 with python3-lxml and "
                    "python3-numpy, and the project's venv (vpype).")
    parser.add_argument("--only", nargs="*", default=(), choices=("svg2gcode", "gcodetools"),
                        help="remake only these generators' programs")
    args = parser.parse_args(argv)
    regenerate(args.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
