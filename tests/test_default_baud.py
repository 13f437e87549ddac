"""One baud rate across the firmware's default image and every host default.

A board flashed with `make flash` must answer a serial_bridge started with no
options, the launch file, config/plotter.yaml, `plotter --port` and the mock
board: each defaults to the rate the default image sets its UART to, worked
out in s51 from the registers the running image has set (s51 paces its UART
by its own rule, so the rate is read from Timer 1's reload, as the chip
would use it).

Skipped when s51 (Debian package sdcc-ucsim) is missing, except on CI.
"""
import re
import sys
from pathlib import Path

import pytest

from firmware_build import FIRMWARE, mcu_image, require_s51

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
STATUS = rb"<(\w+) [^>]*>[^\n]*\n"


def _sfr(sim, addr: int) -> int:
    out = sim.cmd(f"dump sfr 0x{addr:x} 0x{addr:x}")
    return int(re.search(rf"^0x{addr:x} \w+:.*?\b0x([0-9a-f]{{2}})\b", out, re.M).group(1), 16)


def default_image_baud() -> int:
    """The default image's UART rate, from its registers after start-up."""
    require_s51()
    with s51sim.Sim(mcu_image()) as sim:
        sim.go()
        assert sim.read_until(rb"\r\n").startswith(b"PLOTTER 8051")
        sim.write(b"?")
        assert re.search(rb"<Idle X0 Y0 ", sim.read_until(STATUS))
        sim.stop()
        tmod, th1, pcon, t2con, scon = (_sfr(sim, a) for a in (0x89, 0x8D, 0x87, 0xC8, 0x98))
    assert scon & 0xC0 == 0x40, "UART mode 1"
    assert tmod & 0xF0 == 0x20, "Timer 1 in 8-bit auto-reload"
    assert t2con & 0x30 == 0, "Timer 1, not Timer 2, clocks the UART"
    cycles_per_s = s51sim.CLOCK_HZ // 12
    per_bit = (16 if pcon & 0x80 else 32) * (256 - th1)
    assert cycles_per_s % per_bit == 0, "an exact rate"
    return cycles_per_s // per_bit


def test_every_host_default_is_the_default_images_rate():
    from plotter_bridge.link.protocol import DEFAULT_BAUD
    from plotter_bridge.sim.mock_board import MockBoardConfig
    assert default_image_baud() == DEFAULT_BAUD
    yaml = (REPO / "ros_ws/src/plotter_bridge/config/plotter.yaml").read_text()
    assert re.findall(r"^\s*baud:\s*(\d+)", yaml, re.M) == [str(DEFAULT_BAUD)]
    assert MockBoardConfig().baud == DEFAULT_BAUD


def test_the_nodes_and_the_plotter_command_default_to_it():
    pytest.importorskip("rclpy")
    import argparse
    from plotter_bridge.cli.run import _graph_options, connection_args
    from plotter_bridge.link.protocol import DEFAULT_BAUD
    from plotter_bridge.nodes.local_graph import GraphOptions
    from plotter_bridge.nodes.params import BAUD
    assert BAUD.default == DEFAULT_BAUD
    assert GraphOptions().baud == DEFAULT_BAUD
    parser = argparse.ArgumentParser()
    connection_args(parser)
    assert _graph_options(parser.parse_args(["--port", "/dev/ttyUSB0"])).baud == DEFAULT_BAUD
