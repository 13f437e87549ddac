"""The main() of every plotter_bridge node: init, spin, clean shutdown on
Ctrl-C, exit code 1 with a message for a bad parameter."""
from __future__ import annotations

from typing import Callable

import rclpy
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node


def run_node(make: Callable[[], Node], name: str, args=None, threads: int = 4) -> None:
    """Spin the node `make()` builds on a multi-threaded executor (action
    callbacks that wait for the board keep other threads free)."""
    rclpy.init(args=args)
    node = None
    try:
        node = make()
        executor = MultiThreadedExecutor(num_threads=threads)
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ValueError as exc:
        rclpy.logging.get_logger(name).fatal(f"bad parameter: {exc}")
        raise SystemExit(1)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
