"""nodes/teardown.py: a process whose node destruction deadlocks in the
middleware, with the GIL held, is ended by the watchdog with every thread's
stack; and the test harness tells that end (tests/node_processes.py) from
any other.  No ROS: the deadlock is a C call that holds the GIL."""
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

from node_processes import stuck_in_dds_teardown

STUCK = textwrap.dedent("""
    import ctypes, sys
    import plotter_bridge.nodes.teardown as teardown
    teardown.TEARDOWN_S = 1
    with teardown.teardown_watchdog():
        if sys.argv[1] == "stuck":
            ctypes.PyDLL(None).sleep(30)  # a C call that keeps the GIL, as the deadlock does
    print("torn down", flush=True)
""")


SOURCE = Path(__file__).resolve().parent.parent / "ros_ws" / "src" / "plotter_bridge"


def run(mode):
    env = dict(os.environ, PYTHONPATH=str(SOURCE))
    return subprocess.run([sys.executable, "-c", STUCK, mode], capture_output=True, text=True, timeout=60, env=env)


def test_a_teardown_stuck_with_the_gil_held_ends_with_the_stacks():
    proc = run("stuck")
    # Ended by the watchdog's alarm, in the 30 s C call: nothing else sends SIGALRM, and
    # had the call returned the process would have said "torn down".
    assert proc.returncode == -signal.SIGALRM, "the watchdog did not end it"
    assert "Timeout (0:00:01)!" in proc.stderr and "<string>" in proc.stderr, proc.stderr
    assert "torn down" not in proc.stdout


def test_a_teardown_that_ends_in_time_stops_the_watchdog():
    proc = run("quick")
    assert proc.returncode == 0 and proc.stdout == "torn down\n", proc.stderr
    assert "Timeout" not in proc.stderr


CI_DUMP = """[INFO] [1795729811.263430781] [plotter.mock_board]: mock board on /dev/pts/0
Timeout (0:00:08)!
Thread 0x00007f22e87bd740 (most recent call first):
  File "/tmp/p/.venv/lib/python3.11/site-packages/rclpy/publisher.py", line 105 in destroy
  File "/tmp/p/.venv/lib/python3.11/site-packages/rclpy/node.py", line 1833 in destroy_publisher
  File "/tmp/p/.venv/lib/python3.11/site-packages/rclpy/node.py", line 1953 in destroy_node
  File "/tmp/p/ros_ws/install/plotter_bridge/lib/python3.11/site-packages/plotter_bridge/nodes/mock_board.py", \
line 91 in destroy_node
"""


def test_the_harness_tells_a_middleware_deadlock_from_other_ends():
    assert stuck_in_dds_teardown(-signal.SIGALRM, CI_DUMP) == "rclpy/publisher.py in destroy"
    assert stuck_in_dds_teardown(1, CI_DUMP) == ""                       # another exit
    assert stuck_in_dds_teardown(-signal.SIGALRM, "no dump") == ""
    ours = CI_DUMP.replace('rclpy/publisher.py", line 105 in destroy',
                           'plotter_bridge/sim/mock_board.py", line 9 in stop')
    assert stuck_in_dds_teardown(-signal.SIGALRM, ours) == ""             # stuck in this project's code
