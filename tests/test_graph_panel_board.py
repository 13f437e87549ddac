"""The node graph drives the front-panel image as it drives the default one.

The mock board runs the panel image's core (firmware/build/panel, through
$PLOTTER_CORE_LIB), and the graph is otherwise the one users run:
serial_bridge streams machine lines to it, and a star and a circle
published on /plotter/shape come out on the step trace.
"""
import time

import pytest

from firmware_build import host_library
from ros_graph import read_trace, wait_until
from test_graph_end_to_end import (STEPS_PER_MM, check_trace_follows, reference_path, wait_idle_after,
                                   watched_graph)

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    with pytest.MonkeyPatch.context() as env:
        env.setenv("PLOTTER_CORE_LIB", str(host_library(PANEL="1")))
        with watched_graph(tmp_path_factory.mktemp("panel_graph")) as g:
            yield g


def test_the_mock_board_runs_the_panel_core(graph):
    lib = str(host_library(PANEL="1").resolve())
    wait_until(lambda: f"firmware core {lib}" in graph.board.output(), 10, "the mock board's start-up log")


@pytest.mark.parametrize("shape,x,y,size,clockwise", [
    ("star", 0.0, 0.0, 40.0, False),
    ("circle", 60.0, 50.0, 24.0, True),
])
def test_shapes_are_drawn_by_the_panel_core(graph, shape, x, y, size, clockwise):
    from plotter_interfaces.msg import ShapeGoal
    from plotter_shapes.geometry import build_shape

    wait_until(lambda: graph.shape_pub.get_subscription_count() > 0, 30, "shape_server subscription")
    wait_until(lambda: graph.probe.node.count_subscribers("program") > 0, 30, "gcode_streamer subscription")
    before = read_trace(graph.trace)
    start = (before[-1][1] / STEPS_PER_MM, before[-1][2] / STEPS_PER_MM) if before else (0.0, 0.0)
    t0 = time.monotonic()
    graph.shape_pub.publish(ShapeGoal(shape=shape, x=x, y=y, size=size, clockwise=clockwise))
    wait_idle_after(graph, t0)
    figure = build_shape(shape, x or None, y or None, size, clockwise)
    trace = read_trace(graph.trace)[len(before):]
    assert trace, "the board took no steps"
    check_trace_follows(trace, reference_path(figure, start))
    assert trace[-1][1:] == tuple(round(v * STEPS_PER_MM) for v in figure.end)
