"""The simulated board: the firmware core built for the host, the mock board
behind a pseudo-terminal, its fault injection and paced UART.  Pure Python,
no ROS (see docs/architecture.md)."""
