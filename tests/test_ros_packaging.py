"""The packages install on a real ROS 2 Jazzy: their package.xml files name
everything they import, `plotter` is an executable of plotter_bridge,
`colcon test` runs each package's own tests, and the nodes use rclpy's
public API only."""
from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Dict, Set

import pytest

REPO = Path(__file__).resolve().parent.parent
SRC = REPO / "ros_ws" / "src"
PYTHON_PACKAGES = ("plotter_bridge", "plotter_shapes", "plotter_web")
# Python modules from Debian packages, by their rosdep keys.
ROSDEP = {"serial": "python3-serial", "matplotlib": "python3-matplotlib", "numpy": "python3-numpy",
          "yaml": "python3-yaml", "aiohttp": "python3-aiohttp"}
# On PyPI only (no rosdep key): named in a comment of package.xml and in requirements.txt.
PIP_ONLY = {"vpype": "vpype", "vpype_cli": "vpype", "svgelements": "svgelements"}


def imports(package: str) -> Set[str]:
    """Top-level modules the package imports anywhere (its launch files too)."""
    found = set()
    for path in (SRC / package).rglob("*.py"):
        if "test" in path.relative_to(SRC / package).parts[:1]:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                found |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
    return found - set(sys.stdlib_module_names) - {"__future__", package, "setuptools"}


def depends(package: str) -> Dict[str, Set[str]]:
    root = ET.parse(SRC / package / "package.xml").getroot()
    out: Dict[str, Set[str]] = {}
    for tag in ("depend", "exec_depend", "test_depend", "build_depend"):
        out[tag] = {e.text.strip() for e in root.findall(tag)}
    return out


@pytest.mark.parametrize("package", PYTHON_PACKAGES)
def test_package_xml_names_every_package_it_imports(package):
    deps = depends(package)
    run = deps["depend"] | deps["exec_depend"]
    xml = (SRC / package / "package.xml").read_text()
    requirements = (REPO / "requirements.txt").read_text()
    for module in sorted(imports(package)):
        if module in PIP_ONLY:
            assert PIP_ONLY[module] in xml and PIP_ONLY[module] in requirements, module
        else:
            assert ROSDEP.get(module, module) in run, f"{package} imports {module}: not in package.xml"


def test_package_xml_check_can_fail():
    """The check above sees an import that package.xml does not name."""
    assert "plotter_bridge" in imports("plotter_shapes") and "rclpy" in imports("plotter_bridge")
    assert "plotter_shapes" not in depends("plotter_bridge")["exec_depend"]


def test_requirements_name_the_jazzy_distribution_packages():
    lines = [line.split("#")[0].strip() for line in (REPO / "requirements.txt").read_text().splitlines()]
    assert "ros-jazzy-rclpy[fastrtps]==7.1.6" in lines and "ros-jazzy-common-interfaces==5.3.6" in lines
    assert not any(line.startswith(("ros-rclpy", "ros-common-interfaces")) for line in lines)


def _public_api_offences(path: Path):
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr == "Impl":
            yield f"{path.name}:{node.lineno}: .Impl (rclpy's private action types)"
        if isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", "")) == "ClientGoalHandle":
            yield f"{path.name}:{node.lineno}: ClientGoalHandle built by hand"
        if isinstance(node, ast.FunctionDef) and node.name == "__init__":
            for inner in ast.walk(node):
                if isinstance(inner, ast.Attribute) and inner.attr == "setswitchinterval":
                    yield f"{path.name}:{inner.lineno}: sys.setswitchinterval in a constructor"
        if isinstance(node, ast.Attribute) and node.attr in ("_parameter_overrides", "_goal_handles"):
            yield f"{path.name}:{node.lineno}: rclpy private attribute {node.attr}"


def test_nodes_use_the_public_rclpy_api_only():
    offences = [o for pkg in PYTHON_PACKAGES for p in (SRC / pkg / pkg).rglob("*.py") for o in _public_api_offences(p)]
    assert offences == []


def test_public_api_check_can_fail(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import sys\nclass N:\n    def __init__(self):\n        sys.setswitchinterval(1)\n"
                   "        h = ClientGoalHandle(1, 2, X.Impl.SendGoalService.Response())\n")
    assert len(list(_public_api_offences(bad))) == 3


def _ros_env() -> Dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    script = f"source {REPO}/.venv/bin/activate && source {REPO}/ros_ws/install/setup.bash && env -0"
    out = subprocess.run(["bash", "-c", script], capture_output=True, check=True, env=env).stdout
    return dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)


@pytest.mark.ros
def test_plotter_is_an_executable_of_plotter_bridge_and_a_console_script():
    env = _ros_env()
    for exe in (REPO / "ros_ws" / "install" / "plotter_bridge" / "lib" / "plotter_bridge" / "plotter",  # ros2 run
                REPO / ".venv" / "bin" / "plotter"):
        r = subprocess.run([str(exe), "--help"], capture_output=True, text=True, env=env, timeout=120)
        assert r.returncode == 0, r.stderr
        for sub in ("stream", "check", "watch", "draw", "svg", "text"):
            assert sub in r.stdout, (exe, r.stdout)


@pytest.mark.ros
def test_colcon_test_runs_each_packages_own_tests_and_they_pass(tmp_path):
    env = _ros_env()
    ws = REPO / "ros_ws"
    # Built and tested in build and install trees of the test's own, beside the project's.
    for verb in ("build", "test"):
        r = subprocess.run([str(REPO / ".venv" / "bin" / "colcon"), "--log-base", str(tmp_path / "log"), verb,
                            "--base-paths", "src", "--build-base", str(tmp_path / "build"),
                            "--install-base", str(tmp_path / "install"), "--packages-select", *PYTHON_PACKAGES,
                            "--event-handlers", "console_direct-"],
                           cwd=ws, capture_output=True, text=True, env=env, timeout=600)
        assert r.returncode == 0, r.stdout + r.stderr
    # colcon writes a log of every verb, test-result too: it goes under tmp_path, not the checkout.
    r = subprocess.run([str(REPO / ".venv" / "bin" / "colcon"), "--log-base", str(tmp_path / "log"), "test-result",
                        "--test-result-base", str(tmp_path / "build"), "--verbose"],
                       cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    summary = re.search(r"Summary: (\d+) tests, (\d+) errors, (\d+) failures", r.stdout)
    assert summary and summary.group(2) == summary.group(3) == "0", r.stdout
    assert int(summary.group(1)) >= 10, r.stdout
