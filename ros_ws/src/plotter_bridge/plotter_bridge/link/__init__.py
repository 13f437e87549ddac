"""The wire to the board: the protocol's lines and replies, the streaming
link, the board session (reconnection, resets, real-time bytes) and the job
journal.  Pure Python, no ROS (see docs/architecture.md)."""
