"""The ROS 2 nodes (serial_bridge, gcode_streamer, mock_board) and what they
share: the node main, QoS profiles, machine parameters, the bridge's
telemetry publishers, and the in-process graph of the plotter command.
The only layer of plotter_bridge that imports rclpy at module level (see
docs/architecture.md)."""
