"""The host's figures for the board's CPU (plotter_bridge.motion.planner
BoardCpu), with which the streamer plans short commands no faster than the
chip parses them and the mock board charges each line, are the image's:
firmware/tools/plan_cost.py (`make -C firmware plancost`) measures in s51
what a chord and an arc cost the main loop (receive, parse, plan, reply)
and their bytes the UART interrupt, and what a line step and an arc step
cost the step interrupt."""
import sys

import pytest

from firmware_build import FIRMWARE, mcu_image, require_s51
from plotter_bridge.motion.planner import BOARD_CPU

sys.path.insert(0, str(FIRMWARE / "tools"))
import plan_cost  # noqa: E402


def test_the_hosts_board_cpu_is_the_images():
    require_s51()
    m = plan_cost.model(mcu_image())
    assert BOARD_CPU.command_cycles == pytest.approx(m.command_cycles, rel=0.03)
    assert BOARD_CPU.arc_command_cycles == pytest.approx(m.arc_command_cycles, rel=0.03)
    assert BOARD_CPU.step_cycles == pytest.approx(m.step_cycles, rel=0.03)
    assert BOARD_CPU.arc_step_cycles == pytest.approx(m.arc_step_cycles, rel=0.03)
    assert BOARD_CPU.cycles_per_s == plan_cost.CYCLES_PER_S
