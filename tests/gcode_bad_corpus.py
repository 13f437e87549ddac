"""Malformed G-code programs and why each must be rejected.

Each case names the physical line the error is on and a word or phrase that
the error message must contain. ``linuxcnc_rejects`` is True when the program
(with M2 appended) is plain LinuxCNC G-code that LinuxCNC's interpreter also
rejects; test_gcode_oracle.py checks those against rs274. The others are
either outside LinuxCNC's rules (it accepts expressions, G18, ...) or only
wrong for the plotter (soft limits, no moves, non-ASCII text).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BadCase:
    name: str
    program: bytes
    line: int
    keyword: str
    linuxcnc_rejects: bool = False


CORPUS = [
    # words and numbers
    BadCase("unknown-letter", b"G21 F100\nG1 X1 Q5\n", 2, "unsupported word letter 'Q'", True),
    BadCase("unknown-letter-e", b"G21 F100\nG1 X1 E5\n", 2, "unsupported word letter 'E'"),
    BadCase("unknown-g-code", b"G21 F100\nG1 X1\nG99.9 X2\n", 3, "unsupported G code G99.9",
            True),
    BadCase("unsupported-g28.1", b"G21\nG28.1\n", 2, "G28.1 (store the home position) is refused"),
    BadCase("vendor-m-code", b"G21\nM100 P100\nG0 X1\n", 2, "a machine's own command"),
    BadCase("peck-drilling", b"G21 F100\nG83 X1 Y1 Z-1 R1\n", 2, "canned cycles other than drilling"),
    BadCase("unsupported-g61.1", b"G61.1\nG0 X1\n", 1, "unsupported G code G61.1"),
    BadCase("unknown-m-code", b"G21\nM250\n", 2, "unsupported M code M250", True),
    BadCase("word-without-number-at-end", b"G21 F100\nG1 X\n", 2, "'X' word without a number",
            True),
    BadCase("word-without-number-before-word", b"F100\nG1 XY1\n", 2,
            "'X' word without a number", True),
    BadCase("g-without-number", b"G\n", 1, "'G' word without a number", True),
    BadCase("number-without-letter", b"F100\nG1 X1 5\n", 2, "without a word letter"),
    BadCase("number-first", b"F100\n10 G1 X1\n", 2, "without a word letter", True),
    BadCase("two-x-words", b"F100\nG1 X1 X2\n", 2, "two X words", True),
    BadCase("two-f-words", b"G1 F100 F200 X1\n", 1, "two F words", True),
    BadCase("two-m-words", b"M3 M5\n", 1, "two M words", True),
    BadCase("two-motion-words", b"F100\nG0 G1 X1\n", 2, "two motion words", True),
    BadCase("two-distance-modes", b"G90 G91\nG0 X1\n", 1, "distance group", True),
    BadCase("two-unit-modes", b"G20 G21\nG0 X1\n", 1, "units group", True),
    BadCase("dwell-and-g92", b"G4 P1 G92 X1\n", 1, "non-modal group", True),
    BadCase("n-not-first", b"F100\nG1 N10 X1\n", 2, "must come first", True),
    BadCase("n-decimal", b"N1.5 G0 X1\n", 1, "whole number"),
    BadCase("number-too-large", b"G0 X10000000\n", 1, "out of range"),
    BadCase("exponent", b"G0 X1e3\n", 1, "unsupported word letter 'E'", True),
    # characters and lines
    BadCase("unclosed-comment", b"G21\nG0 X1 (pen up\n", 2, "unclosed comment", True),
    BadCase("nested-comment", b"G21 (a (b) c)\nG0 X1\n", 1, "nested comment", True),
    BadCase("close-without-open", b"G0 X1 )\n", 1, "')' without", True),
    BadCase("expression", b"G21\nG0 X[1+2]\n", 2, "expressions"),
    BadCase("parameter", b"#1=5\nG0 X1\n", 1, "parameters"),
    BadCase("checksum", b"G0 X1*45\n", 1, "checksums", True),
    BadCase("block-delete", b"/G0 X1\n", 1, "block delete"),
    BadCase("percent-inside-line", b"G0 X1 %\n", 1, "unexpected character '%'", True),
    BadCase("overlong-line", b"G21\nG0 X1" + b" " * 300 + b"Y1\n", 2, "line too long"),
    BadCase("binary-garbage", b"G21\nG0 X1\n\x00\xff\xfe\x80garbage\n", 3, "invalid character U+0000"),
    BadCase("control-character", b"G21\nG0 X1\x07\n", 2, "invalid character", True),
    BadCase("carriage-return-inside", b"G0 X1\rG0 X2\n", 1, "invalid character", True),
    BadCase("utf8-outside-comment", b"G21\nG0 X1 \xc3\xa9\n", 2, "invalid character U+00E9 outside a comment"),
    BadCase("text-garbage", b"G21\nhello world\n", 2, "'H' word without a number", True),
    BadCase("empty-file", b"", 1, "empty program"),
    BadCase("only-comments", b"(hello)\n; world\n\n%\n", 4, "empty program", True),
    BadCase("no-moves", b"G21 G90 F100\nM3\nM5\n", 3, "makes no moves"),
    BadCase("no-moves-before-m2", b"G21\nM3\nM2\nG0 X1\n", 3, "makes no moves"),
    # modes, feed, dwell, G92
    BadCase("plane-g18", b"G18\nG0 X1\n", 1, "only the XY plane"),
    BadCase("plane-g19", b"G21 G19\n", 1, "only the XY plane"),
    BadCase("no-feed-rate", b"G21\nG0 X5\nG1 X10\n", 3, "no feed rate", True),
    BadCase("no-feed-rate-arc", b"G21\nG2 X10 I5\n", 2, "no feed rate", True),
    BadCase("zero-feed-rate", b"G21 F0\nG1 X10\n", 2, "no feed rate", True),
    BadCase("negative-feed-rate", b"G21\nG1 F-100 X1\n", 2, "negative feed rate", True),
    BadCase("z-only-without-feed", b"G21\nG1 Z-1\n", 2, "no feed rate", True),
    BadCase("axis-without-motion-mode", b"G21\nX10 Y10\n", 2, "without a motion mode", True),
    BadCase("p-without-g4", b"F100\nG1 X1 P2\n", 2, "P word without G4", True),
    BadCase("dwell-without-p", b"G0 X1\nG4\n", 2, "needs a P word", True),
    BadCase("dwell-negative", b"G0 X1\nG4 P-1\n", 2, "negative", True),
    BadCase("g92-without-axes", b"G0 X1\nG92\n", 2, "G92 without any axis word", True),
    BadCase("g92-with-motion", b"F100\nG1 X1 G92\n", 2, "both use the axis words", True),
    BadCase("g92-with-i", b"G0 X1\nG92 X0 I1\n", 2, "I word without an arc", True),
    # arcs
    BadCase("arc-without-ijr", b"G21 F100\nG2 X10\n", 2, "needs I/J", True),
    BadCase("arc-word-alone", b"G21 F100\nG3\n", 2, "needs I/J", True),
    BadCase("arc-mixed-r-and-ij", b"F100\nG2 X10 R5 I5\n", 2, "both R and I/J", True),
    BadCase("r-arc-same-point", b"F100\nG0 X5\nG2 X5 R5\n", 3, "ends where it starts", True),
    BadCase("r-arc-no-axes", b"F100\nG3 R5\n", 2, "ends where it starts", True),
    BadCase("r-too-small", b"F100\nG2 X10 R4.9\n", 2, "radius too small", True),
    BadCase("r-zero", b"F100\nG2 X10 R0\n", 2, "radius too small", True),
    BadCase("zero-radius", b"F100\nG0 X5 Y5\nG2 X5 Y5 I0 J0\n", 3, "zero-radius", True),
    BadCase("zero-radius-start", b"F100\nG2 X1 I0 J0\n", 2, "zero-radius", True),
    BadCase("radius-mismatch", b"G21 F100\nG2 X10 I4\n", 2, "radius to end of arc differs",
            True),
    BadCase("radius-mismatch-metric-small", b"G21 F100\nG0 X0\nG2 X10 I4.97\n", 3,
            "radius to end of arc differs", True),
    BadCase("radius-mismatch-inch", b"G20 F10\nG2 X1 I0.49\n", 2,
            "radius to end of arc differs", True),
    BadCase("i-with-g1", b"F100\nG1 X10 I5\n", 2, "I word without an arc", True),
    BadCase("r-with-g0", b"G0 X10 R5\n", 1, "R word without an arc", True),
    BadCase("j-without-motion", b"G21\nJ5\n", 2, "J word without an arc", True),
    # soft limits (default work area X 0..200, Y 0..200 mm)
    BadCase("outside-x", b"G21 G90\nG0 X10 Y10\nG0 X250\n", 3, "outside the work area"),
    BadCase("outside-negative", b"G21 F100\nG1 X-1\n", 2, "outside the work area"),
    BadCase("outside-inch", b"G20\nG0 X8\n", 2, "outside the work area"),
    BadCase("outside-after-g92", b"G21\nG0 X10\nG92 X0\nG0 X195\n", 4,
            "outside the work area"),
    BadCase("arc-bulges-outside", b"G21 F100\nG0 X5 Y100\nG2 X5 Y120 J10\n", 3,
            "arc leaves the work area"),
    BadCase("circle-bulges-outside", b"G21 F100\nG0 X100 Y195\nG3 I0 J-10\nG2 J10\n", 4,
            "arc leaves the work area"),
]
