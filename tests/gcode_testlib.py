"""Helpers shared by the G-code tests (no ROS needed).

- Puts ros_ws/src/plotter_bridge on sys.path, so ``plotter_bridge.gcode``
  imports from the working tree.
- Locates LinuxCNC's acceptance programs in shared/acceptance/linuxcnc.
- Evaluates LinuxCNC bracket expressions (``[25.00 - [0.0099 * sqrt[2]]]``),
  which are outside the plotter's G-code subset, into plain numbers.
- Samples parsed moves into points, to compare paths.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import sys
from pathlib import Path
from typing import List

REPO_ROOT = Path(__file__).resolve().parent.parent
BRIDGE_SRC = REPO_ROOT / "ros_ws" / "src" / "plotter_bridge"
if str(BRIDGE_SRC) not in sys.path:
    sys.path.insert(0, str(BRIDGE_SRC))

DATA_DIR = Path(__file__).resolve().parent / "data" / "gcode"


def acceptance_dir() -> Path:
    """shared/acceptance/linuxcnc beside the repository (or $PLOTTER_ACCEPTANCE_DIR)."""
    override = os.environ.get("PLOTTER_ACCEPTANCE_DIR")
    if override:
        return Path(override)
    for base in (REPO_ROOT.parent / "shared", Path("/work/shared")):
        candidate = base / "acceptance" / "linuxcnc"
        if candidate.is_dir():
            return candidate
    return REPO_ROOT.parent / "shared" / "acceptance" / "linuxcnc"


def acceptance_programs(folder: str) -> List[Path]:
    """The .ngc programs of acceptance_dir()/folder.  Where there are none (the
    folder is missing), one path that is not there: each test over them then
    fails reading it, naming where it looked, instead of being skipped as a
    test over an empty list would be."""
    return sorted((acceptance_dir() / folder).glob("*.ngc")) or [acceptance_dir() / folder / "(no .ngc here)"]


# ------------------------------------------------------- bracket expressions

_TOKEN = re.compile(r"\s*(?:(\d+\.?\d*|\.\d+)|(sqrt)|(.))", re.IGNORECASE)


class _Expr:
    """Recursive-descent evaluator for + - * /, unary minus, sqrt[...] and [...]."""

    def __init__(self, text: str) -> None:
        self.tokens = [m.group(0).strip().lower() for m in _TOKEN.finditer(text)
                       if m.group(0).strip()]
        self.pos = 0

    def peek(self) -> str:
        return self.tokens[self.pos] if self.pos < len(self.tokens) else ""

    def take(self, expected: str = None) -> str:
        tok = self.peek()
        if expected is not None and tok != expected:
            raise ValueError(f"expected {expected!r}, found {tok!r}")
        self.pos += 1
        return tok

    def expr(self) -> float:
        value = self.term()
        while self.peek() in ("+", "-"):
            value = value + self.term() if self.take() == "+" else value - self.term()
        return value

    def term(self) -> float:
        value = self.factor()
        while self.peek() in ("*", "/"):
            value = value * self.factor() if self.take() == "*" else value / self.factor()
        return value

    def factor(self) -> float:
        tok = self.peek()
        if tok == "-":
            self.take()
            return -self.factor()
        if tok == "sqrt":
            self.take()
            return math.sqrt(self.bracket())
        if tok == "[":
            return self.bracket()
        self.take()
        return float(tok)

    def bracket(self) -> float:
        self.take("[")
        value = self.expr()
        self.take("]")
        return value


def evaluate(expression: str) -> float:
    """Value of one bracket expression such as ``[0.9985 * 100]``."""
    parser = _Expr(expression)
    value = parser.bracket()
    if parser.pos != len(parser.tokens):
        raise ValueError(f"trailing text in {expression!r}")
    return value


def substitute_expressions(text: str) -> str:
    """Replace every top-level ``[...]`` expression by its value (12 decimals)."""
    out: List[str] = []
    i = 0
    while i < len(text):
        if text[i] != "[":
            out.append(text[i])
            i += 1
            continue
        depth, j = 0, i
        while True:
            depth += {"[": 1, "]": -1}.get(text[j], 0)
            if depth == 0:
                break
            j += 1
        number = f"{evaluate(text[i:j + 1]):.12f}".rstrip("0").rstrip(".")
        out.append(number)
        i = j + 1
    return "".join(out)


def expected_message(ngc_text: str) -> str:
    """LinuxCNC's message on the first line of a bad/*.ngc file."""
    first = ngc_text.splitlines()[0].strip()
    if first.startswith(";"):
        return first[1:].strip()
    return first.strip("()").strip()


# ------------------------------------------------------- running the CLI

def check_json(path: Path, *extra: str) -> List[dict]:
    """The moves of ``plotter check PATH --json``, run in-process; asserts exit code 0."""
    from plotter_bridge.cli import main as cli

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", str(path), "--json", *extra])
    assert code == 0, f"plotter check rejected {path}: {err.getvalue()}"
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    return [r for r in records if r["type"] not in ("note", "error")]


# ------------------------------------------------------- paths as points

def move_points(m, spacing=0.004):
    """Points along a parsed move, at most `spacing` mm apart."""
    if m.kind != "arc":
        n = max(1, math.ceil(math.hypot(m.x - m.sx, m.y - m.sy) / spacing))
        return [(m.sx + (m.x - m.sx) * k / n, m.sy + (m.y - m.sy) * k / n) for k in range(n + 1)]
    a0 = math.atan2(m.sy - m.cy, m.sx - m.cx)
    a1 = math.atan2(m.y - m.cy, m.x - m.cx)
    r = math.hypot(m.sx - m.cx, m.sy - m.cy)
    sweep = ((a0 - a1) if m.cw else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
    n = max(8, math.ceil(r * sweep / spacing))
    sign = -1 if m.cw else 1
    return [(m.cx + r * math.cos(a0 + sign * sweep * k / n), m.cy + r * math.sin(a0 + sign * sweep * k / n))
            for k in range(n + 1)]


# ------------------------------------------------------- distance to a path

def _in_sweep(angle: float, a0: float, a1: float, cw: bool, full: bool) -> bool:
    if full:
        return True
    tau = 2 * math.pi
    if cw:
        return (a0 - angle) % tau <= (a0 - a1) % tau
    return (angle - a0) % tau <= (a1 - a0) % tau


def distance_to_move(p, m) -> float:
    """Distance (mm) from a point to a parsed move: its segment, or its arc."""
    px, py = p
    if m.kind != "arc":
        dx, dy = m.x - m.sx, m.y - m.sy
        length2 = dx * dx + dy * dy
        t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - m.sx) * dx + (py - m.sy) * dy) / length2))
        return math.hypot(px - (m.sx + t * dx), py - (m.sy + t * dy))
    r = math.hypot(m.sx - m.cx, m.sy - m.cy)
    a0 = math.atan2(m.sy - m.cy, m.sx - m.cx)
    a1 = math.atan2(m.y - m.cy, m.x - m.cx)
    if _in_sweep(math.atan2(py - m.cy, px - m.cx), a0, a1, bool(m.cw), m.is_full_circle):
        return abs(math.hypot(px - m.cx, py - m.cy) - r)
    return min(math.hypot(px - m.sx, py - m.sy), math.hypot(px - m.x, py - m.y))


class MoveIndex:
    """The parsed moves of a program in a grid of `cell` mm, for the distance from a
    point to the nearest of them; a point farther than `reach` from all of them is
    reported as infinitely far."""

    def __init__(self, moves, cell: float = 1.0, reach: float = 0.25) -> None:
        from plotter_bridge.gcode.geometry import arc_extreme_points
        self.cell, self.grid = cell, {}
        for m in moves:
            xs, ys = [m.sx, m.x], [m.sy, m.y]
            if m.kind == "arc":
                if m.is_full_circle:
                    r = math.hypot(m.sx - m.cx, m.sy - m.cy)
                    xs += [m.cx - r, m.cx + r]
                    ys += [m.cy - r, m.cy + r]
                else:
                    for ex, ey in arc_extreme_points((m.sx, m.sy), (m.x, m.y), (m.cx, m.cy), bool(m.cw)):
                        xs.append(ex)
                        ys.append(ey)
            for i in range(math.floor((min(xs) - reach) / cell), math.floor((max(xs) + reach) / cell) + 1):
                for j in range(math.floor((min(ys) - reach) / cell), math.floor((max(ys) + reach) / cell) + 1):
                    self.grid.setdefault((i, j), []).append(m)

    def distance(self, p) -> float:
        near = self.grid.get((math.floor(p[0] / self.cell), math.floor(p[1] / self.cell)), ())
        return min((distance_to_move(p, m) for m in near), default=math.inf)
