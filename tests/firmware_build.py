"""Builds the firmware's host library (and 8051 images) once per test session.

Without arguments: the default build, firmware/build/.  With build options
(firmware/Makefile, e.g. INTERP="dda", DRIVE="phase3", ZAXIS="1", FOLLOW="1", BAUD="115200" or
CPU6T="1"), the
build of those options in its own directory, firmware/build/<options>/.
"""
import fcntl
import os
import shutil
import subprocess
from functools import lru_cache
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
FIRMWARE = REPO_ROOT / "firmware"

DEFAULTS = {"INTERP": "pbp", "DRIVE": "stepdir", "ZAXIS": "0", "FOLLOW": "0", "BAUD": "9600", "CPU6T": "0"}


# Options that are on/off flags: their directory name when on.
FLAG_NAMES = {"ZAXIS": "z", "FOLLOW": "follow", "BAUD": "b115200", "CPU6T": "6t"}


def build_dir(**options) -> Path:
    """firmware/build/ or firmware/build/<options>/, as the Makefile names it."""
    names = []
    for key, default in DEFAULTS.items():
        value = options.get(key, default)
        if value != default:
            names.append(FLAG_NAMES.get(key, value))
    return FIRMWARE / "build" / "-".join(names) if names else FIRMWARE / "build"


def _make_args(options):
    return [f"{k}={v}" for k, v in sorted(options.items()) if v != DEFAULTS.get(k)]


def make(*args: str) -> None:
    """make -C firmware, one at a time on this tree: test processes side by
    side (pytest-xdist workers) build the same files, generated sources
    included, and two makes writing one file leave it torn."""
    with open(FIRMWARE / "Makefile") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        subprocess.run(["make", "-s", "-C", str(FIRMWARE), *args], check=True)


@lru_cache(maxsize=None)
def _build(target: str, options: tuple) -> Path:
    opts = dict(options)
    path = build_dir(**opts) / target
    make(*_make_args(opts), str(path.relative_to(FIRMWARE)))
    return path


def host_library(**options) -> Path:
    """libplotter_core.so of the default build, or of the given build options."""
    return _build("libplotter_core.so", tuple(sorted(options.items())))


def mcu_image(**options) -> Path:
    """The 8051 image's base path (plotter, without .ihx) of the given build options."""
    return _build("plotter.ihx", tuple(sorted(options.items()))).with_suffix("")


def require_s51() -> None:
    """Skip the calling test when s51 (Debian package sdcc-ucsim) is missing;
    on CI (CI=true) that is a failure."""
    import pytest
    if shutil.which("s51") is None:
        reason = "s51 (Debian package sdcc-ucsim) is not installed"
        if os.environ.get("CI") == "true":
            pytest.fail(reason + " - required on CI", pytrace=False)
        pytest.skip(reason)


# A step pulse waits for the instruction under way or a masked copy of a multi-byte value: within
# this many machine cycles of the schedule when the UART is quiet.
QUIET_LATENCY = 32


def uart_step_delay(base: Path) -> int:
    """Machine cycles a step pulse may wait beyond QUIET_LATENCY while the UART works: the
    interrupts the chip takes before the step timer's at their shared level (the e-stop's and the
    UART's, firmware/tools/isr_share.py Arbitration), counted from the image's listings."""
    import sys
    sys.path.insert(0, str(FIRMWARE / "tools"))
    import isr_share
    import s51sim
    return isr_share.arbitration(s51sim.Symbols(base)).uart_delay()
