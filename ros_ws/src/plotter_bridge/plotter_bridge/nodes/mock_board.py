"""mock_board: a simulated plotter board for tests and demos.

Creates a pseudo-terminal, prints its path and publishes it on `mock_port`
(std_msgs/String, transient local); behind it the firmware's own core runs in
real time (see sim/mock_board.py).  Parameters: `link` (also make a symlink to
the pty there, so a bridge can be started with port:=<link>), `trace` (CSV
of every step), `seq_log` (file of the sequence numbers of the commands the
board started), `baud` (byte rate of the simulated UART), `faults` (faults on
the serial line and board events, e.g. `drop=0.01,corrupt=0.01,dup=0.001,
unplug_at=4000,unplug_for=2,reset_at=9000`; see sim/faults.py).

`switches` ("X,Y" in mm from where the board is powered on, e.g. "-6.5,-4")
puts limit switches at the -X and -Y ends of an XY table: each closes at and
beyond its position, as the board's P1.5 and P1.7 (firmware/README.md).

`sheet` (a G-code file whose pen-down moves are black lines
`sheet_line_width_mm` wide) puts a sheet under the pen of an XY table for
line following: the board runs the core built with FOLLOW=1, the pen stands
at `sheet_start` ("X,Y" mm on the sheet) where the board is powered on, and
its three sensors, `sensor_radius_mm` from the pen, read the sheet at every
step (firmware/README.md, *Line following*).

Services `~/unplug` (the pty vanishes for `unplug_for` seconds and comes back
at the same link path) and `~/power_cycle` (the board resets) simulate the
same events on demand.
"""
from __future__ import annotations

import math
import sys
from typing import Optional, Tuple

from rclpy.node import Node
from std_msgs.msg import String
from std_srvs.srv import Trigger

from plotter_bridge.sim.faults import FaultSpec, parse_faults
from plotter_bridge.sim.mock_board import MockBoard, MockBoardConfig
from plotter_bridge.sim.sheet import SensorRing, Sheet, SheetError

from .main import DEFAULT_NAMESPACE, run_node
from .params import BAUD, MACHINE, NodeParameters, ParamSpec, all_of, check_machine, machine_of
from .qos import latched

SPECS = (
    ParamSpec("link", "", "path of a symlink to the pty ('' = none)", read_only=True),
    ParamSpec("trace", "", "CSV file of every step: t_s,x_steps,y_steps ('' = none)", read_only=True),
    BAUD,
    ParamSpec("seq_log", "", "file of the sequence numbers of the commands the board started, one a line "
                             "('' = none)", read_only=True),
    ParamSpec("faults", "", "serial faults and board events, e.g. drop=0.01,corrupt=0.01,dup=0.001,"
                            "delay=0.001,seed=1,unplug_at=STEPS,unplug_for=S,reset_at=STEPS", read_only=True),
    ParamSpec("unplug_for", 2.0, "how long the port stays away on ~/unplug", "s", low=0.0, high=3600.0),
    ParamSpec("switches", "", "limit switches at the -X and -Y ends: 'X,Y' in mm from the power-on position "
                              "('' = none)", read_only=True),
    ParamSpec("cpu", True, "charge each line the 8051's main-loop cycles (motion/planner.py BoardCpu), so that "
                           "short commands come no faster than the chip parses them; false: no time", read_only=True),
    ParamSpec("sheet", "", "line following: a G-code file whose pen-down moves are the black lines under the "
                           "pen ('' = none)", read_only=True),
    ParamSpec("sheet_line_width_mm", 7.0, "the sheet's lines' width", "mm", low=0.1, high=100.0, read_only=True),
    ParamSpec("sheet_start", "0,0", "where on the sheet the pen stands at power-on: 'X,Y' in mm", read_only=True),
    ParamSpec("sensor_radius_mm", 3.0, "the line sensors' distance from the pen", "mm", low=0.1, high=50.0,
              read_only=True),
    *MACHINE,
)


def switches_mm(text: str) -> Optional[Tuple[float, float]]:
    """'X,Y' in mm, or None for ''; ValueError naming what is wrong."""
    if not text.strip():
        return None
    x, y = point_mm("switches", text, "-6.5,-4")
    if x > 0.0 or y > 0.0:
        raise ValueError(f"switches = {text!r}: the switches are at or below the power-on position (X, Y <= 0)")
    return x, y


def check_switches(values) -> Optional[str]:
    try:
        switches_mm(str(values["switches"]))
    except ValueError as exc:
        return str(exc)
    if str(values["switches"]).strip() and values["machine"] != "cartesian":
        return "switches: only on the XY table (machine cartesian)"
    return None


def point_mm(name: str, text: str, example: str = "130,100") -> Tuple[float, float]:
    """'X,Y' in mm; ValueError naming the parameter and what is wrong."""
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"{name} = {text!r}: two numbers 'X,Y' in mm, e.g. '{example}'") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{name} = {text!r}: finite numbers")
    return x, y


def check_sheet(values) -> Optional[str]:
    try:
        point_mm("sheet_start", str(values["sheet_start"]))
    except ValueError as exc:
        return str(exc)
    if str(values["sheet"]).strip() and values["machine"] != "cartesian":
        return "sheet: line following runs on the XY table only (machine cartesian)"
    return None


def load_sheet(values) -> Optional[Sheet]:
    """The sheet of the parameters, or None; ValueError (SheetError) naming the file and what is wrong."""
    path = str(values["sheet"]).strip()
    if not path:
        return None
    try:
        return Sheet.from_gcode(path, float(values["sheet_line_width_mm"]))
    except OSError as exc:
        raise SheetError(f"sheet = {path!r}: {exc.strerror or exc}") from None


def check_faults(values) -> Optional[str]:
    try:
        parse_faults(str(values["faults"]))
    except ValueError as exc:
        return f"faults = {values['faults']!r}: {exc}"
    return None


class MockBoardNode(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("mock_board", namespace=namespace, **kwargs)
        checks = all_of(check_machine, check_faults, check_switches, check_sheet)
        self.params = NodeParameters(self, SPECS, cross=checks)
        p = self.params
        machine = machine_of(p.values())
        switches = switches_mm(str(p["switches"]))
        config = MockBoardConfig(baud=int(p["baud"]), link=str(p["link"]), trace=str(p["trace"]),
                                 seq_log=str(p["seq_log"]), faults=parse_faults(str(p["faults"])),
                                 machine=machine, cpu=bool(p["cpu"]),
                                 switches=None if switches is None else
                                 (math.floor(switches[0] * machine.steps_per_mm),
                                  math.floor(switches[1] * machine.steps_per_mm)),
                                 sheet=load_sheet(p.values()),
                                 sheet_start_mm=point_mm("sheet_start", str(p["sheet_start"])),
                                 sensors=SensorRing(float(p["sensor_radius_mm"])))
        self.board = MockBoard(config)
        self.create_publisher(String, "mock_port", latched()).publish(String(data=self.board.port_path))
        self.create_service(Trigger, "~/unplug", self._srv_unplug)
        self.create_service(Trigger, "~/power_cycle", self._srv_power_cycle)
        self.board.start()
        if config.faults != FaultSpec():
            self.get_logger().info(f"faults: {config.faults}")
        where = f" (link {config.link})" if config.link else ""
        print(f"mock board on {self.board.port_path}{where}", flush=True)
        self.get_logger().info(f"mock board on {self.board.port_path}{where}, "
                               f"firmware core {self.board.core.library}")

    def _srv_unplug(self, request, response):
        seconds = float(self.params["unplug_for"])
        self.board.unplug(seconds)
        response.success, response.message = True, f"port away for {seconds:g} s"
        return response

    def _srv_power_cycle(self, request, response):
        self.board.power_cycle()
        response.success, response.message = True, "board reset"
        return response

    def destroy_node(self) -> None:
        self.board.stop()
        c = self.board.fault_counts()
        if c.total or self.board.unplugs or self.board.resets:
            print(f"mock board faults: {c.dropped} dropped, {c.corrupted} corrupted, {c.duplicated} "
                  f"duplicated, {c.delayed} delayed of {c.bytes} bytes; {self.board.unplugs} unplugs, "
                  f"{self.board.resets} resets", flush=True)
        super().destroy_node()


def main(args=None) -> int:
    return run_node(MockBoardNode, "mock_board", args)


if __name__ == "__main__":
    sys.exit(main())
