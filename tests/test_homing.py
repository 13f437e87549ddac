"""The homing cycle (link/homing.py) against the mock board's limit switches:
it finds each switch to the step, puts the origin the pull-off away from
it, the same place again after any drawing, and stops with the reason when
a switch is not there; `plotter home` runs it on a running graph, and only
when the bridge is told the machine has its switches (homing:=true)."""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)

from plotter_bridge.link.board_session import BoardSession, SessionConfig  # noqa: E402
from plotter_bridge.link.homing import HomingConfig, home, homing_config  # noqa: E402
from plotter_bridge.link.serial_port import open_port  # noqa: E402
from plotter_bridge.sim.mock_board import MockBoard, MockBoardConfig  # noqa: E402

BAUD = 115200
FAST = HomingConfig(seek_rate=4000, locate_rate=200, pull_off=160, travel=20000)


class Rig:
    """A mock board with switches, and a board session pumped in a thread, as serial_bridge has it."""

    def __init__(self, switches) -> None:
        self.board = MockBoard(MockBoardConfig(baud=BAUD, switches=switches))
        self.board.start()
        self.session = BoardSession(lambda: open_port(self.board.port_path, BAUD), SessionConfig(baud=BAUD))
        self._alive = True
        self._pump = threading.Thread(target=self._run, daemon=True)
        self._pump.start()
        assert self.session.wait_connected(30)

    def _run(self) -> None:
        while self._alive:
            self.session.pump()
            time.sleep(0.001)

    def draw(self, *commands: str) -> None:
        job = self.session.start_job(list(commands), [1] * len(commands))
        result = self.session.wait_job(job, 60)
        assert result is not None and result.success, result

    def close(self) -> None:
        self._alive = False
        self._pump.join(2)
        self.session.close()
        self.board.stop()


@pytest.fixture
def rig(request):
    r = Rig(request.param)
    yield r
    r.close()


@pytest.mark.parametrize("rig", [(-520, -330), (-7, -12000)], indirect=True,
                         ids=["near", "far-in-y"])
def test_homing_finds_each_switch_and_the_origin_is_the_same_place_every_time(rig):
    sx, sy = rig.board.config.switches
    ok, message = home(rig.session, FAST, log=lambda _: None)
    assert ok, message
    # The origin is the pull-off from each switch, counted in the carriage's own steps.
    assert rig.board._carriage == (sx + FAST.pull_off, sy + FAST.pull_off)
    assert (rig.session.link.status.x, rig.session.link.status.y) == (0, 0) and rig.session.position_known
    for commands in (["P 1", "L 1000 800 4000 0", "C 400 0 200 0 3000 0", "P 0"], ["L 37 -11 900 0"]):
        rig.draw(*commands)
        ok, message = home(rig.session, FAST, log=lambda _: None)
        assert ok, message
        assert rig.board._carriage == (sx + FAST.pull_off, sy + FAST.pull_off)
    assert f"X at -{FAST.pull_off}, Y at -{FAST.pull_off}" in message     # from the last origin, as found


@pytest.mark.parametrize("rig", [(-30000, -300)], indirect=True)
def test_a_switch_that_is_not_there_stops_the_cycle_with_the_reason(rig):
    ok, message = home(rig.session, HomingConfig(seek_rate=8000, travel=2000), log=lambda _: None)
    assert not ok and message == ("homing stopped: seek on X: no limit switch within 2000 steps; is it wired "
                                  "(firmware/README.md: P1.5)?")
    assert rig.board._carriage == (-2000, 0)          # it went as far as it was allowed, no further
    assert rig.session.link.status.state == "Idle"    # and the board takes the next command


@pytest.mark.parametrize("rig", [(-100, -100)], indirect=True)
def test_after_a_board_reset_homing_gives_back_the_position(rig):
    ok, _ = home(rig.session, FAST, log=lambda _: None)
    rig.draw("L 2000 1500 4000 0")
    rig.board.power_cycle()
    deadline = time.monotonic() + 10
    while rig.session.position_known and time.monotonic() < deadline:
        time.sleep(0.02)
    assert not rig.session.position_known           # the board's reset is seen: no job may run
    ok, message = home(rig.session, FAST, log=lambda _: None)
    assert ok, message
    assert rig.board._carriage == (-100 + FAST.pull_off, -100 + FAST.pull_off) and rig.session.position_known


def test_settings_are_checked_in_the_units_given():
    config = homing_config(1200, 120, 2, 250, 80)
    assert (config.seek_rate, config.locate_rate, config.pull_off, config.travel) == (1600, 160, 160, 20000)
    with pytest.raises(ValueError, match="travel = 40000: must be 1..32767"):
        homing_config(1200, 120, 2, 500, 80)
    with pytest.raises(ValueError, match="pull_off .* must be shorter than its travel"):
        HomingConfig(pull_off=500, travel=400)


# ---------------------------------------------------------------- on a running graph

@pytest.mark.ros
def test_plotter_home_on_a_running_graph(tmp_path):
    from node_processes import PlotterGraph, new_domain, wait_until
    from ros_graph import read_trace
    plotter = Path(__file__).resolve().parent.parent / ".venv" / "bin" / "plotter"
    domain = new_domain()
    env = dict(__import__("os").environ, ROS_DOMAIN_ID=str(domain))

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(plotter), *args], capture_output=True, text=True, timeout=300, env=env)

    for name in ("off", "on"):
        (tmp_path / name).mkdir()
    graph = PlotterGraph(domain, tmp_path / "off", board_args=("-p", "switches:=-4.5,-2"))
    try:
        r = run("home")
        assert r.returncode == 1 and "homing is off: set homing:=true" in r.stderr, r.stderr
    finally:
        graph.close()
    graph = PlotterGraph(domain, tmp_path / "on", board_args=("-p", "switches:=-4.5,-2"),
                         bridge_args=("-p", "homing:=true", "-p", "homing_seek:=3000.0"))
    try:
        r = run("home")
        assert r.returncode == 0 and "homed: the switches closed at X at -360, Y at -160 steps" in r.stdout, \
            r.stdout + r.stderr
        r = run("state")
        assert "x_mm: 0.0" in r.stdout and "y_mm: 0.0" in r.stdout and "position_known: True" in r.stdout, r.stdout
        # The carriage went to each switch and came back by the pull-off (2 mm): in motor steps from power-on,
        # the switches are at -360 and -160, the origin at -200 and 0.
        wait_until(lambda: graph.trace.exists() and graph.trace.stat().st_size > 0, 10, "the trace")
        steps = [(x, y) for _, x, y in read_trace(graph.trace)]
        assert min(x for x, _ in steps) == -360 and min(y for _, y in steps) == -160
        assert steps[-1] == (-200, 0), "the carriage rests the pull-off from each switch"
    finally:
        graph.close()
