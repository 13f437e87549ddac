"""The RViz configuration and the launch file are installed with plotter_bridge and name its topics."""
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
    for rel in ("rviz/plotter.rviz", "launch/plotter.launch.py"):
        assert (SHARE / rel).read_text() == (SRC / rel).read_text()


def test_flash_target_runs_stcgal_on_the_image():
    import re
    import subprocess
    from pathlib import Path
    repo = Path(__file__).resolve().parent.parent
    out = subprocess.run(["make", "-n", "-C", str(repo / "firmware"), "flash", "PORT=/dev/ttyUSB7",
                          "PYTHON=python3"], capture_output=True, text=True, check=True).stdout
    assert re.search(r"python3 -m stcgal -P stc89 -p /dev/ttyUSB7 build/+plotter.ihx", out)
