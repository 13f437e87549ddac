"""Programs written by the tools people use (tests/data/real, SOURCES.md), and
how a user of each tool runs it on this plotter: the dialect of the
firmware the tool writes for, the servo angles its machine uses, a work area
that holds the drawing where it does not fit the default 0..200 mm.

A program the plotter refuses has the lines and words of the reasons, all
of which one run must list.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Tuple

REAL = Path(__file__).resolve().parent / "data" / "real"
WIDE = (-60.0, 260.0, -160.0, 260.0)       # mm: a table bigger than the default, for drawings off its corner


@dataclass(frozen=True)
class RealProgram:
    file: str                                   # under tests/data/real
    dialect: str
    marlin_pen: Optional[Tuple[float, float]] = None    # (down, up) servo angles of the tool's machine
    area: Optional[Tuple[float, float, float, float]] = None
    refused: Tuple[Tuple[int, str], ...] = ()   # (line, words of the reason) of every refused line
    rs274: bool = False                         # LinuxCNC's interpreter reads it as it is
    draws: bool = True                          # the pen goes down (False: the tool wrote no pen commands)
    notes: Tuple[str, ...] = ()                 # words of notes the reading must give

    @property
    def path(self) -> Path:
        return REAL / self.file

    @property
    def name(self) -> str:
        return self.file

    def options(self):
        """How its tool's firmware reads it (GCodeOptions)."""
        from plotter_bridge.gcode.dialect import GCodeOptions
        if self.marlin_pen:
            return GCodeOptions(self.dialect, marlin_pen_down=self.marlin_pen[0], marlin_pen_up=self.marlin_pen[1])
        return GCodeOptions(self.dialect)

    def args(self) -> List[str]:
        """The options of plotter check and plotter stream for it."""
        out = ["--dialect", self.dialect]
        if self.marlin_pen:
            out += ["--marlin-pen", *(f"{a:g}" for a in self.marlin_pen)]
        if self.area:
            out += ["--area", *(f"{a:g}" for a in self.area)]
        return out


PROGRAMS = [
    # CamBam: drilling cycles (a dot per hole), a tool change, M3 S, G64 G40.
    RealProgram("cambam/test.nc", "linuxcnc", area=WIDE, rs274=True,
                notes=("M6 tool change", "G40 cutter radius compensation off", "G98 canned cycles")),
    RealProgram("freecad/Ecscentrick_0.5_8_12_mm_slote_33MM_cut.nc", "grbl", area=WIDE,
                notes=("K word: K on an arc in the XY plane",)),
    RealProgram("freecad/test_linuxcnc_metric_ref.ngc", "linuxcnc", area=WIDE, rs274=True,
                notes=("G43 tool length offset", "G49", "G80")),
    RealProgram("fusion360/1018_puz_18_bit.nc", "grbl", area=WIDE),
    # gcodeplot: a 3D printer's firmware turned plotter: "G00 S1; endstops", "G00 E0; no extrusion", G28 X.
    RealProgram("gcodeplot/3rect.svg.gcode", "marlin", notes=("E word", "S word: without a servo", "G28 go home")),
    RealProgram("gcodetools/arc_0001.gcode", "linuxcnc", rs274=True),
    # gcodetools with a DexArm robot's own header and footer: that arm's M2000 and M888.
    RealProgram("gcodetools/testpattern.gcode", "linuxcnc", area=(-100.0, 260.0, -160.0, 400.0),
                refused=((3, "M2000: a machine's own command"), (4, "M888: a machine's own command"))),
    RealProgram("grbl-plotter/lastProcessed.nc", "grbl", rs274=True),
    RealProgram("jscut/jscut.gcode", "grbl", area=WIDE, rs274=True),
    RealProgram("jscut/jscut-outside.gcode", "grbl", area=WIDE, rs274=True),
    RealProgram("lasertools/unbt_laser_logo_0001_crosshair.gcode", "grbl", rs274=True),
    # LightBurn: "G00 G17 G40 G21 G54" on top, M4 with S power per move, M8/M9.
    RealProgram("lightburn/example_2_circle.gcode", "grbl", notes=("G40", "G54", "M8 flood coolant")),
    # Makelangelo: Marlin-polargraph, its servo at 90 up / 25 down, "G28 X Y", "M0 Ready black and click".
    RealProgram("makelangelo/save_simple_move.gcode", "marlin", marlin_pen=(25.0, 90.0), area=WIDE,
                notes=("M300: not a servo angle", "M200 filament", "G28 go home", "message 'Ready black and click'",
                       "M400")),
    # Mr Beam: its compressor is M100, a maker's own code, on a laser bigger than this table.
    RealProgram("mrbeam/Line.gco", "grbl", area=(0.0, 500.0, 0.0, 500.0),
                refused=((13, "M100: a machine's own command"), (43, "M100: a machine's own command"))),
    RealProgram("openbuilds-cam/file-7.gcode", "grbl", area=WIDE, rs274=True),
    RealProgram("pcb-gcode/Handbrake.top.mill.gcode", "grbl"),
    RealProgram("sketchucam/arc_rword_test.gcode", "linuxcnc", rs274=True, notes=("G49", "G61")),
    # svg2gcode's own test output: no --on/--off, so no pen command: all of it travels.
    RealProgram("svg2gcode/square_transformed.gcode", "grbl", rs274=True, draws=False),
    # Text2G-Code: 46 up, 43 down; "Per compatibilità" in a comment; E words; G1 before any F.
    RealProgram("text2gcode/tweetTest.gcode", "marlin", marlin_pen=(43.0, 46.0),
                notes=("E word", "no F yet", "G28 go home")),
    # The Unicorn plugin: its options as one comment of 345 characters, 50 down and 45 up, M300 S255 at the end.
    RealProgram("unicorn/mechLines1.gcode", "marlin", marlin_pen=(50.0, 45.0), area=WIDE,
                notes=("M18 stepper motors off", "M300 S255: not a servo angle", "Z does not move the pen")),
]
ACCEPTED = [p for p in PROGRAMS if not p.refused]
REFUSED = [p for p in PROGRAMS if p.refused]
