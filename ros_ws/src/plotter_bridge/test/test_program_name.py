"""A program's name for logs and errors: its leading comment."""
from plotter_bridge.gcode.parser import program_name


def test_the_leading_comment_names_a_program():
    assert program_name("(star)\nG21 G90\n") == "star"
    assert program_name("%\n; logo.svg  by  vpype\nG0 X1\n") == "logo.svg by vpype"
    assert program_name("\n\n(car reversed) G21\n") == "car reversed"
    assert program_name("G21 G90\n(late comment)\n") == "program"
    assert program_name("") == "program" and program_name("()\nG0 X1") == "program"
    assert program_name("(" + "x" * 100 + ")") == "x" * 60
    assert program_name("(\x07bell)\n", default="topic") == "topic"
