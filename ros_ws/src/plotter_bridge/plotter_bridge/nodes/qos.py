"""The QoS profiles of the plotter's topics, written once."""
from __future__ import annotations

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def latched() -> QoSProfile:
    """Reliable and transient local, depth 1: a subscriber that comes late
    still gets the last message (the board's state, the mock board's port,
    the bridge's paths and ink).  Subscribers of these topics use it too, or
    they would not be matched with the publisher's transient local."""
    return QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)
