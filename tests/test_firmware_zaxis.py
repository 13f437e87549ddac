"""The Z axis: the firmware build option ZAXIS=1 (firmware/README.md).

A third axis with its own step and direction pins (P1.5, P1.6), moved alone
by the command `Z dz [feed [exit]]` (firmware/PROTOCOL.md), through the same
ramp as the lines; the status report gains a Z field after Y.  Checked in
the host build and on the real image in the s51 simulator (VCD trace of
port 1): Z moves only on Z commands and by exactly dz, its pulses and
direction on their pins, the status and the board's RAM agree, and X and Y
move step for step as the default build moves them for the same commands
without the Z ones - XY interpolation unchanged.  The s51 part is skipped
when s51 (Debian package sdcc-ucsim) is missing, except on CI (CI=true).
"""
import re
import sys

import pytest

from firmware_build import FIRMWARE, host_library, mcu_image, require_s51
from plotter_bridge.sim.firmware_core import FirmwareCore

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

X_STEP, X_DIR, Y_STEP, Y_DIR, PEN, Z_STEP, Z_DIR = 0x01, 0x02, 0x04, 0x08, 0x10, 0x20, 0x40
STATUS = re.compile(r"<(\w+) X(-?\d+) Y(-?\d+) Z(-?\d+) Q(\d+) N(\d+) S(\d+) P(\d+) U(\d+) A(\d+)>")
REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"

COMMANDS = ["L 30 20", "Z -15", "P 1", "C 10 10 10 0", "Z 40 500", "L -10 5", "Z -7 300 0", "P 0"]
END = (30, 35, 18)


def xy_commands():
    return [c for c in COMMANDS if not c.startswith("Z")]


def host_steps(library, commands, z=False):
    """Per step: ("x"|"y"|"z", +1/-1), and the end position."""
    core = FirmwareCore(library)
    pos_z = (lambda: core.position_z) if z else (lambda: 0)
    try:
        core.transmitted()
        out = []
        (x1, y1), z1 = core.position, pos_z()
        for _ in core.interrupts(commands):
            (x0, y0), z0 = (x1, y1), z1
            (x1, y1), z1 = core.position, pos_z()
            for axis, d in (("x", x1 - x0), ("y", y1 - y0), ("z", z1 - z0)):
                if d:
                    out.append((axis, d))
        assert b"err" not in core.transmitted()
        return out, (*core.position, pos_z())
    finally:
        core.close()


def test_host_build_moves_z_alone_and_xy_as_the_default():
    steps, end = host_steps(host_library(ZAXIS="1"), COMMANDS, z=True)
    assert end == END
    assert sum(1 for a, d in steps if a == "z") == 15 + 40 + 7
    default, default_end = host_steps(host_library(), xy_commands())
    assert [s for s in steps if s[0] != "z"] == default
    assert default_end[:2] == END[:2]


def test_host_build_refuses_bad_z_commands():
    core = FirmwareCore(host_library(ZAXIS="1"))
    try:
        core.transmitted()
        for line, code in (("Z", 6), ("Z 1 2 3 4", 6), ("Z 40000", 11), ("Z 5 -3", 11)):
            core.receive(line.encode() + b"\n")
            core.poll(3)
            assert f"err E{code} ".encode() in core.transmitted(), line
    finally:
        core.close()


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


@pytest.fixture(scope="module")
def board(tmp_path_factory):
    require_s51()
    vcd = str(tmp_path_factory.mktemp("z") / "p1.vcd")
    with s51sim.Sim(mcu_image(ZAXIS="1"), vcd=vcd) as sim:
        sim.read_until(rb"\r\n")
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
    return dict(replies=replies, status=status, ram=ram, vcd=vcd)


def board_steps(vcd):
    out, prev = [], None
    for t, v in s51sim.read_vcd(vcd)["P1"]:
        if prev is not None:
            rising = v & ~prev & (X_STEP | Y_STEP | Z_STEP)
            if rising:
                assert rising in (X_STEP, Y_STEP, Z_STEP), "one axis per step"
                axis, dirbit = {X_STEP: ("x", X_DIR), Y_STEP: ("y", Y_DIR), Z_STEP: ("z", Z_DIR)}[rising]
                out.append((axis, -1 if v & dirbit else 1))
        prev = v
    return out


def test_board_moves_z_on_its_pins_and_reports_it(board):
    assert all(r.startswith("ok") for r in board["replies"]), board["replies"]
    s = board["status"]
    assert s.group(1) == "Idle"
    assert tuple(int(s.group(k)) for k in (2, 3, 4)) == END
    assert board["ram"] == END[:2]
    got = board_steps(board["vcd"])
    want, _ = host_steps(host_library(ZAXIS="1"), COMMANDS, z=True)
    assert got == want
    assert sum(d for a, d in got if a == "z") == END[2]
