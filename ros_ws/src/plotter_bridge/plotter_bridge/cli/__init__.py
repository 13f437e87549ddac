"""The plotter command line and the pictures it draws (see docs/architecture.md)."""
