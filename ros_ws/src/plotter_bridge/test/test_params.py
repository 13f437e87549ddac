"""What a node's parameter may be: ParamSpec, checked without a node."""
import math

from plotter_bridge.nodes.params import MACHINE, WORK_AREA, ParamSpec, check_machine, check_work_area


def test_numbers_take_integer_literals_and_refuse_the_rest():
    spec = ParamSpec("steps_per_mm", 80.0, "motor steps per mm", "steps/mm", low=0.0, above=True, high=10000.0)
    assert spec.check(100) is None and spec.coerce(100) == 100.0 and isinstance(spec.coerce(100), float)
    for bad in (0, 0.0, -80.0, 10001, math.nan, math.inf, "fast", True, [1.0]):
        why = spec.check(bad)
        assert why.startswith(f"steps_per_mm = {bad!r}: must be a number > 0 and <= 10000"), why


def test_whole_numbers_words_flags_and_lists():
    baud = ParamSpec("baud", 115200, "baud rate", low=300, high=1_000_000)
    assert baud.check(9600) is None and baud.check(9600.0) is None
    assert "whole number" in baud.check(9600.5) and baud.check(100) is not None
    kind = ParamSpec("machine", "cartesian", "kinematics", choices=("cartesian", "hanging"))
    assert kind.check("hanging") is None and "one of cartesian, hanging" in kind.check("delta")
    flag = ParamSpec("lookahead", True, "plan across commands")
    assert flag.check(False) is None and flag.check(1) is not None
    pulley = ParamSpec("pulley_left", [-150.0, 1150.0], "left pulley", length=2)
    assert pulley.check([-150, 1150]) is None and pulley.coerce([-150, 1150]) == [-150.0, 1150.0]
    assert pulley.check([1.0]) is not None and pulley.check([1.0, math.nan]) is not None


def test_descriptors_carry_description_range_and_read_only():
    for spec in (*MACHINE, *WORK_AREA):
        d = spec.descriptor()
        assert d.description and d.additional_constraints and d.dynamic_typing
        assert d.read_only == spec.read_only
        if spec.low is not None and spec.high is not None:
            assert d.floating_point_range or d.integer_range
    assert not MACHINE[1].descriptor(checks=False).read_only


def test_cross_checks_name_both_parameters():
    area = {s.name: s.default for s in WORK_AREA}
    assert check_work_area(area) is None
    assert "x_min = 250 must be below x_max = 200" in check_work_area({**area, "x_min": 250.0})
    machine = {s.name: s.default for s in MACHINE}
    assert check_machine(machine) is None
    assert "pulley_left" in check_machine({**machine, "pulley_left": [1000.0, 1150.0]})
