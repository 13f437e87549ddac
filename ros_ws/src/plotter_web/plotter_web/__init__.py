"""A web page for the pen plotter, served by the web_ui node."""
