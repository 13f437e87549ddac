"""Shape geometry of the plotter and the DrawShape action server."""
