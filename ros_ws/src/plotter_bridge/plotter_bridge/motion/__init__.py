"""Motion: step moves to board commands, the kinematics of each machine, the
look-ahead speed planner, and a whole program compiled to planned commands.
Pure Python, no ROS (see docs/architecture.md)."""
