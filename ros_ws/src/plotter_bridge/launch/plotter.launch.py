"""One plotter: serial_bridge, gcode_streamer and shape_server in a namespace,
optionally the mock board and RViz, all with the settings of one params file.

    ros2 launch plotter_bridge plotter.launch.py port:=/dev/ttyUSB0
    ros2 launch plotter_bridge plotter.launch.py mock:=true port:=/tmp/plotter rviz:=true
    ros2 launch plotter_bridge plotter.launch.py namespace:=plotter2 port:=/dev/ttyUSB1
    ros2 launch plotter_bridge plotter.launch.py params_file:=my_plotter.yaml

The machine (steps per mm, work area, baud rate...) comes from `params_file`
(default: the installed config/plotter.yaml); only the port is given here,
since it differs from one plugged-in board to the next.  With mock:=true the
mock board makes `port` a link to its pseudo-terminal.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    namespace = LaunchConfiguration("namespace")
    port = LaunchConfiguration("port")
    params_file = LaunchConfiguration("params_file")
    default_params = PathJoinSubstitution([FindPackageShare("plotter_bridge"), "config", "plotter.yaml"])
    rviz_config = PathJoinSubstitution([FindPackageShare("plotter_bridge"), "rviz", "plotter.rviz"])
    return LaunchDescription([
        DeclareLaunchArgument("namespace", default_value="plotter", description="namespace of the plotter's nodes"),
        DeclareLaunchArgument("port", default_value="/dev/ttyUSB0", description="serial port of the board"),
        DeclareLaunchArgument("params_file", default_value=default_params,
                              description="the plotter's settings for every node (config/plotter.yaml)"),
        DeclareLaunchArgument("mock", default_value="false", description="run the mock board at `port`"),
        DeclareLaunchArgument("rviz", default_value="false", description="start RViz with plotter.rviz"),
        Node(package="plotter_bridge", executable="mock_board", namespace=namespace, output="screen",
             parameters=[params_file, {"link": port}], condition=IfCondition(LaunchConfiguration("mock"))),
        Node(package="plotter_bridge", executable="serial_bridge", namespace=namespace, output="screen",
             parameters=[params_file, {"port": port}]),
        Node(package="plotter_bridge", executable="gcode_streamer", namespace=namespace, output="screen",
             parameters=[params_file]),
        Node(package="plotter_shapes", executable="shape_server", namespace=namespace, output="screen",
             parameters=[params_file]),
        Node(package="rviz2", executable="rviz2", arguments=["-d", rviz_config],
             condition=IfCondition(LaunchConfiguration("rviz"))),
    ])
