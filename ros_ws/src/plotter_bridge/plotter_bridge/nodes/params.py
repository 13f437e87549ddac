"""The machine's ROS parameters, declared the same way by every node that
needs them (mock_board, serial_bridge, gcode_streamer)."""
from __future__ import annotations

import math

from rcl_interfaces.msg import ParameterDescriptor

from plotter_bridge.motion.kinematics import DEFAULT_Z_STEPS_PER_MM, MACHINES, HangingGeometry, Machine

_DEFAULT = HangingGeometry()


def declare_machine(node) -> Machine:
    """Declare `machine`, `steps_per_mm`, the hanging geometry and the Z
    axis (`z_mode`, `z_steps_per_mm`); return the Machine."""
    d = ParameterDescriptor
    node.declare_parameter("machine", "cartesian", d(description=f"kinematics: {' | '.join(MACHINES)}"))
    node.declare_parameter("steps_per_mm", 80.0, d(description="cartesian: motor steps per millimetre, both axes"))
    node.declare_parameter("pulley_left", list(_DEFAULT.left),
                           d(description="hanging: left pulley [x, y], mm from the board origin"))
    node.declare_parameter("pulley_right", list(_DEFAULT.right),
                           d(description="hanging: right pulley [x, y], mm from the board origin"))
    node.declare_parameter("spool_circumference", _DEFAULT.spool_circumference,
                           d(description="hanging: string wound per spool turn, mm"))
    node.declare_parameter("pulses_per_rev", _DEFAULT.pulses_per_rev,
                           d(description="hanging: motor pulses per spool turn"))
    node.declare_parameter("z_mode", "pen", d(description="what G-code Z drives: pen (up/down) | axis "
                                                       "(a third axis, firmware built with ZAXIS=1)"))
    node.declare_parameter("z_steps_per_mm", DEFAULT_Z_STEPS_PER_MM, d(description="z_mode axis: motor steps per millimetre of Z"))
    g = lambda name: node.get_parameter(name).value  # noqa: E731
    left, right = [float(v) for v in g("pulley_left")], [float(v) for v in g("pulley_right")]
    numbers = [float(g("steps_per_mm")), float(g("spool_circumference")), float(g("pulses_per_rev")), *left, *right]
    if len(left) != 2 or len(right) != 2 or not all(math.isfinite(v) for v in numbers) \
            or min(numbers[:3]) <= 0 or left[0] >= right[0]:
        raise ValueError(f"bad machine parameters: steps_per_mm, spool, pulses, pulleys = {numbers}")
    return Machine(str(g("machine")), float(g("steps_per_mm")),
                   HangingGeometry((left[0], left[1]), (right[0], right[1]),
                                   float(g("spool_circumference")), float(g("pulses_per_rev"))),
                   str(g("z_mode")), float(g("z_steps_per_mm")))
