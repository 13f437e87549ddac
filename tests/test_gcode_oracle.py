"""The G-code front end against an independent oracle: LinuxCNC's rs274.

rs274 is LinuxCNC's standalone interpreter; it prints the canonical machining
calls (STRAIGHT_TRAVERSE, STRAIGHT_FEED, ARC_FEED, ...) of a program. It comes
from Debian's linuxcnc-uspace package, fetched with ``apt-get download`` and
unpacked with ``dpkg -x`` (nothing is installed) into a cache directory,
``~/.cache/plotter-rs274`` or $PLOTTER_RS274_CACHE, so that reruns are fast.
When it cannot be obtained the tests are skipped with the reason, or fail if
PLOTTER_REQUIRE_RS274=1.

rs274 prints numbers with 4 decimals in the program's units, relative to the
G92 offset it reports; the comparison converts them to machine mm and allows
1e-4 mm, or more where the printed numbers are rounded coarser than that: by
0.00005 inch for inch coordinates and for offsets printed in inches.

The pen is compared through this model of the canonical calls: spindle on
(M3) lowers it, spindle off (M5) raises it, a change of Z sets it (Z <= 0
down, or Z <= pen_up_z); traverses (G0) travel with the pen up. For the grbl
dialect the spindle's speed is its power: the pen is down while the spindle
runs at a speed above 0. Every program is run by both
with the line ``G0 Z1`` in front (PREFIX), so that rs274's Z starts, like the
plotter's pen, in the up position.
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import math
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib as lib  # noqa: E402
from gcode_bad_corpus import CORPUS  # noqa: E402

from plotter_bridge.cli import main as cli  # noqa: E402

OWN_PROGRAMS = sorted((lib.DATA_DIR / "oracle").glob("*.ngc"))
RAPID_RATE = 3000.0
DEBIAN_PACKAGES = ("linuxcnc-uspace", "libboost-python1.74.0")
# Libraries rs274 links to, by Debian package, for a system that lacks some.
LIBRARY_PACKAGES = {
    "libpython3.11.so.1.0": "libpython3.11", "libedit.so.2": "libedit2",
    "libtirpc.so.3": "libtirpc3", "libbsd.so.0": "libbsd0", "libmd.so.0": "libmd0",
    "libexpat.so.1": "libexpat1", "libtinfo.so.6": "libtinfo6",
    "libgssapi_krb5.so.2": "libgssapi-krb5-2", "libkrb5.so.3": "libkrb5-3",
    "libk5crypto.so.3": "libk5crypto3", "libkrb5support.so.0": "libkrb5support0",
    "libkeyutils.so.1": "libkeyutils1", "libcom_err.so.2": "libcom-err2",
    "libz.so.1": "zlib1g",
}
PREFIX = "G0 Z1\n"
RUN_LOCK = Path(tempfile.gettempdir()) / "plotter-rs274.lock"


# ------------------------------------------------------------------ rs274

class Unavailable(Exception):
    pass


@dataclass
class Rs274Result:
    ok: bool
    calls: List[Tuple[str, List[str]]]
    message: str  # LinuxCNC's error message ("" when accepted)
    bad_line: str  # the text of the line it complained about


_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_0-9]+)\((.*)\)\s*$")


class Rs274:
    def __init__(self, binary: Path, env: Dict[str, str], table: Path) -> None:
        self.binary, self.env, self.table = binary, env, table

    def run(self, path: Path) -> Rs274Result:
        # Concurrent rs274 processes share LinuxCNC's shared memory and now and
        # then die of SIGBUS: run one at a time on this machine, retry a crash.
        with open(RUN_LOCK, "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            for _ in range(3):
                proc = subprocess.run(
                    [str(self.binary), "-t", str(self.table), "-g", str(path)],
                    stdin=subprocess.DEVNULL, capture_output=True, text=True,
                    env=self.env, timeout=60, check=False)
                if proc.returncode >= 0:
                    break
        calls = []
        for line in proc.stdout.splitlines():
            m = _CALL.match(line)
            if m:
                args = [a.strip() for a in m.group(2).split(",")] if m.group(2) else []
                calls.append((m.group(1), args))
        notes = [line for line in proc.stderr.splitlines()
                 if line.strip() and line.strip() != "executing"]
        message = notes[0].strip() if notes else ""
        bad_line = notes[1].strip() if len(notes) > 1 else ""
        return Rs274Result(proc.returncode == 0 and not message, calls, message, bad_line)


def _run(cmd: List[str], cwd: Path, timeout: int = 600) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=str(cwd), capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL, check=False)


def _apt_download(packages: List[str], dest: Path) -> None:
    if shutil.which("apt-get") is None or shutil.which("dpkg") is None:
        raise Unavailable("apt-get/dpkg not found (a Debian system is needed)")
    proc = _run(["apt-get", "download", *packages], dest)
    if proc.returncode != 0 and os.geteuid() == 0:
        _run(["apt-get", "update"], dest)  # the package lists may be missing or old
        proc = _run(["apt-get", "download", *packages], dest)
    if proc.returncode != 0:
        raise Unavailable(f"apt-get download {' '.join(packages)} failed: "
                          f"{proc.stderr.strip()[-400:]}")


def _unpack(debs: List[Path], tree: Path) -> None:
    for deb in debs:
        proc = _run(["dpkg", "-x", str(deb), str(tree)], tree.parent)
        if proc.returncode != 0:
            raise Unavailable(f"dpkg -x {deb.name} failed: {proc.stderr.strip()[-400:]}")


def _library_env(tree: Path) -> Dict[str, str]:
    patterns = ("usr/lib/*.so*", "usr/lib/*-linux-gnu/*.so*", "lib/*-linux-gnu/*.so*")
    dirs = sorted({str(p.parent) for pattern in patterns for p in tree.glob(pattern)})
    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = ":".join(dirs + [env.get("LD_LIBRARY_PATH", "")]).rstrip(":")
    return env


def _missing_libraries(binary: Path, env: Dict[str, str]) -> List[str]:
    proc = subprocess.run(["ldd", str(binary)], capture_output=True, text=True, env=env,
                          check=False, timeout=60)
    return [line.split()[0] for line in proc.stdout.splitlines() if "not found" in line]


def obtain_rs274(cache: Path) -> Rs274:
    cache.mkdir(parents=True, exist_ok=True)
    tree = cache / "tree"
    binary = tree / "usr" / "bin" / "rs274"
    with open(cache / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # other test runs may fetch at the same time
        if not binary.exists():
            debs = cache / "debs"
            shutil.rmtree(debs, ignore_errors=True)
            debs.mkdir()
            _apt_download(list(DEBIAN_PACKAGES), debs)
            partial = cache / "tree.partial"
            shutil.rmtree(partial, ignore_errors=True)
            partial.mkdir()
            _unpack(sorted(debs.glob("*.deb")), partial)
            shutil.rmtree(tree, ignore_errors=True)
            partial.rename(tree)
            shutil.rmtree(debs, ignore_errors=True)
        env = _library_env(tree)
        missing = _missing_libraries(binary, env)
        if missing:
            wanted = sorted({LIBRARY_PACKAGES[m] for m in missing if m in LIBRARY_PACKAGES})
            if not wanted:
                raise Unavailable(f"rs274 needs libraries of unknown packages: {missing}")
            extra = cache / "extra-debs"
            extra.mkdir(exist_ok=True)
            _apt_download(wanted, extra)
            _unpack(sorted(extra.glob("*.deb")), tree)
            shutil.rmtree(extra, ignore_errors=True)
            env = _library_env(tree)
            missing = _missing_libraries(binary, env)
            if missing:
                raise Unavailable(f"rs274 still misses libraries: {missing}")
        # Tools 1-99 of no length or diameter: the tool changes real programs make (T3 M6) are found.
        table = cache / "TOOLS.tbl"
        table.write_text("".join(f"T{n} P{n} Z0 D0 ;pen\n" for n in range(1, 100)))
        probe = cache / "probe.ngc"
        probe.write_text("G21 F100\nG1 X1\nM2\n")
    tool = Rs274(binary, env, table)
    result = tool.run(probe)
    if not result.ok or not any(name == "STRAIGHT_FEED" for name, _ in result.calls):
        raise Unavailable(f"rs274 does not run: {result.message or result.calls[:3]}")
    return tool


@pytest.fixture(scope="session")
def rs274() -> Rs274:
    cache = Path(os.environ.get("PLOTTER_RS274_CACHE")
                 or Path.home() / ".cache" / "plotter-rs274")
    try:
        return obtain_rs274(cache)
    except (Unavailable, OSError, subprocess.SubprocessError) as exc:
        reason = f"LinuxCNC rs274 oracle unavailable: {exc}"
        if os.environ.get("PLOTTER_REQUIRE_RS274") == "1":
            pytest.fail(reason, pytrace=False)
        pytest.skip(reason)


# ------------------------------------------------------- canonical calls -> moves

def oracle_moves(calls: List[Tuple[str, List[str]]], rapid_rate: float, *,
                 power_word: bool = False, pen_up_z: float = 0.0) -> List[dict]:
    """Moves in machine mm, shaped like ``plotter check --json`` records."""
    unit = 1.0
    offset = (0.0, 0.0)
    offset_unit = 0.0  # the unit the offset was printed in (0: exactly zero)
    feed = 0.0
    pen = "up"
    z_mm = 0.0
    spindle_on, speed = False, None      # a speed never set counts as turning: "M3" alone draws
    position: Optional[Tuple[float, float]] = None
    position_quant = 0.0
    moves: List[dict] = []

    def machine(x: str, y: str) -> Tuple[float, float]:
        return float(x) * unit + offset[0], float(y) * unit + offset[1]

    def z_change(z: str) -> None:
        nonlocal pen, z_mm
        new = float(z) * unit
        if abs(new - z_mm) > 0.002:
            pen = "down" if new <= pen_up_z else "up"
        z_mm = new

    for name, args in calls:
        if name == "USE_LENGTH_UNITS":
            unit = 25.4 if args[0] == "CANON_UNITS_INCHES" else 1.0
        elif name == "SET_G92_OFFSET":
            offset = (float(args[0]) * unit, float(args[1]) * unit)
            offset_unit = unit if offset != (0.0, 0.0) else 0.0
        elif name == "SET_G5X_OFFSET":
            assert all(float(a) == 0.0 for a in args[1:]), "G54..G59 offsets are unused"
        elif name == "SET_FEED_RATE":
            feed = float(args[0]) * unit
        elif name in ("START_SPINDLE_CLOCKWISE", "START_SPINDLE_COUNTERCLOCKWISE"):
            spindle_on = True
            pen = "down" if speed is None or speed > 0.0 or not power_word else "up"
        elif name == "STOP_SPINDLE_TURNING":
            spindle_on = False
            pen = "up"
        elif name == "SET_SPINDLE_SPEED" and power_word:
            speed = float(args[1])
            if spindle_on:
                pen = "down" if speed > 0.0 else "up"
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            z_change(args[2])
            end = machine(args[0], args[1])
            start = position or (0.0, 0.0)
            # Points and offsets are printed rounded to 0.0001 of their units.
            quant = 0.00005 * (unit + offset_unit) * (1 + 1e-9)
            same = quant + position_quant
            position, position_quant = end, quant
            if abs(end[0] - start[0]) <= same and abs(end[1] - start[1]) <= same:
                continue  # a pen change only
            rapid = name == "STRAIGHT_TRAVERSE"
            moves.append({"type": "line", "x": end[0], "y": end[1],
                          "feed": rapid_rate if rapid else feed,
                          "pen": "up" if rapid else pen, "unit": unit, "quant": quant})
        elif name == "ARC_FEED":
            z_change(args[5])
            end = machine(args[0], args[1])
            centre = machine(args[2], args[3])
            quant = 0.00005 * (unit + offset_unit) * (1 + 1e-9)
            position, position_quant = end, quant
            moves.append({"type": "arc", "x": end[0], "y": end[1], "cx": centre[0],
                          "cy": centre[1], "cw": int(args[4]) < 0, "feed": feed,
                          "pen": pen, "unit": unit, "quant": quant})
    return moves


def assert_same_moves(ours: List[dict], theirs: List[dict], label: str) -> None:
    assert len(ours) == len(theirs), (
        f"{label}: {len(ours)} moves from plotter check, {len(theirs)} from rs274\n"
        f"ours:   {ours}\nrs274:  {theirs}")
    for index, (a, b) in enumerate(zip(ours, theirs)):
        where = f"{label}: move {index + 1} (line {a['line']})"
        # rs274 prints 4 decimals in program units: allow that rounding.
        tol = max(1e-4, b["quant"])
        assert a["type"] == b["type"], f"{where}: {a} vs {b}"
        assert a["pen"] == b["pen"], f"{where}: pen {a} vs {b}"
        for key in ("x", "y", "cx", "cy"):
            if key in b:
                assert abs(a[key] - b[key]) <= tol, f"{where}: {key} {a} vs {b}"
        if "cw" in b:
            assert a["cw"] == b["cw"], f"{where}: direction {a} vs {b}"
        assert abs(a["feed"] - b["feed"]) <= max(1e-3, 5e-5 * b["unit"]), \
            f"{where}: feed {a} vs {b}"


def with_prefix(text: str) -> str:
    """PREFIX as the first line of the program (after a leading '%' line)."""
    first, newline, rest = text.partition("\n")
    if first.strip() == "%":
        return first + newline + PREFIX + rest
    return PREFIX + text


def compare(rs274: Rs274, text: str, tmp_path: Path, label: str, dialect: str = "linuxcnc",
            pen_up_z: float = 0.0) -> List[dict]:
    """Run both on the program with PREFIX; assert both accept it and agree."""
    path = tmp_path / "program.ngc"
    path.write_text(with_prefix(text))
    result = rs274.run(path)
    assert result.ok, f"{label}: rs274 rejected it: {result.message} ({result.bad_line})"
    ours = lib.check_json(path, "--no-limits", "--rapid-rate", str(RAPID_RATE),
                          "--dialect", dialect, "--pen-up-z", str(pen_up_z))
    theirs = oracle_moves(result.calls, RAPID_RATE, power_word=dialect in ("grbl", "linuxcnc"), pen_up_z=pen_up_z)
    assert_same_moves(ours, theirs, label)
    return ours


# ------------------------------------------------------------------ tests

def test_oracle_is_available(rs274):
    result = rs274.run(lib.DATA_DIR / "oracle" / "g92_offsets.ngc")
    assert result.ok and any(name == "SET_G92_OFFSET" for name, _ in result.calls)


@pytest.mark.parametrize("path", lib.acceptance_programs("good"), ids=lambda p: p.name)
def test_rs274_reproduces_expected_calls(rs274, path):
    """The oracle itself: rs274 gives LinuxCNC's recorded answer for good/*.ngc."""
    expected = [re.sub(r"^\s*\d+\s+", "", line).strip() for line in
                Path(str(path) + ".expected").read_text().splitlines() if line.strip()]
    result = rs274.run(path)
    got = [f"N..... {name}({', '.join(args)})" for name, args in result.calls]
    assert result.ok
    assert [c.split("(")[0] for c in got] == [c.split("(")[0] for c in expected]
    arc_expected = [c for c in expected if "ARC_FEED" in c]
    arc_got = [c for c in got if "ARC_FEED" in c]
    assert arc_got == arc_expected


@pytest.mark.parametrize("path", lib.acceptance_programs("good"), ids=lambda p: p.name)
def test_good_programs_match_oracle(rs274, path, tmp_path):
    text = lib.substitute_expressions(path.read_text())
    original = rs274.run(path)
    substituted = tmp_path / "substituted.ngc"
    substituted.write_text(text)
    assert rs274.run(substituted).calls == original.calls  # the numbers are faithful
    ours = compare(rs274, text, tmp_path, path.name)
    assert [m["type"] for m in ours] == ["arc"]


@pytest.mark.parametrize("path", lib.acceptance_programs("quick"), ids=lambda p: p.name)
def test_quick_programs_match_oracle(rs274, path, tmp_path):
    ours = compare(rs274, path.read_text(), tmp_path, path.name)
    assert ours


@pytest.mark.parametrize("path", OWN_PROGRAMS, ids=lambda p: p.name)
def test_own_programs_match_oracle(rs274, path, tmp_path):
    ours = compare(rs274, path.read_text(), tmp_path, path.name)
    assert ours


def test_enough_own_programs():
    assert len(OWN_PROGRAMS) >= 10


# Our message for each LinuxCNC message of the bad set.
BAD_REASONS = {
    "Radius to end of arc differs from radius to start": "radius to end of arc differs",
    "Cannot do g1 with zero feed rate": "no feed rate",
    "R i j k words all missing for arc": "needs I/J",
}


@pytest.mark.parametrize("path", lib.acceptance_programs("bad"), ids=lambda p: p.name)
def test_bad_programs_rejected_by_both(rs274, path, tmp_path):
    text = path.read_text()
    expected = lib.expected_message(text)
    original = rs274.run(path)
    assert not original.ok and original.message == expected
    substituted = tmp_path / path.name
    substituted.write_text(lib.substitute_expressions(text))
    again = rs274.run(substituted)
    assert not again.ok and again.message.split(":")[0] == expected.split(":")[0]
    bad_line = 1 + [line.strip() for line in text.splitlines()].index(original.bad_line)
    keyword = next(v for k, v in BAD_REASONS.items() if expected.startswith(k))
    code, err = run_check(substituted)
    assert code == 2
    assert err.startswith(f"{substituted}:line {bad_line}: "), err
    assert keyword in err


def run_check(path: Path, *extra: str) -> Tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["check", str(path), "--no-limits", *extra])
    return code, err.getvalue()


@pytest.mark.parametrize("case", [c for c in CORPUS if c.linuxcnc_rejects],
                         ids=lambda c: c.name)
def test_corpus_rejections_agree_with_rs274(rs274, case, tmp_path):
    """Bad programs that are plain LinuxCNC G-code: rs274 rejects them too."""
    path = tmp_path / "bad.ngc"
    path.write_bytes(case.program + b"\nM2\n")
    result = rs274.run(path)
    assert not result.ok, f"rs274 accepted {case.program!r}"


# ------------------------------------------------ random programs, both ways

def random_program(rng: random.Random) -> str:
    """Random lines, arcs (I/J and R), unit and distance modes, G92 and pen changes."""
    lines = ["G17 G21 G90 G94", f"F{rng.choice([100, 250, 1200])}"]
    inch = False
    absolute = True
    x = y = 0.0  # program coordinates in the current units
    z_mm = 1.0  # the PREFIX line leaves Z at 1
    mode = "G0"  # the PREFIX line is a G0

    def motion(word: str, rest: str) -> str:
        """A motion line; the word is left out at times when it is the modal one."""
        nonlocal mode
        same = word == mode
        mode = word
        return rest if same and rng.random() < 0.3 else f"{word} {rest}"

    def z_word() -> str:
        """A Z word that changes Z: the canonical calls only show changes."""
        nonlocal z_mm
        # Z0 only as an exact absolute word: increments in inches land near 0.
        levels = (2.0, 1.0, -0.5, -1.0) + ((0.0,) if absolute else ())
        new_z = rng.choice([v for v in levels if v != z_mm])
        word = new_z / (25.4 if inch else 1.0)
        if not absolute:
            word -= z_mm / (25.4 if inch else 1.0)
        z_mm = new_z
        return f"Z{word:.6f}"

    def fmt(v: float) -> str:
        return f"{v:.4f}"

    def target(tx: float, ty: float) -> str:
        return f"X{fmt(tx)} Y{fmt(ty)}" if absolute else f"X{fmt(tx - x)} Y{fmt(ty - y)}"

    for _ in range(rng.randint(4, 14)):
        r = rng.random()
        size = 1 / 25.4 if inch else 1.0
        if r < 0.08:
            inch = not inch
            scale = 1 / 25.4 if inch else 25.4
            x, y = x * scale, y * scale
            lines.append("G20" if inch else "G21")
        elif r < 0.14:
            absolute = not absolute
            lines.append("G90" if absolute else "G91")
        elif r < 0.18:
            x, y = round(rng.uniform(-5, 5), 4), round(rng.uniform(-5, 5), 4)
            lines.append(f"G92 X{fmt(x)} Y{fmt(y)}")
        elif r < 0.22:
            lines.append(rng.choice(["M3", "M5"]))
        elif r < 0.28:
            lines.append(motion(rng.choice(["G0", "G1"]), z_word()))
        elif r < 0.55:
            tx = round(x + rng.uniform(-20, 20) * size, 4)
            ty = round(y + rng.uniform(-20, 20) * size, 4)
            extra = f" {z_word()}" if rng.random() < 0.2 else ""
            lines.append(motion(rng.choice(["G0", "G1"]), target(tx, ty) + extra))
            x, y = tx, ty
        else:
            kind = rng.choice(["G2", "G3"])
            radius = rng.uniform(2, 15) * size
            a0 = rng.uniform(0, 2 * math.pi)
            cx, cy = x - radius * math.cos(a0), y - radius * math.sin(a0)
            centre = f"I{fmt(cx - x)} J{fmt(cy - y)}"
            if rng.random() < 0.15:
                lines.append(f"{kind} {centre}")  # full circle
                mode = kind
                continue
            a1 = a0 + rng.uniform(0.2, 6.0)
            tx = round(cx + radius * math.cos(a1), 4)
            ty = round(cy + radius * math.sin(a1), 4)
            if rng.random() < 0.5:
                lines.append(motion(kind, f"{target(tx, ty)} {centre}"))
            else:
                chord = math.hypot(tx - x, ty - y)
                r_value = max(radius, chord / 2 + 0.01 * size) * rng.choice([1, -1])
                lines.append(motion(kind, f"{target(tx, ty)} R{fmt(r_value)}"))
            x, y = tx, ty
    if not any(re.match(r"(G[0-3] )?[XI]", line) for line in lines):
        lines.append("G91 G1 X1 Y1")  # an empty program is an error for the plotter
    lines.append("M2")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("seed", range(200))
def test_random_programs_match_oracle(rs274, seed, tmp_path):
    program = random_program(random.Random(seed))
    path = tmp_path / "random.ngc"
    path.write_text(with_prefix(program))
    result = rs274.run(path)
    code, err = run_check(path)
    assert result.ok == (code == 0), (
        f"rs274 {'accepts' if result.ok else 'rejects: ' + result.message}, "
        f"plotter check {'accepts' if code == 0 else 'rejects: ' + err}\n{program}")
    if result.ok:
        compare(rs274, program, tmp_path, f"random program {seed}:\n{program}")


# ------------------------------------------- the dialects where they are LinuxCNC's

def in_grbl_forms(program: str, rng: random.Random) -> str:
    """The program with grbl's pen (M3 S<power>, S<power>, M3 S0, S0) and the words
    grbl and LinuxCNC both take without a move (G54, coolant, path control) on
    lines of their own; pen changes are added, random_program makes few."""
    out, running = [], False

    def pen(word: str) -> str:
        nonlocal running
        if word == "M3":
            power = rng.choice([1, 255, 1000, 12.5])
            line = f"S{power}" if running and rng.random() < 0.5 else f"M3 S{power}"
            running = True
            return line
        line = rng.choice(["M5", "M3 S0"] + (["S0"] if running else []))
        running = running and line != "M5"
        return line

    for line in program.splitlines():
        if line != "M2" and rng.random() < 0.3:
            out.append(pen(rng.choice(["M3", "M5"])))
        out.append(pen(line) if line in ("M3", "M5") else line)
        if rng.random() < 0.1 and line != "M2":
            out.append(rng.choice(["G54", "M7", "M8", "M9", "G64", "G61"]))
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("seed", range(30))
@pytest.mark.parametrize("dialect", ["grbl", "marlin"])
def test_random_programs_match_oracle_in_dialects(rs274, dialect, seed, tmp_path):
    """grbl's pen and no-op words, and Marlin wherever it reads as LinuxCNC does,
    with the pen from Z at several thresholds."""
    program, pen_up_z = dialect_program(dialect, seed)
    path = tmp_path / "random.ngc"
    path.write_text(with_prefix(program))
    result = rs274.run(path)
    code, err = run_check(path, "--dialect", dialect, "--pen-up-z", str(pen_up_z))
    assert result.ok == (code == 0), (
        f"rs274 {'accepts' if result.ok else 'rejects: ' + result.message}, "
        f"plotter check {'accepts' if code == 0 else 'rejects: ' + err}\n{program}")
    if result.ok:
        compare(rs274, program, tmp_path, f"{dialect} program {seed}:\n{program}", dialect, pen_up_z)


def dialect_program(dialect: str, seed: int) -> Tuple[str, float]:
    rng = random.Random(1000 + seed)
    program = random_program(rng)
    if dialect == "grbl":
        program = in_grbl_forms(program, rng)
    return program, [0.0, 0.5, -0.75, 1.5][seed % 4]


@pytest.mark.parametrize("dialect", ["grbl", "marlin"])
def test_dialect_sweep_draws_and_lifts(dialect):
    """The programs above are no empty test: many draw, and the grbl ones use every pen form."""
    from plotter_bridge.gcode.dialect import GCodeOptions
    from plotter_bridge.gcode.parser import moves_of, parse
    texts = [dialect_program(dialect, seed) for seed in range(30)]
    drawing = sum(any(m.pen == "down" and not m.rapid for m in moves_of(
        parse(PREFIX + text, options=GCodeOptions(dialect, pen_up_z)))) for text, pen_up_z in texts)
    assert drawing >= 10
    if dialect == "grbl":
        lines = {line.split(" S")[0].split("S")[0] or "S" for text, _ in texts for line in text.splitlines()}
        assert {"M3", "M5", "S", "G54", "M8", "M9"} <= lines
