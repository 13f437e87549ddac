"""What the colcon install holds: the RViz configuration and the launch file, which name the
bridge's topics, and every module of plotter_bridge's layers and of plotter_shapes."""
import ast
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parent.parent
SRC = REPO / "ros_ws" / "src" / "plotter_bridge"
SHARE = REPO / "ros_ws" / "install" / "plotter_bridge" / "share" / "plotter_bridge"


def test_rviz_config_shows_the_bridge_topics():
    config = yaml.safe_load((SRC / "rviz" / "plotter.rviz").read_text())
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "plotter"
    topics = {d["Topic"]["Value"]: d["Class"] for d in manager["Displays"] if "Topic" in d}
    assert topics == {"/plotter/path": "rviz_default_plugins/Path",
                      "/plotter/planned_path": "rviz_default_plugins/Path",
                      "/plotter/ink": "rviz_default_plugins/Marker",
                      "/plotter/pen": "rviz_default_plugins/Marker"}


def test_launch_file_starts_the_nodes():
    tree = ast.parse((SRC / "launch" / "plotter.launch.py").read_text())
    names = {node.name for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)}
    assert "generate_launch_description" in names
    executables = {kw.value.value for node in ast.walk(tree) if isinstance(node, ast.Call)
                   for kw in node.keywords if kw.arg == "executable"}
    assert executables == {"mock_board", "serial_bridge", "gcode_streamer", "shape_server", "rviz2"}


@pytest.mark.ros
def test_installed_with_the_package():
    for rel in ("rviz/plotter.rviz", "launch/plotter.launch.py", "config/plotter.yaml"):
        assert (SHARE / rel).read_text() == (SRC / rel).read_text()


def test_flash_target_runs_stcgal_on_the_image():
    import re
    import subprocess
    from pathlib import Path
    repo = Path(__file__).resolve().parent.parent
    # The chip's clock mode goes with the image: 12T for the default one, 6T for CPU6T=1's.
    for extra, mode, image in (([], "false", "build/+plotter.ihx"), (["CPU6T=1"], "true", "build/+6t/+plotter.ihx")):
        out = subprocess.run(["make", "-n", "-C", str(repo / "firmware"), "flash", "PORT=/dev/ttyUSB7",
                              "PYTHON=python3", *extra], capture_output=True, text=True, check=True).stdout
        assert re.search(rf"python3 -m stcgal -P stc89 -p /dev/ttyUSB7 -o cpu_6t_enabled={mode} {image}", out), out


def _installed(package: str) -> Path:
    found = sorted((REPO / "ros_ws" / "install" / package / "lib").glob(f"python3*/site-packages/{package}"))
    assert found, f"{package} is not installed: run scripts/setup.sh"
    return found[-1]


@pytest.mark.ros
@pytest.mark.parametrize("package", ["plotter_bridge", "plotter_shapes"])
def test_the_install_holds_every_module_of_the_source(package):
    src = REPO / "ros_ws" / "src" / package / package
    modules = lambda root: sorted(str(p.relative_to(root)) for p in root.rglob("*.py"))  # noqa: E731
    assert modules(_installed(package)) == modules(src)


@pytest.mark.ros
def test_every_installed_module_imports_from_the_install_and_the_executables_are_there():
    import os
    import subprocess
    import sys
    script = (
        "import importlib, pkgutil, sys\n"
        "import plotter_bridge, plotter_shapes\n"
        "for pkg in (plotter_bridge, plotter_shapes):\n"
        "    for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "        mod = importlib.import_module(m.name)\n"
        "        assert '/install/' in mod.__file__, mod.__file__\n"
        "        print(m.name)\n")
    env = {k: v for k, v in os.environ.items()}
    src = str(REPO / "ros_ws" / "src")
    env["PYTHONPATH"] = os.pathsep.join(p for p in env.get("PYTHONPATH", "").split(os.pathsep)
                                        if p and not p.startswith(src))
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env,
                       cwd=str(REPO / "ros_ws"), timeout=120)
    assert r.returncode == 0, r.stderr
    names = set(r.stdout.split())
    for layer in ("gcode", "motion", "link", "sim", "nodes", "cli"):
        assert f"plotter_bridge.{layer}" in names
    assert {"plotter_bridge.nodes.main", "plotter_bridge.nodes.qos", "plotter_shapes.commands"} <= names
    for package, executables in (("plotter_bridge", ("serial_bridge", "gcode_streamer", "mock_board", "plotter")),
                                 ("plotter_shapes", ("shape_server",))):
        for exe in executables:
            assert os.access(REPO / "ros_ws" / "install" / package / "lib" / package / exe, os.X_OK), exe
