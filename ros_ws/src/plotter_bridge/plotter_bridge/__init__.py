"""ROS 2 bridge to the plotter board: serial protocol, G-code streaming, mock board, CLI."""
