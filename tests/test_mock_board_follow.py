"""The mock board with a sheet under its pen (sim/mock_board.py, the core
built with FOLLOW=1): a host sends `F` over the pty as to the board, the
sensors read the sheet where the carriage is at every step, and the step
trace follows the line once round."""
from __future__ import annotations

import csv
import math
import re
import time

import pytest
import serial

from firmware_build import host_library
from follow_lines import circle, distances, path_length
from plotter_bridge.motion.kinematics import Machine
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.sim.mock_board import MockBoard, MockBoardConfig
from plotter_bridge.sim.sheet import Sheet

SPM = 80.0
WIDTH = 7.0
STATUS = re.compile(rb"<(\w+) X(-?\d+) Y(-?\d+) .* B(\d+) F(\d+) W(\d+)>")


def status(port: serial.Serial) -> tuple:
    port.reset_input_buffer()
    port.write(b"?")
    deadline = time.monotonic() + 10
    buf = b""
    while time.monotonic() < deadline:
        buf += port.read(256)
        m = STATUS.search(buf)
        if m:
            return m.groups()
    raise AssertionError(f"no status report in {buf!r}")


@pytest.mark.parametrize("start_offset", [(0.0, 0.0), (0.8, -0.6)], ids=["on the centre", "off it"])
def test_a_host_sends_f_and_the_mock_board_follows_the_sheet_once_round(tmp_path, start_offset):
    line = circle(100.0, 100.0, 12.0)
    start = (line.start[0] + start_offset[0], line.start[1] + start_offset[1])
    trace_path = tmp_path / "trace.csv"
    config = MockBoardConfig(speed=20.0, trace=str(trace_path), sheet=Sheet([line.points], WIDTH),
                             sheet_start_mm=start)
    board = MockBoard(config, FirmwareCore(host_library(FOLLOW="1")))
    board.start()
    try:
        with serial.Serial(board.port_path, 9600, timeout=0.1) as port:
            port.write(b"F 6 400 0 280\n")
            reply = b""
            deadline = time.monotonic() + 10
            while b"\n" not in reply.partition(b"ok")[2] and time.monotonic() < deadline:
                reply += port.read(64)
            assert b"ok Q" in reply, reply
            deadline = time.monotonic() + 120
            while True:
                mode, x, y, bits, follow, walked = status(port)
                if mode == b"Idle" and follow != b"1":
                    break
                assert time.monotonic() < deadline, "the follow did not end"
                time.sleep(0.2)
    finally:
        board.stop()
        board.close()
    assert follow == b"2"                                    # home
    with open(trace_path) as f:
        steps = [(start[0] + int(r["x_steps"]) / SPM, start[1] + int(r["y_steps"]) / SPM) for r in csv.DictReader(f)]
    assert int(walked) == len(steps)
    assert (int(x), int(y)) == (round((steps[-1][0] - start[0]) * SPM), round((steps[-1][1] - start[1]) * SPM))
    assert 0.98 <= path_length([start] + steps) / line.length <= 1.15
    assert distances(steps[::2], [line.points]).max() < WIDTH / 2
    assert math.dist(steps[-1], line.start) <= WIDTH / 2 + 1.0


def test_the_mock_board_refuses_a_sheet_it_cannot_follow():
    line = circle(100.0, 100.0, 12.0)
    with pytest.raises(ValueError, match="XY table only"):
        MockBoard(MockBoardConfig(sheet=Sheet([line.points], WIDTH), machine=Machine(kind="hanging")))
    with pytest.raises(ValueError, match="FOLLOW=1"):
        MockBoard(MockBoardConfig(sheet=Sheet([line.points], WIDTH)), FirmwareCore(host_library()))
