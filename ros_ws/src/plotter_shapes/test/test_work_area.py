"""A shape is checked against the work area before it becomes a program."""
import pytest

from plotter_bridge.gcode.limits import WorkArea
from plotter_shapes.geometry import goal_program
from plotter_shapes.work_area import extent, outside


def _program(*args):
    _, lines = goal_program(*args)
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("shape", ["diamond", "star", "circle", "cone", "car"])
def test_shapes_in_the_middle_fit_and_shapes_at_the_edge_do_not(shape):
    area = WorkArea()
    assert outside(_program(shape, 0.0, 0.0, 40.0), area) is None
    for x, y in ((199.0, 100.0), (1.0, 100.0), (100.0, 199.0), (100.0, 1.0)):
        why = outside(_program(shape, x, y, 40.0), area)
        assert why and why.startswith("does not fit the work area (X 0..200 mm, Y 0..200 mm)"), why


def test_a_circle_reaches_its_whole_radius():
    assert extent(_program("circle", 100.0, 100.0, 30.0)) == pytest.approx((70.0, 130.0, 70.0, 130.0))
    assert "X -50.0..250.0" in outside(_program("circle", 100.0, 100.0, 150.0), WorkArea())
    assert outside(_program("circle", 100.0, 100.0, 30.0), WorkArea(0, 120, 0, 200)) is not None
