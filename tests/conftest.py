"""Shared fixtures and set-up of the plotter test suite.

- The pure-Python parts of the ROS packages (G-code parser, geometry, ...) are
  importable straight from ros_ws/src, without ROS: see add_source_packages_to_path.
- Tests that need ROS are marked ``@pytest.mark.ros`` and import rclpy and the
  messages inside the test (or a fixture), so the other tests do not pay for
  ROS start-up. They need the venv and the built workspace on the paths, which
  scripts/test.sh arranges (it sources .venv/bin/activate and
  ros_ws/install/setup.bash). Elsewhere they are skipped when the workspace is
  not on the paths, unless PLOTTER_REQUIRE_ROS=1 (set by scripts/test.sh),
  which turns that into a failure.
- Each test session gets its own ROS domain on loopback, so that test runs of
  several people on one machine do not see each other's topics.
"""

import functools
import gc
import importlib.util
import os
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
ROS_SRC = REPO_ROOT / "ros_ws" / "src"
SOURCE_PACKAGES = ("plotter_bridge", "plotter_shapes", "plotter_web")


def add_source_packages_to_path():
    """Make the ament_python packages in ros_ws/src importable as plain packages.

    Their source directories go first on sys.path, so ``import plotter_bridge``
    imports the working-tree code even when an installed copy is also on the path.
    """
    for name in SOURCE_PACKAGES:
        path = str(ROS_SRC / name)
        if path in sys.path:
            sys.path.remove(path)
        sys.path.insert(0, path)


add_source_packages_to_path()


def _setup_ros_environment():
    # Own DDS domain per test session (unless one was chosen), discovery on
    # loopback only. Set before rclpy is imported, inherited by subprocesses.
    # An xdist worker always takes one of its own share: the one it inherits
    # is its controller's, the same for every worker.
    from node_processes import worker_domains
    domains = worker_domains()
    own = str(domains[os.getpid() % len(domains)])
    if os.environ.get("PYTEST_XDIST_WORKER"):
        os.environ["ROS_DOMAIN_ID"] = own
    os.environ.setdefault("ROS_DOMAIN_ID", own)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


_setup_ros_environment()


@functools.lru_cache(maxsize=None)
def ros_available():
    """True when rclpy and the built plotter_interfaces can be imported."""
    try:
        return (importlib.util.find_spec("rclpy") is not None
                and importlib.util.find_spec("plotter_interfaces") is not None)
    except (ImportError, ValueError):
        return False


def pytest_runtest_setup(item):
    if item.get_closest_marker("ros") is None or ros_available():
        return
    reason = ("ROS workspace not on the paths: run scripts/test.sh, or source "
              ".venv/bin/activate and ros_ws/install/setup.bash")
    if os.environ.get("PLOTTER_REQUIRE_ROS") == "1":
        pytest.fail(reason, pytrace=False)
    pytest.skip(reason)


@pytest.fixture(autouse=True)
def _collect_ros_garbage(request):
    """An rclpy future that failed because its node was destroyed (the
    executor's tasks and the node hold each other) prints "The following
    exception was never retrieved" when the cyclic garbage collector frees
    it, which may be during a later test that captures stderr.  Collected at
    the end of each ROS test, the message stays in that test's output."""
    yield
    if request.node.get_closest_marker("ros"):
        gc.collect()


@pytest.fixture(scope="session")
def repo_root():
    """Path of the repository root."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def ros_ws(repo_root):
    """Path of the colcon workspace (ros_ws/)."""
    return repo_root / "ros_ws"


@pytest.fixture
def ros_env():
    """Environment for subprocesses that run ROS nodes (a copy of os.environ)."""
    return dict(os.environ)


@pytest.fixture
def rclpy_context():
    """A fresh, initialised rclpy Context for one test; shut down afterwards.

    Create nodes with ``rclpy.create_node(name, context=rclpy_context)`` and
    executors with ``SingleThreadedExecutor(context=rclpy_context)``.
    """
    import rclpy
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context)
    try:
        yield context
    finally:
        if context.ok():
            rclpy.shutdown(context=context)


@pytest.fixture
def rig():
    """A BoardSession on the host build of the firmware core, on simulated time
    (reliability_sim.SimRig), connected."""
    from firmware_build import host_library
    from reliability_sim import SimRig
    r = SimRig(library=host_library())
    r.connect()
    yield r
    r.close()


# Three colours, no layers, 100 x 60 mm: blue written two ways is one pen.
COLOURS_SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="60mm" viewBox="0 0 100 60">
<rect x="10" y="10" width="80" height="40" stroke="black" fill="none"/>
<circle cx="30" cy="30" r="10" stroke="red" fill="none"/>
<line x1="50" y1="40" x2="85" y2="40" stroke="#0000ff"/>
<line x1="50" y1="45" x2="85" y2="45" stroke="blue"/>
</svg>
"""


@pytest.fixture
def colours(tmp_path):
    """The path of COLOURS_SVG, a drawing in three pens."""
    path = tmp_path / "colours.svg"
    path.write_text(COLOURS_SVG)
    return str(path)


# ------------------------------------------------ the suite's own bookkeeping

# The only reasons a test may skip in a whole run (scripts/test.sh): a skip
# for any other reason is a check that silently did not happen, and fails.
# None today: a check that applies to one build is written for that build.
EXPECTED_SKIPS: tuple = ()


# The longest files first: scripts/test_stages.py hands a file to a worker as
# one lot (its module fixtures are made once), and the stage lasts until the
# last lot ends, so a long one taken last would leave the other core idle.
# The figures of docs/testing.md, longest first; the other files follow in
# their own order.
LONGEST_FILES = (
    "test_firmware_isr_share.py", "test_follow.py", "test_firmware_asm_equivalence.py",
    "test_firmware_interpolation.py", "test_gcode_oracle.py", "test_generator_corpus.py",
    "test_firmware_panel.py", "test_real_programs.py", "test_firmware_preemption.py", "test_arcfit.py",
    "test_firmware_follow.py", "test_homing.py", "test_follow_command.py", "test_firmware_plan_cost.py",
    "test_big_jobs_sim.py",
    # the ros stage's
    "test_web_ui.py", "test_ros_driver.py", "test_plotter_client.py", "test_follow_graph.py",
    "test_plotter_cli.py", "test_plotter_follow.py", "test_fleet.py", "test_svg_layers.py",
    "test_host_stalls.py",
)


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def pytest_addoption(parser):
    parser.addoption("--stage-report", default="",
                     help="write the run's outcome counts and skips as JSON to this file (scripts/test_stages.py)")


def _skip_reason(report) -> str:
    """A skipped report's reason (its longrepr is (file, line, reason) for a skip)."""
    return str(report.longrepr[2] if isinstance(report.longrepr, tuple) else report.longrepr)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under PLOTTER_STRICT_SKIPS=1 a skip whose reason is not one of
    EXPECTED_SKIPS is turned into a failure that names the reason."""
    outcome = yield
    report = outcome.get_result()
    if (os.environ.get("PLOTTER_STRICT_SKIPS") != "1" or not report.skipped
            or hasattr(report, "wasxfail")):
        return
    reason = _skip_reason(report)
    if not any(expected in reason for expected in EXPECTED_SKIPS):
        report.outcome = "failed"
        report.longrepr = f"skipped, and this run allows no skip for that reason: {reason}"


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    path = config.getoption("--stage-report")
    if not path or hasattr(config, "workerinput"):
        return
    import json
    stats = terminalreporter.stats
    counts = {key: len(stats.get(key, ()))      # as pytest's own summary line counts them
              for key in ("failed", "passed", "skipped", "xfailed", "xpassed", "error", "deselected")}
    skips = []
    for report in stats.get("skipped", ()):
        skips.append({"test": report.nodeid, "reason": _skip_reason(report)})
    Path(path).write_text(json.dumps({"counts": counts, "skips": skips, "exitstatus": int(exitstatus)}))
