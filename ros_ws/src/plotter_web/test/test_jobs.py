"""What the page sends is checked before anything moves."""
import pytest

from plotter_bridge.gcode.limits import WorkArea
from plotter_web.jobs import MAX_UPLOAD, check_program, check_upload, is_svg, jog_program


def test_a_good_program_gets_a_preview_and_a_bad_one_its_line():
    ok = check_program("(sq)\nG21 G90\nG0 X10 Y10\nM3\nG1 X20 Y10 F900\nM5\nM2\n", "sq", WorkArea(), (0, 0))
    assert ok.ok and ok.preview == [[(10.0, 10.0), (20.0, 10.0)]]
    bad = check_program("G21 G90\nG1 X500 Y10 F900\nM2\n", "wide", WorkArea(), (0, 0))
    assert not bad.ok and bad.errors[0]["line"] == 2 and bad.errors[0]["text"] == "G1 X500 Y10 F900"


def test_uploads_are_named_and_refused_with_a_reason():
    job = check_upload("dir/p.gcode", b"(logo)\nG0 X1 Y1\nM2\n", WorkArea(), (0, 0))
    assert job.ok and job.name == "logo"
    assert check_upload("p.gcode", b"G0 X1\n\xff\n", WorkArea(), (0, 0)).errors[0]["line"] == 2
    assert "too large" in check_upload("p.gcode", b" " * (MAX_UPLOAD + 1), WorkArea(), (0, 0)).errors[0]["message"]
    assert MAX_UPLOAD >= 20 << 20, "a million-line drawing is taken"
    assert is_svg("x.txt", b"  <?xml version='1.0'?><svg/>") and not is_svg("x.nc", b"G0 X1")


@pytest.mark.parametrize("dx,dy", [(0.1, 0.0), (0.0, -10.0), (-1.0, 1.0)])
def test_jog_is_a_relative_pen_up_move(dx, dy):
    job = check_program(jog_program(dx, dy), "jog", WorkArea(), (50.0, 50.0))
    assert job.ok and job.preview == []


@pytest.mark.parametrize("dx,dy", [(0.0, 0.0), (11.0, 0.0), (float("nan"), 1.0)])
def test_a_jog_out_of_range_is_refused(dx, dy):
    with pytest.raises(ValueError):
        jog_program(dx, dy)


THREE_PENS = (b'<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" viewBox="0 0 60 40">'
              b'<path d="M 5 5 L 20 5 M 25 5 L 35 5 M 20 5 L 25 5" stroke="black" fill="none"/>'
              b'<path d="M 40 10 L 55 25" stroke="red" fill="none"/>'
              b'<path d="M 40 35 L 55 35" stroke="blue" fill="none"/></svg>')


def pen_changes(program: str):
    return [line for line in program.splitlines() if " M6 " in line]


def test_an_svg_upload_draws_the_layers_asked_for_in_that_order():
    every = check_upload("p.svg", THREE_PENS, WorkArea(), (0, 0), width=60.0)
    assert every.ok and [c.split('"')[1] for c in pen_changes(every.program)] == ["black", "red", "blue"]
    two = check_upload("p.svg", THREE_PENS, WorkArea(), (0, 0), width=60.0, layers="3, 1")
    assert two.ok and [c.split('"')[1] for c in pen_changes(two.program)] == ["blue", "black"]
    # Each layer lands where it lies in the whole drawing: blue's line is where it was with every layer.
    blue = [p for p in every.preview if p[0][1] == p[-1][1] and p[0][1] < 100.0]
    assert blue and blue[0] in two.preview


def test_optimize_merges_a_layers_paths():
    plain = check_upload("p.svg", THREE_PENS, WorkArea(), (0, 0), width=60.0, layers="1")
    merged = check_upload("p.svg", THREE_PENS, WorkArea(), (0, 0), width=60.0, layers="1", optimize=True)
    assert plain.ok and merged.ok
    assert len(merged.preview) < len(plain.preview)


@pytest.mark.parametrize("layers, reasons", [("4", ["4 is not a layer"]), ("1,1,5", ["1 is given twice", "5 is not"]),
                                             ("x", ["give layer numbers"])])
def test_a_bad_layer_order_is_refused_with_every_reason_and_the_files_layers(layers, reasons):
    job = check_upload("p.svg", THREE_PENS, WorkArea(), (0, 0), width=60.0, layers=layers)
    assert not job.ok and len(job.errors) == 1
    message = job.errors[0]["message"]
    assert all(r in message for r in reasons), message
    if layers != "x":
        assert "1 'black'" in message and "3 'blue'" in message, message


def test_layers_are_for_svg_drawings_a_gcode_upload_is_read_as_it_is():
    job = check_upload("p.gcode", b"(logo)\nG0 X1 Y1\nM2\n", WorkArea(), (0, 0), layers="2,1")
    assert job.ok and job.name == "logo"
