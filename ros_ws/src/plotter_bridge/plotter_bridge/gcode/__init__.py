"""G-code in: the parser, its item types, arc geometry, the work-area check and
the conversion to integer steps.  Pure Python, no ROS (see docs/architecture.md)."""
