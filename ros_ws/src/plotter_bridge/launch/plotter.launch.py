"""One plotter: serial_bridge, gcode_streamer and shape_server in a namespace,
optionally the mock board and RViz.

    ros2 launch plotter_bridge plotter.launch.py port:=/dev/ttyUSB0
    ros2 launch plotter_bridge plotter.launch.py mock:=true port:=/tmp/plotter rviz:=true
    ros2 launch plotter_bridge plotter.launch.py namespace:=plotter2 port:=/dev/ttyUSB1

With mock:=true the mock board makes `port` a link to its pseudo-terminal.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    namespace = LaunchConfiguration("namespace")
    port = LaunchConfiguration("port")
    baud = ParameterValue(LaunchConfiguration("baud"), value_type=int)
    steps_per_mm = ParameterValue(LaunchConfiguration("steps_per_mm"), value_type=float)
    rviz_config = PathJoinSubstitution([FindPackageShare("plotter_bridge"), "rviz", "plotter.rviz"])
    return LaunchDescription([
        DeclareLaunchArgument("namespace", default_value="plotter", description="namespace of the plotter's nodes"),
        DeclareLaunchArgument("port", default_value="/dev/ttyUSB0", description="serial port of the board"),
        DeclareLaunchArgument("baud", default_value="115200",
                              description="baud rate: 115200 for `make BAUD=115200` firmware, else 9600"),
        DeclareLaunchArgument("steps_per_mm", default_value="80.0", description="motor steps per mm, both axes"),
        DeclareLaunchArgument("mock", default_value="false", description="run the mock board at `port`"),
        DeclareLaunchArgument("rviz", default_value="false", description="start RViz with plotter.rviz"),
        Node(package="plotter_bridge", executable="mock_board", namespace=namespace, output="screen",
             parameters=[{"link": port, "baud": baud}], condition=IfCondition(LaunchConfiguration("mock"))),
        Node(package="plotter_bridge", executable="serial_bridge", namespace=namespace, output="screen",
             parameters=[{"port": port, "baud": baud, "steps_per_mm": steps_per_mm}]),
        Node(package="plotter_bridge", executable="gcode_streamer", namespace=namespace, output="screen",
             parameters=[{"steps_per_mm": steps_per_mm}]),
        Node(package="plotter_shapes", executable="shape_server", namespace=namespace, output="screen"),
        Node(package="rviz2", executable="rviz2", arguments=["-d", rviz_config],
             condition=IfCondition(LaunchConfiguration("rviz"))),
    ])
