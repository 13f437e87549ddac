"""Direct phase drive: the firmware build option DRIVE (firmware/README.md).

The step interrupt energises the motor windings itself, through port pins,
instead of sending step and direction pulses to a driver: the X windings on
P1.0-P1.2 (three phases) or P1.0-P1.3 (two-phase unipolar), the Y windings
on P2.0-P2.2 / P2.0-P2.3, the pen on P1.4 as in the default build.  One step
is one move along the sequence (seed 002's three-phase motors):

- phase3: single excitation A, B, C;
- phase3d: double excitation A, AB, B, BC, C, CA (half the step angle);
- unipolar: two-phase unipolar half steps A, AB, B, BA', A', A'B', B', B'A.

Checked for each, in the host build and on the real image in the s51
simulator (VCD trace of ports 1 and 2): every change of a motor's windings
is one move forwards or backwards along its sequence, never a skip or an
unknown pattern, and the windings are never all off; the moves, counted,
give the position the board reports and the commanded end; step by step
they are the path of the host build of the same core; the pen follows its
commands.  The s51 part is skipped when s51 (Debian package sdcc-ucsim) is
missing, except on CI (CI=true), where that is a failure.
"""
import re
import sys

import pytest

from firmware_build import FIRMWARE, host_library, mcu_image, require_s51
from plotter_bridge.sim.firmware_core import FirmwareCore

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

# The winding patterns of each build option, in sequence order (bit 0 = the
# first winding: A, then B, C for three phases; A, B, A', B' for unipolar).
DRIVES = {
    "phase3": (0x07, [0b001, 0b010, 0b100]),
    "phase3d": (0x07, [0b001, 0b011, 0b010, 0b110, 0b100, 0b101]),
    "unipolar": (0x0F, [0b0001, 0b0011, 0b0010, 0b0110, 0b0100, 0b1100, 0b1000, 0b1001]),
}
PEN = 0x10                                  # P1.4
STATUS = re.compile(r"<(\w+) X(-?\d+) Y(-?\d+) Q(\d+) N(\d+) S(\d+) P(\d+) U(\d+) A(\d+)>")
REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"

# Both directions on both axes; a quarter and a three-quarter circle turn
# both axes round.
COMMANDS = ["L 13 -7", "P 1", "C 10 10 10 0", "A -10 10 0 10", "L -20 3", "P 0"]
END = (-7, 16)


def move(seq, old, new):
    """+1 or -1: new is the pattern after, resp. before, old in seq."""
    k = seq.index(old)
    if new == seq[(k + 1) % len(seq)]:
        return 1
    if new == seq[(k - 1) % len(seq)]:
        return -1
    raise AssertionError(f"{old:04b} -> {new:04b} is not one move along the sequence")


def host_path(drive):
    """Per step of the host build of the core: (dx, dy), and ("pen", down);
    the windings checked after every step."""
    bits, seq = DRIVES[drive]
    core = FirmwareCore(host_library(DRIVE=drive))
    lib = core._lib
    try:
        assert lib.core_drive() == list(DRIVES).index(drive) + 1
        core.transmitted()
        x_pat, y_pat = lib.core_port() & bits, lib.core_port2() & bits
        assert (x_pat, y_pat) == (seq[0], seq[0]), "winding A energised at power-on"
        out, pen = [], False
        x1, y1 = core.position
        for _ in core.interrupts(COMMANDS):
            x0, y0 = x1, y1
            x1, y1 = core.position
            nx, ny = lib.core_port() & bits, lib.core_port2() & bits
            assert (move(seq, x_pat, nx) if nx != x_pat else 0) == x1 - x0
            assert (move(seq, y_pat, ny) if ny != y_pat else 0) == y1 - y0
            x_pat, y_pat = nx, ny
            if (x1, y1) != (x0, y0):
                out.append((x1 - x0, y1 - y0))
            if core.pen_down != pen:
                pen = core.pen_down
                out.append(("pen", pen))
        return out, core.position
    finally:
        core.close()


@pytest.mark.parametrize("drive", list(DRIVES))
def test_host_build_moves_the_windings_along_the_sequence(drive):
    path, end = host_path(drive)
    assert end == END
    assert sum(1 for s in path if s[0] != "pen") == (13 + 7) + 20 + 60 + (20 + 3)


@pytest.fixture(scope="module")
def s51():
    require_s51()


def wait_idle(sim):
    """The status report once the board is idle."""
    for _ in range(400):
        sim.write(b"?")
        try:
            status = STATUS.search(sim.read_until(rb">[^\n]*\n", timeout=3).decode())
        except TimeoutError:                # a "?" lost while the interrupt ran: ask again
            continue
        if status.group(1) == "Idle":
            return status
    raise AssertionError("the board did not come to rest")


def board_run(drive, vcd):
    base = mcu_image(DRIVE=drive)
    with s51sim.Sim(base, vcd=vcd, extra_signals=("sfr[0xa0]",)) as sim:
        banner = sim.read_until(rb"\r\n").decode()
        sim.vcd_start()
        replies = []
        for command in COMMANDS:
            # One at a time, each to an idle board.
            status = wait_idle(sim)
            sim.write(command.encode() + b"\n")
            replies.append(sim.read_until(REPLY).decode().strip())
        status = wait_idle(sim)
        sim.vcd_stop()
        ram = (sim.int32("_pos_x"), sim.int32("_pos_y"))
    return banner, replies, status, ram


def board_path(drive, vcd):
    """The host_path list, rebuilt from the port 1 and port 2 trace."""
    bits, seq = DRIVES[drive]
    ev = s51sim.read_vcd(vcd)
    merged = sorted([(t, 1, v) for t, v in ev["P1"]] + [(t, 2, v) for t, v in ev["P2"]],
                    key=lambda e: (e[0], e[1]))
    out, last = [], {}
    for t, port, v in merged:
        if port not in last:
            assert v & bits == seq[0], "winding A energised at power-on"
        else:
            old = last[port]
            if (v ^ old) & bits:
                assert v & bits in seq, f"pattern {v & bits:04b} is not in the sequence"
                d = move(seq, old & bits, v & bits)
                out.append((d, 0) if port == 1 else (0, d))
            if port == 1 and (v ^ old) & PEN:
                out.append(("pen", bool(v & PEN)))
        last[port] = v
    return out


@pytest.mark.parametrize("drive", list(DRIVES))
def test_board_drives_the_windings_and_reaches_the_end(s51, drive, tmp_path):
    vcd = str(tmp_path / f"{drive}.vcd")
    banner, replies, status, ram = board_run(drive, vcd)
    assert banner.startswith("PLOTTER 8051 1.0 ready")
    assert all(r.startswith("ok") for r in replies), replies
    assert status.group(1) == "Idle"
    assert (int(status.group(2)), int(status.group(3))) == END
    assert ram == END
    got = board_path(drive, vcd)
    x = sum(s[0] for s in got if s[0] != "pen")
    y = sum(s[1] for s in got if s[0] != "pen")
    assert (x, y) == END, "the position counted from the windings"
    want, _ = host_path(drive)
    assert got == want, "step by step the host build's path"
    assert [s for s in got if s[0] == "pen"] == [("pen", True), ("pen", False)]
