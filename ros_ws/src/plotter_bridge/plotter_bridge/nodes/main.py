"""The main() of every plotter node (serial_bridge, gcode_streamer,
mock_board, and plotter_shapes' shape_server): init, spin, a clean exit on
Ctrl-C, exit code 1 with one line on the log for a bad parameter or bad
command-line arguments."""
from __future__ import annotations

import signal
import threading
from typing import Callable, List, Optional

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node

from .late_clients import retry_late_answers
from .spinning import shutdown_after_callbacks, spin_step
from .teardown import teardown_watchdog

EXIT_OK = 0
EXIT_BAD_PARAMETER = 1
SPIN_STEP_S = 0.25     # s the main thread waits for work before it looks at signals and shutdown again

#: The namespace of a node started without a remap; `-r __ns:=/plotter2`
#: runs a second plotter beside the first.
DEFAULT_NAMESPACE = "/plotter"


def run_node(make: Callable[[], Node], name: str, args: Optional[List[str]] = None, threads: int = 4) -> int:
    """Spin the node `make()` builds on a multi-threaded executor; return the
    exit code.  A node refuses a bad parameter by raising ValueError (params.
    BadParameter), or rclpy's ParameterException, from its constructor."""
    stop = threading.Event()
    previous = _take_sigint(stop)
    try:
        return _run(make, name, args, threads, stop)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


def _take_sigint(stop: threading.Event):
    """Ctrl-C sets `stop` instead of raising KeyboardInterrupt; the handler this replaced.

    A KeyboardInterrupt is raised wherever the main thread happens to be, and once it came
    between a lock's acquire and the `with` block of the executor's thread pool (its idle
    semaphore): the lock stayed taken, every worker blocked on it, and the node never exited.
    Set before rclpy.init, which keeps this handler and calls it after its own (the context
    shut down, the waits woken); the spin loop sees `stop` within SPIN_STEP_S."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGINT, lambda _signum, _frame: stop.set())


def _run(make: Callable[[], Node], name: str, args: Optional[List[str]], threads: int,
         stop: threading.Event) -> int:
    try:
        rclpy.init(args=args)
    except Exception as exc:  # rcl's own parse of --ros-args
        print(f"[FATAL] [{name}]: bad command-line arguments: {exc}", flush=True)
        return EXIT_BAD_PARAMETER
    node: Optional[Node] = None
    executor: Optional[MultiThreadedExecutor] = None
    retry_late_answers()
    try:
        try:
            node = make()
            executor = MultiThreadedExecutor(num_threads=threads)
            executor.add_node(node)
            # In steps, not one spin(): rclpy wakes a waiting spin() on Ctrl-C with a guard condition,
            # and a node beside CPU-bound processes once sat 15 s in that wait after SIGINT.  Coming
            # back to Python every SPIN_STEP_S sees `stop`.
            while not stop.is_set() and spin_step(executor, SPIN_STEP_S):
                pass
        except (ValueError, ParameterException, RCLError) as exc:
            if not rclpy.ok():
                # Ctrl-C while the node was being made: rclpy's handler shut the context down under
                # it, and making the next entity failed for that (ValueError from an action server,
                # RCLError from the rest), not for a parameter.
                return EXIT_OK
            if isinstance(exc, RCLError):
                raise
            rclpy.logging.get_logger(name).fatal(f"bad parameter: {exc}")
            return EXIT_BAD_PARAMETER
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if executor is not None:
            shutdown_after_callbacks(executor)
        with teardown_watchdog():
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
    return EXIT_OK
