#!/usr/bin/env python3
"""Big drawings: `plotter check` beside LinuxCNC's rs274 on the same files, wall time and peak
resident memory of each process, for random walks of 10k, 100k and 1M lines
(benchmarks/big_drawing.py).

    bash scripts/setup.sh && .venv/bin/python benchmarks/big_jobs.py [--sizes 10000 100000 1000000]

rs274 is fetched as tests/test_gcode_oracle.py does (Debian's linuxcnc-uspace, cached in
~/.cache/plotter-rs274); without it its columns say why.  Each figure is one run of its own
process (os.wait4 gives that process's own peak memory); the machine's load is printed first.
"""
from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "benchmarks")]

from big_drawing import write  # noqa: E402


@dataclass
class Run:
    seconds: float
    peak_mb: float
    code: int
    said: str


def measure(cmd: List[str], env: Optional[dict] = None) -> Run:
    """Wall time and the process's own peak resident memory (ru_maxrss, kB on Linux)."""
    with tempfile.TemporaryFile() as out:
        t0 = time.monotonic()
        proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.monotonic() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        said = out.read().decode(errors="replace")
    return Run(seconds, usage.ru_maxrss / 1024.0, proc.returncode, said)


def rs274_command():
    """(argv prefix, env) of rs274, or the reason it is not here."""
    try:
        from test_gcode_oracle import Unavailable, obtain_rs274
    except ImportError as exc:          # pytest missing: the oracle's module imports it
        return None, f"cannot load tests/test_gcode_oracle.py: {exc}"
    cache = Path(os.environ.get("PLOTTER_RS274_CACHE") or Path.home() / ".cache" / "plotter-rs274")
    try:
        tool = obtain_rs274(cache)
    except Unavailable as exc:
        return None, str(exc)
    return ([str(tool.binary), "-t", str(tool.table), "-g"], tool.env), ""


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    args = p.parse_args()
    plotter = shutil.which("plotter") or str(Path(sys.executable).parent / "plotter")
    oracle, why = rs274_command()
    load = os.getloadavg()[0]
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, load average {load:.1f} at the start, "
          f"Python {platform.python_version()}; rs274: {'found' if oracle else why}\n")
    print("| lines | MB | plotter check s | peak MB | rs274 s | peak MB | check / rs274 |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="plotter-big-") as tmp:
        for size in args.sizes:
            path = Path(tmp) / f"walk{size}.ngc"
            with open(path, "w") as f:
                write(size, f)
            check = measure([plotter, "check", str(path)])
            if check.code != 0:
                print(f"plotter check {path.name} exited {check.code}:\n{check.said[-2000:]}", file=sys.stderr)
            row = [f"{size}", f"{path.stat().st_size / 1e6:.1f}", f"{check.seconds:.2f}", f"{check.peak_mb:.0f}"]
            if oracle:
                prefix, env = oracle
                ref = measure([*prefix, str(path)], env=env)
                row += [f"{ref.seconds:.2f}", f"{ref.peak_mb:.0f}", f"{check.seconds / ref.seconds:.1f}"]
            else:
                row += ["-", "-", "-"]
            print("| " + " | ".join(row) + " |", flush=True)
            path.unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
