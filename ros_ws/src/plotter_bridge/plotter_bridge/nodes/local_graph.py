"""The plotter's node graph in one process, for the `plotter` command.

Starts the serial bridge and the G-code streamer (and, with a mock board,
the simulated board in a thread) on one executor, and runs programs through
the streamer's `run_program` action exactly as a separate client would;
board commands (a line follow's `F`) go to the bridge's `stream_commands`.
"""
from __future__ import annotations

import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, List, Optional, Tuple

import rclpy
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter import Parameter

from plotter_interfaces.action import RunProgram, StreamCommands

from plotter_bridge.gcode.dialect import GCodeOptions
from plotter_bridge.link.protocol import DEFAULT_BAUD
from plotter_bridge.nodes.action_client import ActionClient
from plotter_bridge.motion.kinematics import DEFAULT_Z_STEPS_PER_MM, Machine
from plotter_bridge.sim.faults import FaultSpec
from plotter_bridge.sim.mock_board import MockBoard, MockBoardConfig
from plotter_bridge.sim.sheet import Sheet

from .gcode_streamer import GCodeStreamer
from .late_clients import retry_late_answers
from .serial_bridge import SerialBridge
from .spinning import SpinThread
from .teardown import teardown_watchdog

ProgressCallback = Callable[[RunProgram.Feedback], None]
# s a job waits for the mock board's first status report before it goes to the streamer
# (which waits only 5 s for a connected board): the simulated board is a thread of this
# process, and a loaded machine can leave it unscheduled for seconds while the bridge's
# serial thread runs on (3.4 s seen beside CPU-bound processes).
MOCK_ANSWER_S = 30.0


@dataclass
class GraphOptions:
    port: str = ""                 # serial port or pyserial URL; "" with mock=True
    mock: bool = False
    baud: int = DEFAULT_BAUD
    steps_per_mm: float = 80.0
    trace: str = ""                # mock board step trace (CSV)
    namespace: str = "/plotter"
    faults: FaultSpec = field(default_factory=FaultSpec)   # mock board: faults on its serial line
    seq_log: str = ""              # mock board: sequence numbers of the commands started
    journal_dir: str = ""          # streamer's job journal ('' = the default)
    machine: str = "cartesian"     # or "hanging" (seed 003; the geometry's defaults)
    area: Optional[Tuple[float, float, float, float]] = None   # work area x_min, x_max, y_min, y_max (mm)
    z_axis: bool = False           # G-code Z moves a third axis (firmware ZAXIS=1), not the pen
    z_steps_per_mm: float = DEFAULT_Z_STEPS_PER_MM
    z_range: Optional[Tuple[float, float]] = None   # travel of Z, z_min, z_max (mm)
    gcode: GCodeOptions = field(default_factory=GCodeOptions)   # the programs' dialect and pen rules
    fit_arcs: bool = True          # the streamer's fit_arcs
    arc_tolerance: float = 0.02    # mm: the streamer's arc_tolerance
    sheet: Optional[Sheet] = None  # mock board: black lines under the pen (machine mm), for line following
    park: Optional[Tuple[float, float]] = (0.0, 0.0)   # where the pen waits at a pen change (None: where it is)


@dataclass
class ProgramResult:
    success: bool
    message: str
    x_mm: float
    y_mm: float
    job_id: str = ""
    z_mm: Optional[float] = None   # the Z axis at the end, when the board has one


class LocalGraph:
    def __init__(self, options: GraphOptions) -> None:
        self.options = options
        self.board: Optional[MockBoard] = None
        self._context = Context()
        rclpy.init(context=self._context, args=[])
        retry_late_answers()
        port = options.port
        self._tmp: Optional[tempfile.TemporaryDirectory] = None
        z_mode = "axis" if options.z_axis else "pen"
        if options.mock:
            # A fixed path (symlink) to the pty, so that an unplugged mock board comes back at it.
            self._tmp = tempfile.TemporaryDirectory(prefix="plotter-mock-")
            port = str(Path(self._tmp.name) / "board")
            machine = Machine(options.machine, options.steps_per_mm, z_mode=z_mode,
                              z_steps_per_mm=options.z_steps_per_mm)
            self.board = MockBoard(MockBoardConfig(baud=options.baud, trace=options.trace, link=port,
                                                   seq_log=options.seq_log, faults=options.faults,
                                                   machine=machine, sheet=options.sheet))
            self.board.start()
        if not port:
            raise ValueError("no port given (use --port PORT or --mock)")
        machine = [Parameter("steps_per_mm", value=float(options.steps_per_mm)),
                   Parameter("machine", value=options.machine),
                   Parameter("z_mode", value=z_mode),
                   Parameter("z_steps_per_mm", value=float(options.z_steps_per_mm))]
        self.bridge = SerialBridge(namespace=options.namespace, context=self._context,
                                   parameter_overrides=[Parameter("port", value=port),
                                                        Parameter("baud", value=int(options.baud)), *machine])
        streamer_params = list(machine)
        if options.area is not None:
            streamer_params += [Parameter(name, value=float(v)) for name, v in
                                zip(("x_min", "x_max", "y_min", "y_max"), options.area)]
        if options.z_range is not None:
            streamer_params += [Parameter(name, value=float(v)) for name, v in
                                zip(("z_min", "z_max"), options.z_range)]
        streamer_params += [Parameter("dialect", value=options.gcode.dialect),
                            *(Parameter(name, value=float(getattr(options.gcode, name)))
                              for name in ("pen_up_z", "marlin_pen_down", "marlin_pen_up"))]
        streamer_params += [Parameter("park_pen", value=options.park is not None)]
        if options.park is not None:
            streamer_params += [Parameter("park_x", value=float(options.park[0])),
                                Parameter("park_y", value=float(options.park[1]))]
        streamer_params += [Parameter("fit_arcs", value=bool(options.fit_arcs)),
                            Parameter("arc_tolerance", value=float(options.arc_tolerance))]
        if options.journal_dir:
            streamer_params.append(Parameter("journal_dir", value=options.journal_dir))
        self.streamer = GCodeStreamer(namespace=options.namespace, context=self._context,
                                      parameter_overrides=streamer_params)
        self.client_node = rclpy.create_node("plotter_cli", namespace=options.namespace,
                                             context=self._context)
        self._client = ActionClient(self.client_node, RunProgram, "run_program")
        self._commands = ActionClient(self.client_node, StreamCommands, "stream_commands")
        # Both action callbacks (bridge and streamer) wait for the board: spare threads keep
        # goal responses, feedback and topics flowing meanwhile.
        self._executor = MultiThreadedExecutor(num_threads=8, context=self._context)
        for node in (self.bridge, self.streamer, self.client_node):
            self._executor.add_node(node)
        self._spin = SpinThread(self._executor)

    def run_program(self, text: str, name: str = "program",
                    progress: Optional[ProgressCallback] = None,
                    timeout: float = 24 * 3600.0, resume: str = "") -> ProgramResult:
        goal = RunProgram.Goal()
        goal.program, goal.name, goal.resume = text, name, resume
        feedback = (lambda fb: progress(fb.feedback)) if progress else None
        r, why = self._run_goal(self._client, goal, feedback, timeout, "the gcode streamer", "program refused")
        if r is None:
            return ProgramResult(False, why, 0.0, 0.0)
        return ProgramResult(r.success, r.message, r.x_mm, r.y_mm, r.job_id, self.bridge.z_mm())

    def stream_commands(self, commands: List[str], timeout: float = 24 * 3600.0) -> Tuple[bool, str]:
        """Board commands as one job of the bridge's: (success, message) when it ends."""
        r, why = self._run_goal(self._commands, StreamCommands.Goal(commands=commands), None, timeout,
                                "the serial bridge", "the serial bridge refused the job (another one runs)")
        return (False, why) if r is None else (r.success, r.message)

    def _run_goal(self, client: ActionClient, goal, feedback, timeout: float, server: str, refused: str):
        """Send a goal and wait for its result: (result, "") or (None, why there is none).
        Ctrl-C or the time-out cancels it."""
        if not client.wait_for_server(timeout_sec=10.0):
            return None, f"{server} is not available"
        if self.board is not None:
            # Not answered by then: the job is refused, saying why.
            self.bridge.session.wait_connected(MOCK_ANSWER_S)
        done = threading.Event()
        send = client.send_goal_async(goal, feedback_callback=feedback)
        send.add_done_callback(lambda _: done.set())
        if not done.wait(10.0):
            return None, f"no answer from {server}"
        handle = send.result()
        if not handle.accepted:
            return None, refused
        finished = threading.Event()
        res = handle.get_result_async()
        res.add_done_callback(lambda _: finished.set())
        try:
            if not finished.wait(timeout):
                handle.cancel_goal_async()
                return None, "timed out"
        except KeyboardInterrupt:
            handle.cancel_goal_async()
            finished.wait(10.0)
            raise
        return res.result().result, ""

    def close(self) -> None:
        # The nodes and the action client go only once the spin thread has
        # left the executor: a callback still running, or a wait set still
        # holding the client, would fail on their destroyed handles.
        self._spin.stop()
        with teardown_watchdog():
            self._client.destroy()
            self._commands.destroy()
            for node in (self.client_node, self.streamer, self.bridge):
                node.destroy_node()
            if self.board is not None:
                self.board.stop()
            if self._tmp is not None:
                self._tmp.cleanup()
            rclpy.try_shutdown(context=self._context)

    def __enter__(self) -> "LocalGraph":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
