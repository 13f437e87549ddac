"""An SVG's layers (plotter_shapes.svg_input read_layers, order_layers): one pen each, a pen change between.

The Inkscape-layer files are vpype's own test files (tests/data/drawings/SOURCES.md).
"""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from gcode_testlib import move_points  # noqa: F401  (puts plotter_bridge on the path)
from plotter_bridge.gcode.parser import parse_program
from plotter_bridge.gcode.types import Move, ToolChange
from plotter_shapes.svg_input import (PX_PER_MM, Placement, VectorError, drawing_program, order_layers,
                                      parse_layer_order, read_layers, read_svg, svg_program)

VPYPE = Path(__file__).parent / "data" / "drawings" / "vpype"
CORPUS = Path(__file__).parent / "data" / "corpus" / "svg"


def changes(program):
    return [i for i in parse_program("\n".join(program) + "\n").items if isinstance(i, ToolChange) and i.wait]


def drawn_by_layer(program):
    """The drawn moves' end points of each layer (split at the pen changes), rounded to 0.1 um."""
    out, layer = [], []
    for item in parse_program("\n".join(program) + "\n").items:
        if isinstance(item, ToolChange) and item.wait:
            out.append(layer)
            layer = []
        elif isinstance(item, Move) and item.pen == "down" and not item.rapid:
            layer.append((round(item.x, 4), round(item.y, 4)))
    return out + [layer]


def test_inkscape_layers_in_file_order_with_their_names():
    layers = read_layers(str(VPYPE / "multilayer_named_layers.svg"))
    assert [(layer.number, layer.name) for layer in layers] == [(1, "my layer 1"), (2, "my layer 2"), (3, "my layer 3")]
    assert layers[1].colour == "#0000ff"
    assert layers[0].colour == "" and layers[2].colour == "", "a layer of several colours names none"
    program = svg_program(str(VPYPE / "multilayer_named_layers.svg"))
    said = changes(program)
    assert [(c.tool, c.label) for c in said] == [(2, 'layer 2 "my layer 2" #0000ff'), (3, 'layer 3 "my layer 3"')]
    assert [len(d) > 0 for d in drawn_by_layer(program)] == [True, True, True]
    first = [i for i in parse_program("\n".join(program) + "\n").items if isinstance(i, ToolChange)][0]
    assert (first.label, first.wait) == ('layer 1 "my layer 1"', False), "the first pen is named, not waited for"


def test_vpype_s_numbered_layers_keep_the_file_s_order():
    layers = read_layers(str(VPYPE / "multilayer_by_attributes.svg"))
    assert [(layer.name, layer.colour) for layer in layers] == [("layer 1", "#990066"), ("3", "#0000ff"), ("2", "")]


def test_a_file_without_inkscape_layers_is_split_by_stroke_colour(colours):
    layers = read_layers(colours)
    assert [(layer.name, layer.colour, len(layer.drawing.lines)) for layer in layers] == [
        ("black", "#000000", 1), ("red", "#ff0000", 1), ("#0000ff", "#0000ff", 2)]
    said = changes(svg_program(colours))
    assert [c.label for c in said] == ['layer 2 "red" #ff0000', 'layer 3 "#0000ff" #0000ff']


def test_one_colour_is_one_layer_and_the_program_is_as_before():
    path = str(CORPUS / "shapes.svg")
    layers = read_layers(path)
    assert len(layers) == 1
    assert svg_program(path) == drawing_program(read_svg(path), Placement(), PX_PER_MM, 1500.0, path)


def test_a_given_order_draws_those_layers_where_they_lie_in_the_whole(colours):
    whole = drawn_by_layer(svg_program(colours))
    some = drawn_by_layer(svg_program(colours, order=[3, 1]))
    assert some == [whole[2], whole[0]], "layer 3 first, then 1, each where the whole drawing has it"
    assert [c.label for c in changes(svg_program(colours, order=[3, 1]))] == ['layer 1 "black" #000000']
    alone = svg_program(colours, order=[2])
    assert not changes(alone) and drawn_by_layer(alone) == [whole[1]]


def test_a_bad_order_says_every_reason_and_the_file_s_layers(colours):
    with pytest.raises(VectorError) as exc:
        order_layers(read_layers(colours), [3, 7, 3, 0])
    text = str(exc.value)
    for said in ("7 is not a layer", "0 is not a layer", "3 is given twice", "1 'black' #000000",
                 "2 'red' #ff0000", "3 '#0000ff' #0000ff"):
        assert said in text, text
    assert parse_layer_order("2, 1") == [2, 1]
    for bad in ("two", ",", "1;2"):
        with pytest.raises(VectorError):
            parse_layer_order(bad)


def points_by_layer(program):
    """Every drawn move's two ends, as a set per layer (an optimised path may run the other way)."""
    out, layer = [], set()
    for item in parse_program("\n".join(program) + "\n").items:
        if isinstance(item, ToolChange) and item.wait:
            out.append(layer)
            layer = set()
        elif isinstance(item, Move) and item.pen == "down" and not item.rapid:
            layer |= {(round(item.sx, 3), round(item.sy, 3)), (round(item.x, 3), round(item.y, 3))}
    return out + [layer]


def test_optimize_keeps_each_layer_to_itself(colours):
    assert points_by_layer(svg_program(colours, optimize_paths=True)) == points_by_layer(svg_program(colours))


# ------------------------------------------------------------ on the mock board, from the command line

def plotter_with_input(args, stdin_text, timeout=600):
    from test_plotter_cli import PLOTTER
    from node_processes import new_domain
    env = dict(os.environ, ROS_DOMAIN_ID=str(new_domain()))
    return subprocess.run([str(PLOTTER), *map(str, args)], input=stdin_text, capture_output=True, text=True,
                          timeout=timeout, env=env)


@pytest.mark.ros
def test_plotter_svg_waits_at_each_pen_change_for_enter(tmp_path, colours):
    from ros_graph import read_trace
    from plotter_bridge.motion.compiler import StreamerConfig
    from plotter_bridge.sim.expected import drawn_whole, program_steps
    trace, program = tmp_path / "trace.csv", tmp_path / "colours.gcode"
    r = plotter_with_input(["svg", colours, "--mock", "--quiet", "--feed", "6000", "--trace", trace,
                            "--gcode", program], "\n\n")
    assert r.returncode == 0, r.stderr
    asked = [line for line in r.stderr.splitlines() if line.startswith("pen change: put in")]
    assert asked == ['pen change: put in layer 2 "red" #ff0000, then press Enter (or run plotter resume); '
                     'Ctrl-C cancels',
                     'pen change: put in layer 3 "#0000ff" #0000ff, then press Enter (or run plotter resume); '
                     'Ctrl-C cancels']
    steps = [(x, y) for _, x, y in read_trace(trace)]
    assert (0, 0) in steps, "parked at the origin for the pen changes"
    assert steps[-1] == (round(135 * 80), round(85 * 80))
    # Every layer drawn, each once, to the step the firmware core takes for the program.
    assert drawn_whole(steps, program_steps(program.read_text(), StreamerConfig()), (0, 0), 80.0) == ""


@pytest.mark.ros
def test_plotter_svg_without_anyone_to_change_the_pen_stops_there_resumable(tmp_path, colours):
    from plotter_bridge.link.journal import Journal, job_summaries
    journal = tmp_path / "journal"
    r = plotter_with_input(["svg", colours, "--mock", "--quiet", "--journal", journal], "")
    assert r.returncode == 1, r.stderr
    assert "no one to change the pen" in r.stderr and "plotter resume" in r.stderr
    # The journal holds the job to finish, stopped with the first layer done: resumed, it starts at the change.
    (job,) = job_summaries(Journal(journal))
    assert job.resumable, job
    assert f"plotter resume {job.job_id}" in r.stderr
    record, _ = Journal(journal).load(job.job_id)
    assert record.commands[job.completed] == "M6 0", (job.completed, record.commands)
    r = plotter_with_input(["svg", colours, "--mock", "--quiet", "--feed", "6000", "--no-pen-wait"], "")
    assert r.returncode == 0, r.stderr
    assert r.stderr.count("(not waited for: --no-pen-wait)") == 2


def test_a_file_that_is_not_an_svg_is_refused_with_its_reason(tmp_path):
    bad = tmp_path / "garbage.svg"
    bad.write_text("<svg this is not")
    with pytest.raises(VectorError, match="cannot read as SVG"):
        read_layers(str(bad))


@pytest.mark.ros
def test_plotter_svg_preview_writes_the_plan_and_moves_nothing(tmp_path):
    docs = Path(__file__).resolve().parent.parent / "docs"
    r = plotter_with_input(["svg", docs / "three-pens.svg", "--width", "120", "--optimize", "--preview",
                            tmp_path / "plan.svg"], "")
    assert r.returncode == 0, r.stderr
    assert "with 3 pens (2 pen changes, not timed)" in r.stdout and "on the board" in r.stdout
    picture = (tmp_path / "plan.svg").read_text()
    assert all(f'id="layer-{k}"' in picture for k in (1, 2, 3)) and 'id="travel"' in picture
    r = plotter_with_input(["svg", docs / "three-pens.svg", "--preview", tmp_path / "plan.jpg"], "")
    assert r.returncode == 2 and "a picture is .svg or .png" in r.stderr
