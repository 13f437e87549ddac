"""Evaluates a ROS 2 launch file without the launch system, for tests.

`launch` and `launch_ros` are not on the Python package index (the PyPI
wheels of Jazzy stop at rclpy), so the launch file cannot run here as
`ros2 launch` runs it.  This module stands in for the part of their API
that plotter.launch.py uses: it executes the file's
generate_launch_description() against recording classes, resolves the
launch arguments (defaults, then the ones given, as `name:=value` does),
the conditions and the substitutions, and returns the nodes the file
describes with their resolved parameters, which a test then starts as the
processes `ros2 launch` would start.  A use of the launch API this stand-in
does not know fails loudly (AttributeError / ImportError), never silently.
"""
from __future__ import annotations

import importlib.util
import sys
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Sequence, Union

Resolver = Callable[[str], str]        # package name -> its share directory


class _Substitution:
    def resolve(self, args: Mapping[str, str], share: Resolver) -> str:
        raise NotImplementedError


class LaunchConfiguration(_Substitution):
    def __init__(self, name: str) -> None:
        self.name = name

    def resolve(self, args, share) -> str:
        if self.name not in args:
            raise KeyError(f"launch argument {self.name!r} not declared")
        return args[self.name]


class FindPackageShare(_Substitution):
    def __init__(self, package: str) -> None:
        self.package = package

    def resolve(self, args, share) -> str:
        return share(self.package)


class PathJoinSubstitution(_Substitution):
    def __init__(self, parts: Sequence[Union[str, _Substitution]]) -> None:
        self.parts = list(parts)

    def resolve(self, args, share) -> str:
        return str(Path(*[resolve(p, args, share) for p in self.parts]))


def resolve(value, args: Mapping[str, str], share: Resolver):
    if isinstance(value, _Substitution):
        return value.resolve(args, share)
    if isinstance(value, dict):
        return {k: resolve(v, args, share) for k, v in value.items()}
    return value


class IfCondition:
    def __init__(self, predicate: Union[str, _Substitution]) -> None:
        self.predicate = predicate

    def holds(self, args, share) -> bool:
        text = str(resolve(self.predicate, args, share)).strip().lower()
        if text not in ("true", "false", "1", "0"):
            raise ValueError(f"IfCondition: {text!r} is not a boolean")
        return text in ("true", "1")


class DeclareLaunchArgument:
    def __init__(self, name: str, default_value=None, description: str = "") -> None:
        self.name, self.default_value, self.description = name, default_value, description


class Node:
    def __init__(self, *, package: str, executable: str, namespace=None, output: str = "log",
                 parameters: Sequence = (), arguments: Sequence = (), condition=None, name=None,
                 remappings: Sequence = ()) -> None:
        if remappings or name is not None:
            raise NotImplementedError("the stand-in does not know node names or remappings")
        self.package, self.executable, self.namespace = package, executable, namespace
        self.parameters, self.arguments, self.condition = list(parameters), list(arguments), condition


class LaunchDescription:
    def __init__(self, entities: Sequence) -> None:
        self.entities = list(entities)


@dataclass
class LaunchedNode:
    """A node as `ros2 launch` would start it."""
    package: str
    executable: str
    namespace: str
    param_files: List[str] = field(default_factory=list)      # in order
    params: Dict[str, object] = field(default_factory=dict)   # given inline (after the files)
    arguments: List[str] = field(default_factory=list)

    def ros_args(self) -> List[str]:
        """The node's --ros-args: namespace, parameter files, then inline values."""
        out = ["-r", f"__ns:=/{self.namespace.strip('/')}"] if self.namespace else []
        for f in self.param_files:
            out += ["--params-file", f]
        for k, v in self.params.items():
            out += ["-p", f"{k}:={v}"]
        return out


def _modules() -> Dict[str, types.ModuleType]:
    mods = {}
    for name, members in {
        "launch": {"LaunchDescription": LaunchDescription},
        "launch.actions": {"DeclareLaunchArgument": DeclareLaunchArgument},
        "launch.conditions": {"IfCondition": IfCondition},
        "launch.substitutions": {"LaunchConfiguration": LaunchConfiguration,
                                 "PathJoinSubstitution": PathJoinSubstitution},
        "launch_ros": {},
        "launch_ros.actions": {"Node": Node},
        "launch_ros.substitutions": {"FindPackageShare": FindPackageShare},
    }.items():
        mod = types.ModuleType(name)
        mod.__dict__.update(members)
        mods[name] = mod
    return mods


def evaluate(launch_file: Path, given: Mapping[str, str], share: Resolver) -> List[LaunchedNode]:
    """The nodes `ros2 launch <launch_file> name:=value ...` would start."""
    saved = {k: sys.modules.get(k) for k in _modules()}
    sys.modules.update(_modules())
    try:
        spec = importlib.util.spec_from_file_location("launch_under_test", launch_file)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        description = module.generate_launch_description()
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    args: Dict[str, str] = {}
    declared = {e.name for e in description.entities if isinstance(e, DeclareLaunchArgument)}
    unknown = set(given) - declared
    if unknown:
        raise KeyError(f"launch arguments not declared by the file: {sorted(unknown)}")
    for e in description.entities:
        if isinstance(e, DeclareLaunchArgument):
            args[e.name] = given[e.name] if e.name in given else str(resolve(e.default_value, args, share))
    nodes = []
    for e in description.entities:
        if not isinstance(e, Node) or (e.condition is not None and not e.condition.holds(args, share)):
            continue
        launched = LaunchedNode(e.package, e.executable, str(resolve(e.namespace, args, share) or ""),
                                arguments=[str(resolve(a, args, share)) for a in e.arguments])
        for p in e.parameters:
            value = resolve(p, args, share)
            if isinstance(value, dict):
                launched.params.update(value)
            else:
                launched.param_files.append(str(value))
        nodes.append(launched)
    return nodes
