"""What a node graph on the mock board drew, held against what it was asked
to draw: the steps the firmware core takes for each program, compiled as
gcode_streamer compiles it (plotter_bridge.sim.expected).  Used by
scripts/demo.py and scripts/soak.py."""
from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Dict, List, Mapping, Sequence, Tuple

import yaml

from plotter_bridge.gcode.types import GCodeError
from plotter_bridge.motion.compiler import StreamerConfig
from plotter_bridge.nodes import gcode_streamer
from plotter_bridge.sim.expected import drawn_whole, program_steps
from plotter_shapes import shape_server_node
from plotter_shapes.geometry import goal_program

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))   # the node graph as processes
from node_processes import params_file  # noqa: E402

Point = Tuple[int, int]


def node_values(specs: Sequence, params: str) -> Dict[str, object]:
    """A node's parameter values as the graph starts it: its defaults, and
    over them the params file's section for every node."""
    with open(params) as f:
        section = yaml.safe_load(f)["/**"]["ros__parameters"]
    return {**{spec.name: spec.default for spec in specs}, **section}


def graph_configs() -> Tuple[StreamerConfig, Dict[str, object]]:
    """The streamer's compiler settings and the shape server's parameter
    values, as PlotterGraph starts them (config/plotter.yaml)."""
    params = params_file()
    config = gcode_streamer.streamer_config(node_values(gcode_streamer.SPECS, params))
    return config, node_values(shape_server_node.SPECS, params)


def figure_program(fig: Mapping, shapes: Mapping[str, object]) -> str:
    """The G-code shape_server publishes for a ShapeGoal given as a dict of its fields."""
    _, lines = goal_program(fig["shape"], fig["x"], fig["y"], fig["size"], fig.get("clockwise", False),
                            fig.get("reverse", False), fig.get("feed", 0.0),
                            default_feed=float(shapes["default_feed"]),
                            default_size=float(shapes["default_size"]),
                            default_centre=(float(shapes["work_x"]), float(shapes["work_y"])))
    return "\n".join(lines) + "\n"


def trace_rows(path: Path) -> int:
    return max(0, path.read_bytes().count(b"\n") - 1)     # less the header


def settled_rows(path: Path, quiet: float = 0.5, timeout: float = 30.0) -> int:
    """Steps in the trace once it has stopped growing for `quiet` seconds:
    the board at rest (the mock board flushes its trace every 0.1 s)."""
    end = time.monotonic() + timeout
    size, since = -1, time.monotonic()
    while time.monotonic() < end:
        now_size = path.stat().st_size
        if now_size != size:
            size, since = now_size, time.monotonic()
        elif time.monotonic() - since >= quiet:
            return trace_rows(path)
        time.sleep(0.05)
    raise TimeoutError(f"the step trace {path} still grows after {timeout:g} s")


def figure_problems(text: str, drawn: Sequence[Point], start: Point, config: StreamerConfig) -> List[str]:
    """Why a figure's slice of the trace is not its program drawn whole from
    `start` (steps), in words; none when it is."""
    try:
        expected = program_steps(text, config, start)
    except GCodeError as exc:
        return [f"its program is refused: {exc}"]
    why = drawn_whole(drawn, expected, start, config.steps_per_mm)
    return [f"not drawn whole: {why}"] if why else []
