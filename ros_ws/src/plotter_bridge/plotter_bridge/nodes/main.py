"""The main() of every plotter node (serial_bridge, gcode_streamer,
mock_board, and plotter_shapes' shape_server): init, spin, a clean exit on
Ctrl-C, exit code 1 with one line on the log for a bad parameter."""
from __future__ import annotations

from typing import Callable, List, Optional

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node

EXIT_OK = 0
EXIT_BAD_PARAMETER = 1


def run_node(make: Callable[[], Node], name: str, args: Optional[List[str]] = None, threads: int = 4) -> int:
    """Spin the node `make()` builds on a multi-threaded executor (action
    callbacks that wait for the board or the streamer keep other threads
    free); return the exit code.  A node refuses a bad parameter by raising
    ValueError, or rclpy's ParameterException (a value of the wrong type),
    from its constructor."""
    rclpy.init(args=args)
    node: Optional[Node] = None
    executor: Optional[MultiThreadedExecutor] = None
    try:
        node = make()
        executor = MultiThreadedExecutor(num_threads=threads)
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ValueError, ParameterException) as exc:
        rclpy.logging.get_logger(name).fatal(f"bad parameter: {exc}")
        return EXIT_BAD_PARAMETER
    finally:
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return EXIT_OK
