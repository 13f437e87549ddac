"""A client on another host: waits for the bridge's state, sends one goal to the
shape_server's `draw` action (as `ros2 action send_goal`), waits for the result,
and prints what it saw as one JSON line. Used by test_fleet.py inside a network
namespace."""
import argparse
import json
import math
import sys
import time

import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from plotter_interfaces.action import DrawShape
from plotter_interfaces.msg import BoardState, ShapeGoal


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--namespace", default="/plotter")
    ap.add_argument("--shape", default="circle")
    ap.add_argument("--x", type=float, default=100.0)
    ap.add_argument("--y", type=float, default=100.0)
    ap.add_argument("--size", type=float, default=15.0)
    ap.add_argument("--feed", type=float, default=0.0, help="mm/min (0: the shape server's default)")
    ap.add_argument("--timeout", type=float, default=90.0)
    args = ap.parse_args()
    rclpy.init()
    node = rclpy.create_node("remote_client", namespace=args.namespace)
    states, positions = [], []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(BoardState, "state", lambda m: states.append((time.monotonic(), m.state, m.queue_free)),
                             latched)
    node.create_subscription(PointStamped, "position",
                             lambda m: positions.append((m.point.x * 1000, m.point.y * 1000)), 10)
    draw = ActionClient(node, DrawShape, "draw")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    end = time.monotonic() + args.timeout
    report = {"discovered": False, "drawn": False}

    def wait(pred) -> bool:
        while time.monotonic() < end:
            if pred():
                return True
            executor.spin_once(timeout_sec=0.05)
        return False

    try:
        if not wait(lambda: any(s[1] == BoardState.IDLE for s in states)) or \
                not wait(draw.server_is_ready):
            return 1
        report["discovered"] = True
        goal = DrawShape.Goal(shape=ShapeGoal(shape=args.shape, x=args.x, y=args.y, size=args.size, feed=args.feed))
        sent = draw.send_goal_async(goal)
        if not wait(sent.done) or not sent.result().accepted:
            return 1
        result = sent.result().get_result_async()
        wait(result.done)
        r = result.result().result if result.done() else None
        report["drawn"] = bool(r and r.success)
        report["message"] = r.message if r else "no result"
        if r is not None and r.success:
            # The board's report of the pen where the job ended may come after the result.
            wait(lambda: bool(positions) and math.dist(positions[-1], (r.x_mm, r.y_mm)) < 1e-6)
        report["positions"] = len(positions)
        report["last"] = positions[-1] if positions else None
        return 0 if report["drawn"] else 1
    finally:
        print(json.dumps(report), flush=True)
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
