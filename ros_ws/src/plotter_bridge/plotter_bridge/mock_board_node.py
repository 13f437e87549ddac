"""mock_board: a simulated plotter board for tests and demos.

Creates a pseudo-terminal, prints its path and publishes it on `mock_port`
(std_msgs/String, transient local); behind it the firmware's own core runs in
real time (see mock_board.py).  Parameters: `link` (also make a symlink to
the pty there, so a bridge can be started with port:=<link>), `trace` (CSV
of every step), `baud` (byte rate of the simulated UART).
"""
from __future__ import annotations

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rcl_interfaces.msg import ParameterDescriptor
from std_msgs.msg import String

from .mock_board import MockBoard, MockBoardConfig

DEFAULT_NAMESPACE = "/plotter"


class MockBoardNode(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("mock_board", namespace=namespace, **kwargs)
        d = ParameterDescriptor
        self.declare_parameter("link", "", d(description="path of a symlink to the pty ('' = none)"))
        self.declare_parameter("trace", "", d(description="CSV file of every step: t_s,x_steps,y_steps ('' = none)"))
        self.declare_parameter("baud", 115200, d(description="simulated UART baud rate"))
        config = MockBoardConfig(baud=int(self.get_parameter("baud").value),
                                 link=str(self.get_parameter("link").value),
                                 trace=str(self.get_parameter("trace").value))
        if config.baud <= 0:
            raise ValueError("baud must be positive")
        self.board = MockBoard(config)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.create_publisher(String, "mock_port", latched).publish(String(data=self.board.port_path))
        self.board.start()
        where = f" (link {config.link})" if config.link else ""
        print(f"mock board on {self.board.port_path}{where}", flush=True)
        self.get_logger().info(f"mock board on {self.board.port_path}{where}")

    def destroy_node(self) -> None:
        self.board.stop()
        super().destroy_node()


def main(args=None) -> None:
    rclpy.init(args=args)
    node = None
    try:
        node = MockBoardNode()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
