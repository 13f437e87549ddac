"""The layers of docs/architecture.md, checked on the source with `ast`.

plotter_bridge's pure layers (gcode, motion, link, sim) import no ROS and
only the pure layers below them; the ROS nodes (nodes/) import no tools;
only the tools (plotter_bridge.cli, plotter_shapes' SVG and text input and
its plotter subcommands) import the drawing libraries; the driver
(plotter_bridge) never imports the application (plotter_shapes); ROS is
imported at module level only by the nodes; the latched QoS profile is built
in nodes/qos.py alone; and no module imports itself through others.  Each
rule is also run on a made-up package that breaks it, so a rule that cannot
fail would show.
"""
from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Set

import pytest

SRC = Path(__file__).resolve().parent.parent / "ros_ws" / "src"
PACKAGES = ("plotter_bridge", "plotter_shapes")

PURE_LAYERS = {              # layer -> the plotter_bridge layers it may import
    "gcode": set(),
    "link": set(),
    "motion": {"gcode", "link"},
    "sim": {"gcode", "link", "motion"},
}
LAYERS = (*PURE_LAYERS, "nodes", "cli")
ROS = {"rclpy", "rcl_interfaces", "std_msgs", "std_srvs", "geometry_msgs", "nav_msgs", "diagnostic_msgs",
       "visualization_msgs", "action_msgs", "unique_identifier_msgs", "builtin_interfaces",
       "plotter_interfaces", "launch", "launch_ros", "rosidl_runtime_py"}
DRAWING = {"matplotlib", "vpype", "vpype_cli", "svgelements"}
TOOLS = ("plotter_bridge.cli", "plotter_shapes.svg_input", "plotter_shapes.text_input", "plotter_shapes.commands")
PURE_SHAPES = ("plotter_shapes.geometry", "plotter_shapes.svg_input", "plotter_shapes.text_input")


@dataclass(frozen=True)
class Import:
    target: str          # dotted module name
    top_level: bool      # at module level (not inside a function)
    line: int


@dataclass
class Module:
    name: str
    path: Path
    tree: ast.Module
    imports: List[Import]


def _is_package(path: Path) -> bool:
    return path.name == "__init__.py"


def load(src: Path, packages=PACKAGES) -> Dict[str, Module]:
    """Every module of the packages under src, with what it imports."""
    files = {}
    for package in packages:
        for path in sorted((src / package / package).rglob("*.py")):
            rel = path.relative_to(src / package).with_suffix("")
            parts = list(rel.parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            files[".".join(parts)] = path
    modules = {}
    for name, path in files.items():
        tree = ast.parse(path.read_text(), str(path))
        package = name if _is_package(path) else name.rpartition(".")[0]
        modules[name] = Module(name, path, tree, list(_imports(tree, package, set(files))))
    return modules


def _imports(tree: ast.Module, package: str, known: Set[str]):
    def visit(node, top):
        for child in ast.iter_child_nodes(node):
            inner = top and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, ast.Import):
                for alias in child.names:
                    yield Import(alias.name, top, child.lineno)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    anchor = package.split(".")
                    anchor = anchor[:len(anchor) - (child.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                if base != "__future__":
                    for alias in child.names:
                        sub = f"{base}.{alias.name}"
                        yield Import(sub if sub in known else base, top, child.lineno)
            yield from visit(child, inner)
    yield from visit(tree, True)


def _root(name: str) -> str:
    return name.split(".")[0]


def _layer(name: str) -> Optional[str]:
    parts = name.split(".")
    return parts[1] if parts[0] == "plotter_bridge" and len(parts) > 1 else None


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


# --- the rules: each returns its violations as text -----------------------------------------------

def unlayered(modules: Dict[str, Module]) -> List[str]:
    return [f"{m.name}: plotter_bridge modules live in one of the layers {LAYERS}"
            for m in modules.values() if _root(m.name) == "plotter_bridge"
            and m.name != "plotter_bridge" and _layer(m.name) not in LAYERS]


def pure_imports(modules: Dict[str, Module]) -> List[str]:
    out = []
    for m in modules.values():
        layer = _layer(m.name)
        pure_shapes = _within(m.name, PURE_SHAPES)
        if layer not in PURE_LAYERS and not pure_shapes:
            continue
        for imp in m.imports:
            if _root(imp.target) in ROS:
                out.append(f"{m.name}:{imp.line} imports {imp.target}: pure code imports no ROS")
            elif layer in PURE_LAYERS and _root(imp.target) == "plotter_bridge" and _layer(imp.target) != layer \
                    and _layer(imp.target) not in PURE_LAYERS[layer]:
                out.append(f"{m.name}:{imp.line} imports {imp.target}: the {layer} layer may import "
                           f"{sorted(PURE_LAYERS[layer]) or 'no other layer'}")
    return out


def nodes_import_no_tools(modules: Dict[str, Module]) -> List[str]:
    return [f"{m.name}:{imp.line} imports {imp.target}: nodes import no tools"
            for m in modules.values() if _layer(m.name) == "nodes"
            for imp in m.imports if _layer(imp.target) == "cli" or _root(imp.target) == "plotter_shapes"]


def driver_imports_no_application(modules: Dict[str, Module]) -> List[str]:
    return [f"{m.name}:{imp.line} imports {imp.target}: plotter_bridge does not depend on plotter_shapes"
            for m in modules.values() if _root(m.name) == "plotter_bridge"
            for imp in m.imports if _root(imp.target) == "plotter_shapes"]


def drawing_libraries_in_tools_only(modules: Dict[str, Module]) -> List[str]:
    return [f"{m.name}:{imp.line} imports {imp.target}: only the tools {TOOLS} draw"
            for m in modules.values() if not _within(m.name, TOOLS)
            for imp in m.imports if _root(imp.target) in DRAWING]


def ros_at_top_only_in_nodes(modules: Dict[str, Module]) -> List[str]:
    """The command line imports ROS where a subcommand needs it, so that
    `plotter check` does not pay for ROS start-up."""
    return [f"{m.name}:{imp.line} imports {imp.target} at module level: only nodes/ does"
            for m in modules.values() if _root(m.name) == "plotter_bridge" and _layer(m.name) != "nodes"
            for imp in m.imports if imp.top_level and _root(imp.target) in ROS]


def qos_written_once(modules: Dict[str, Module]) -> List[str]:
    return [f"{m.name}:{node.lineno} builds a QoSProfile: use plotter_bridge.nodes.qos"
            for m in modules.values() if m.name != "plotter_bridge.nodes.qos"
            for node in ast.walk(m.tree) if isinstance(node, ast.Call)
            and getattr(node.func, "id", getattr(node.func, "attr", None)) == "QoSProfile"]


def cycles(modules: Dict[str, Module]) -> List[str]:
    """Import cycles between modules (imports inside functions count too)."""
    graph = {name: sorted({i.target for i in m.imports if i.target in modules and i.target != name})
             for name, m in modules.items()}
    out, state, stack = [], {}, []

    def visit(name):
        state[name] = "open"
        stack.append(name)
        for nxt in graph[name]:
            if state.get(nxt) == "open":
                out.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[name] = "done"

    for name in sorted(graph):
        if name not in state:
            visit(name)
    return out


RULES = (unlayered, pure_imports, nodes_import_no_tools, driver_imports_no_application,
         drawing_libraries_in_tools_only, ros_at_top_only_in_nodes, qos_written_once, cycles)


@pytest.fixture(scope="module")
def modules():
    found = load(SRC)
    assert "plotter_bridge.link.protocol" in found and "plotter_shapes.geometry" in found
    return found


@pytest.mark.parametrize("rule", RULES, ids=lambda r: r.__name__)
def test_the_packages_keep_the_rule(rule, modules):
    assert rule(modules) == []


# --- each rule fails on a package that breaks it ------------------------------------------------------

BROKEN = {
    "plotter_bridge/plotter_bridge/__init__.py": "",
    "plotter_bridge/plotter_bridge/helpers.py": "X = 1\n",
    "plotter_bridge/plotter_bridge/gcode/__init__.py": "",
    "plotter_bridge/plotter_bridge/gcode/parser.py": "from ..motion import commands\n",
    "plotter_bridge/plotter_bridge/link/__init__.py": "",
    "plotter_bridge/plotter_bridge/link/protocol.py": "def f():\n    import rclpy\n",
    "plotter_bridge/plotter_bridge/motion/__init__.py": "",
    "plotter_bridge/plotter_bridge/motion/commands.py": "from plotter_bridge.gcode import parser\n",
    "plotter_bridge/plotter_bridge/sim/__init__.py": "",
    "plotter_bridge/plotter_bridge/sim/mock_board.py": "def draw():\n    import matplotlib\n",
    "plotter_bridge/plotter_bridge/nodes/__init__.py": "",
    "plotter_bridge/plotter_bridge/nodes/serial_bridge.py":
        "from rclpy.qos import QoSProfile\nfrom ..cli import run\nq = QoSProfile(depth=1)\n",
    "plotter_bridge/plotter_bridge/cli/__init__.py": "",
    "plotter_bridge/plotter_bridge/cli/run.py": "import rclpy\nfrom plotter_shapes.geometry import Line\n",
    "plotter_shapes/plotter_shapes/__init__.py": "",
    "plotter_shapes/plotter_shapes/geometry.py": "from std_msgs.msg import String\n",
}
EXPECTED = {
    unlayered: ["plotter_bridge.helpers"],
    pure_imports: ["plotter_bridge.gcode.parser:1 imports plotter_bridge.motion.commands",
                   "plotter_bridge.link.protocol:2 imports rclpy",
                   "plotter_shapes.geometry:1 imports std_msgs.msg"],
    nodes_import_no_tools: ["plotter_bridge.nodes.serial_bridge:2 imports plotter_bridge.cli.run"],
    driver_imports_no_application: ["plotter_bridge.cli.run:2 imports plotter_shapes.geometry"],
    drawing_libraries_in_tools_only: ["plotter_bridge.sim.mock_board:2 imports matplotlib"],
    ros_at_top_only_in_nodes: ["plotter_bridge.cli.run:1 imports rclpy at module level"],
    qos_written_once: ["plotter_bridge.nodes.serial_bridge:3 builds a QoSProfile"],
    cycles: ["plotter_bridge.gcode.parser -> plotter_bridge.motion.commands -> plotter_bridge.gcode.parser"],
}


@pytest.mark.parametrize("rule", RULES, ids=lambda r: r.__name__)
def test_the_rule_fails_on_a_package_that_breaks_it(rule, tmp_path):
    for rel, text in BROKEN.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    found = rule(load(tmp_path))
    assert len(found) == len(EXPECTED[rule]), found
    for violation, start in zip(sorted(found), sorted(EXPECTED[rule])):
        assert violation.startswith(start), (violation, start)
