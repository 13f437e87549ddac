"""What the page sends is checked before anything moves."""
import pytest

from plotter_bridge.gcode.limits import WorkArea
from plotter_web.jobs import check_program, check_upload, is_svg, jog_program


def test_a_good_program_gets_a_preview_and_a_bad_one_its_line():
    ok = check_program("(sq)\nG21 G90\nG0 X10 Y10\nM3\nG1 X20 Y10 F900\nM5\nM2\n", "sq", WorkArea(), (0, 0))
    assert ok.ok and ok.preview == [[(10.0, 10.0), (20.0, 10.0)]]
    bad = check_program("G21 G90\nG1 X500 Y10 F900\nM2\n", "wide", WorkArea(), (0, 0))
    assert not bad.ok and bad.errors[0]["line"] == 2 and bad.errors[0]["text"] == "G1 X500 Y10 F900"


def test_uploads_are_named_and_refused_with_a_reason():
    job = check_upload("dir/p.gcode", b"(logo)\nG0 X1 Y1\nM2\n", WorkArea(), (0, 0))
    assert job.ok and job.name == "logo"
    assert check_upload("p.gcode", b"G0 X1\n\xff\n", WorkArea(), (0, 0)).errors[0]["line"] == 2
    assert "too large" in check_upload("p.gcode", b" " * (5 << 20), WorkArea(), (0, 0)).errors[0]["message"]
    assert is_svg("x.txt", b"  <?xml version='1.0'?><svg/>") and not is_svg("x.nc", b"G0 X1")


@pytest.mark.parametrize("dx,dy", [(0.1, 0.0), (0.0, -10.0), (-1.0, 1.0)])
def test_jog_is_a_relative_pen_up_move(dx, dy):
    job = check_program(jog_program(dx, dy), "jog", WorkArea(), (50.0, 50.0))
    assert job.ok and job.preview == []


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (11.0, 0.0), (float("nan"), 1.0)])
def test_a_jog_out_of_range_is_refused(dx, dy):
    with pytest.raises(ValueError):
        jog_program(dx, dy)
