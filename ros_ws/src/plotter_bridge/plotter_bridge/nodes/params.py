"""The parameters of the plotter's nodes, declared and checked in one way.

Each parameter is a ParamSpec: its description, unit and allowed values go
into its descriptor (`ros2 param describe`), and the same spec checks a value
wherever it comes from.  At start-up (`-p`, `--params-file`) a bad value
ends the node with one line naming the parameter and what it may be; while
the node runs, `ros2 param set` is refused with that reason, or applied.
Parameters a node cannot apply while running are read-only.

Numbers take integer literals too (`-p steps_per_mm:=100`, what everyone
types): a parameter declared with a float default would otherwise refuse an
integer with a type error, so numeric parameters are declared with dynamic
typing and their type is checked here instead.

MACHINE is the machine every node but shape_server must agree on; WORK_AREA
the area the streamer checks programs against and the shape server checks
shapes against.  config/plotter.yaml holds their values once for all nodes.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.node import Node

from plotter_bridge.link.protocol import DEFAULT_BAUD
from plotter_bridge.motion.kinematics import DEFAULT_Z_STEPS_PER_MM, MACHINES, HangingGeometry, Machine

Value = Union[bool, int, float, str, List[float]]
CrossCheck = Callable[[Mapping[str, Value]], Optional[str]]


class BadParameter(ValueError):
    """A parameter value a node cannot start with; the text names it and what it may be."""


@dataclass(frozen=True)
class ParamSpec:
    name: str
    default: Value
    description: str
    unit: str = ""
    low: Optional[float] = None     # numbers: the least allowed value
    high: Optional[float] = None    # numbers: the greatest allowed value
    above: bool = False             # numbers: strictly greater than `low`
    choices: Tuple[str, ...] = ()   # text: the allowed words
    read_only: bool = False         # the node cannot apply a change while running
    length: int = 0                 # number lists: how many numbers

    @property
    def kind(self) -> type:
        return type(self.default)

    def allowed(self) -> str:
        """What a value may be, in words: "a number > 0 and <= 10000"."""
        if self.kind is bool:
            return "true or false"
        if self.kind is str:
            return f"one of {', '.join(self.choices)}" if self.choices else "text"
        if self.kind is list:
            return f"a list of {self.length} numbers"
        noun = "a whole number" if self.kind is int else "a number"
        bounds = []
        if self.low is not None:
            bounds.append(f"> {self.low:g}" if self.above else f">= {self.low:g}")
        if self.high is not None:
            bounds.append(f"<= {self.high:g}")
        return " and ".join([f"{noun} {bounds[0]}" if bounds else noun, *bounds[1:]])

    def check(self, value: object) -> Optional[str]:
        """Why `value` cannot be this parameter's value, or None."""
        if not self._fits(value):
            unit = f", {self.unit}" if self.unit else ""
            return f"{self.name} = {value!r}: must be {self.allowed()} ({self.description}{unit})"
        return None

    def _fits(self, value: object) -> bool:
        if self.kind is bool:
            return isinstance(value, bool)
        if self.kind is str:
            return isinstance(value, str) and (not self.choices or value in self.choices)
        if self.kind is list:
            return (isinstance(value, (list, tuple)) and len(value) == self.length
                    and all(_is_number(v) and math.isfinite(v) for v in value))
        if not _is_number(value) or not math.isfinite(value):
            return False
        if self.kind is int and value != int(value):
            return False
        if self.low is not None and (value <= self.low if self.above else value < self.low):
            return False
        return self.high is None or value <= self.high

    def coerce(self, value: Value) -> Value:
        """A checked value in the spec's own type (an integer literal for a float is a float)."""
        if self.kind is float:
            return float(value)
        if self.kind is int:
            return int(value)
        if self.kind is list:
            return [float(v) for v in value]
        return value

    def descriptor(self, checks: bool = True) -> ParameterDescriptor:
        """The parameter's descriptor; without `checks`, neither its range
        nor read_only (see NodeParameters)."""
        unit = f" [{self.unit}]" if self.unit else ""
        d = ParameterDescriptor(name=self.name, description=self.description + unit,
                                additional_constraints=self.allowed(), read_only=self.read_only and checks,
                                dynamic_typing=True)
        # A range shows the bounds (a bound that is itself excluded, "> 0",
        # is in additional_constraints and checked by the spec).
        if checks and self.low is not None and self.high is not None:
            if self.kind is float:
                d.floating_point_range = [FloatingPointRange(from_value=float(self.low),
                                                             to_value=float(self.high), step=0.0)]
            elif self.kind is int:
                d.integer_range = [IntegerRange(from_value=int(self.low), to_value=int(self.high), step=1)]
        return d


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class NodeParameters:
    """The declared parameters of one node and their current, checked values.

    `cross` checks what single values cannot (x_min below x_max); it sees
    every value, the new ones with the current ones.  `on_change` is called
    with the names of the parameters a runtime change set, after they are
    set (the node applies them there)."""

    def __init__(self, node: Node, specs: Sequence[ParamSpec], cross: Optional[CrossCheck] = None,
                 on_change: Optional[Callable[[List[str]], None]] = None) -> None:
        self._specs: Dict[str, ParamSpec] = {s.name: s for s in specs}
        self._cross = cross
        self._on_change = on_change
        self._lock = threading.Lock()
        self._values: Dict[str, Value] = {}
        self._declared = False
        self._refusal = ""
        node.add_on_set_parameters_callback(self._check_set)
        for spec in specs:
            # Declared first without the range (rclpy would check it before
            # the spec does, in words of its own), then given its whole descriptor.
            self._refusal = ""
            try:
                node.declare_parameter(spec.name, spec.default, spec.descriptor(checks=False))
            except ParameterException as exc:
                raise BadParameter(self._refusal or str(exc)) from None
            node.set_descriptor(spec.name, spec.descriptor())
            self._values[spec.name] = spec.coerce(node.get_parameter(spec.name).value)
        why = cross(self._values) if cross else None
        if why:
            raise BadParameter(why)
        self._declared = True
        node.add_post_set_parameters_callback(self._applied)

    def __getitem__(self, name: str) -> Value:
        with self._lock:
            return self._values[name]

    def values(self) -> Dict[str, Value]:
        with self._lock:
            return dict(self._values)

    def _check_set(self, params) -> SetParametersResult:
        with self._lock:
            candidate = dict(self._values)
        mine = [p for p in params if p.name in self._specs]
        for p in mine:
            spec = self._specs[p.name]
            why = spec.check(p.value)
            if why:
                self._refusal = why
                return SetParametersResult(successful=False, reason=why)
            candidate[p.name] = spec.coerce(p.value)
        if mine and self._declared and self._cross:
            why = self._cross(candidate)
            if why:
                return SetParametersResult(successful=False, reason=why)
        return SetParametersResult(successful=True)

    def _applied(self, params) -> None:
        names = [p.name for p in params if p.name in self._specs]
        if not names:
            return
        with self._lock:
            for p in params:
                if p.name in self._specs:
                    self._values[p.name] = self._specs[p.name].coerce(p.value)
        if self._on_change:
            self._on_change(names)


def ordered(values: Mapping[str, Value], pairs: Iterable[Tuple[str, str]], unit: str = "mm") -> Optional[str]:
    """Cross-check: each (low, high) pair of parameters strictly increasing."""
    for lo, hi in pairs:
        if values[lo] >= values[hi]:
            return f"{lo} = {values[lo]:g} must be below {hi} = {values[hi]:g} ({unit})"
    return None


# --- the machine: every node that converts between mm and steps ------------------------
_DEFAULT = HangingGeometry()
MACHINE = (
    ParamSpec("machine", "cartesian", "kinematics of the machine", choices=tuple(MACHINES), read_only=True),
    ParamSpec("steps_per_mm", 80.0, "cartesian: motor steps per millimetre, both axes", "steps/mm",
              low=0.0, above=True, high=10000.0, read_only=True),
    ParamSpec("pulley_left", list(_DEFAULT.left), "hanging: left pulley [x, y] from the board origin", "mm",
              length=2, read_only=True),
    ParamSpec("pulley_right", list(_DEFAULT.right), "hanging: right pulley [x, y] from the board origin", "mm",
              length=2, read_only=True),
    ParamSpec("spool_circumference", _DEFAULT.spool_circumference, "hanging: string wound per spool turn", "mm",
              low=0.0, above=True, high=10000.0, read_only=True),
    ParamSpec("pulses_per_rev", _DEFAULT.pulses_per_rev, "hanging: motor pulses per spool turn", "pulses",
              low=0.0, above=True, high=1e6, read_only=True),
    ParamSpec("z_mode", "pen", "what G-code Z drives: the pen (up/down), or a third axis (firmware ZAXIS=1)",
              choices=("pen", "axis"), read_only=True),
    ParamSpec("z_steps_per_mm", DEFAULT_Z_STEPS_PER_MM, "z_mode axis: motor steps per millimetre of Z", "steps/mm",
              low=0.0, above=True, high=10000.0, read_only=True),
)


def check_machine(values: Mapping[str, Value]) -> Optional[str]:
    left, right = values["pulley_left"], values["pulley_right"]
    if left[0] >= right[0]:
        return f"pulley_left = {list(left)} must be left of pulley_right = {list(right)} (mm)"
    return None


def machine_of(values: Mapping[str, Value]) -> Machine:
    left, right = values["pulley_left"], values["pulley_right"]
    return Machine(str(values["machine"]), float(values["steps_per_mm"]),
                   HangingGeometry((left[0], left[1]), (right[0], right[1]),
                                   float(values["spool_circumference"]), float(values["pulses_per_rev"])),
                   str(values["z_mode"]), float(values["z_steps_per_mm"]))


# The serial line's rate, for the bridge and the mock board alike.
BAUD = ParamSpec("baud", DEFAULT_BAUD, f"baud rate of the serial line ({DEFAULT_BAUD}: the firmware's default "
                 "image; 115200 for firmware built with BAUD=115200)", "baud", low=300, high=1_000_000,
                 read_only=True)


# --- the work area: the streamer checks programs, the shape server shapes ---------------
COORDINATE = 1e5     # mm: any place a plotter could reach, well inside the firmware's step range
WORK_AREA = (
    ParamSpec("x_min", 0.0, "work area: least X, from the power-on origin", "mm", low=-COORDINATE, high=COORDINATE),
    ParamSpec("x_max", 200.0, "work area: greatest X, from the power-on origin", "mm",
              low=-COORDINATE, high=COORDINATE),
    ParamSpec("y_min", 0.0, "work area: least Y, from the power-on origin", "mm", low=-COORDINATE, high=COORDINATE),
    ParamSpec("y_max", 200.0, "work area: greatest Y, from the power-on origin", "mm",
              low=-COORDINATE, high=COORDINATE),
)


def check_work_area(values: Mapping[str, Value]) -> Optional[str]:
    return ordered(values, (("x_min", "x_max"), ("y_min", "y_max")))


def all_of(*checks: CrossCheck) -> CrossCheck:
    def check(values: Mapping[str, Value]) -> Optional[str]:
        return next((why for why in (c(values) for c in checks) if why), None)
    return check
