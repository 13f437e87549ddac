"""Line following (seed 003) in the host build of the firmware core: the
steering of core/follow.c run on virtual sheets (sim/sheet.py, sim/follow.py).

The sensors sit 3 mm from the pen; the lines are 7 and 8 mm wide (wider
than the ring, as the steering asks).  Over a sweep of closed smooth lines,
both ways round and in two places, the pen goes once round and stops at
the start, never off the black; a line that ends (met every way), or
breaks off for longer than the lost distance, is reported lost where it
ends.
Corners: vertices turning 30 to 60 degrees and 90 (squares), and rounded
right angles, are followed once round on the black, by the corner search
(follow.c); those it does not always take (72 degrees) or never takes
(120) stop the follow, and never send the pen round for ever.
"""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from follow_lines import (LINE_ENDS, LINES, Line, circle, distances, lollipop, path_length, polygon, rounded_rectangle,
                          square, with_gap)
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.sim.follow import FollowError, FollowGoal, follow
from plotter_bridge.sim.sheet import SensorRing, Sheet, SheetError

SPM = 80.0
RING = SensorRing(3.0)
WIDTHS = (7.0, 8.0)
SHIFT = (37.33, -21.71)          # the second place: not a whole number of steps from the first
CAP = 200_000


@pytest.fixture(scope="module")
def core():
    c = FirmwareCore()
    yield c
    c.close()


def shifted(line: Line, dx: float, dy: float) -> Line:
    return Line(line.name, tuple((x + dx, y + dy) for x, y in line.points), (line.start[0] + dx, line.start[1] + dy),
                line.heading_deg, line.closed, line.sharp)


def along(line, width: float, **kw) -> FollowGoal:
    """Setting out along the line, the start gate half its width."""
    return FollowGoal(line.heading_deg, gate_mm=width / 2, **kw)


SMOOTH = [line for line in LINES if not line.sharp]


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("place", [(0.0, 0.0), SHIFT], ids=["here", "shifted"])
@pytest.mark.parametrize("line", SMOOTH, ids=[line.name for line in SMOOTH])
def test_a_closed_smooth_line_is_followed_once_round_on_the_black(core, line, place, width):
    once_round_on_the_black(core, shifted(line, *place), width)


def once_round_on_the_black(core, line: Line, width: float) -> None:
    run = follow(core, Sheet([line.points], width), RING, line.start, along(line, width), SPM, CAP)
    trace = run.trace_mm(SPM)
    assert run.reason == "home"
    # Once round: not a second lap, not back the way it came.
    assert 0.98 <= path_length(trace) / line.length <= 1.15
    # The pen stays near the centre, by the sensors' spacing: drifting d off it, the sensor nearest the drift
    # (120 degrees apart, none more than 60 from it) is d + r cos 60 out and leaves the black at
    # d = width/2 - r/2, where the steering turns the pen back; 0.25 mm (20 steps) allows for its lag.
    assert distances(trace[::2], [line.points]).max() < width / 2 - RING.radius_mm / 2 + 0.25
    # It stops on the start gate, across the line from the start by no more than the gate's half width.
    assert math.dist(trace[-1], line.start) <= width / 2 + 1.0 / SPM


# The ends: every way, the sine waves in both places.
ENDS = ([(line, (0.0, 0.0)) for line in LINE_ENDS]
        + [(line, SHIFT) for line in LINE_ENDS if line.name.startswith("sine")])


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("line, place", ENDS, ids=[f"{line.name} {'here' if place == (0, 0) else 'shifted'}"
                                                   for line, place in ENDS])
def test_the_line_is_lost_where_it_ends(core, line, place, width):
    # On an 8 mm line the pen turns part way round the line's rounded end before the black falls behind it:
    # the corner search must not take the way back down the line for a way on.
    line = shifted(line, *place)
    run = follow(core, Sheet([line.points], width), RING, line.start, along(line, width), SPM, CAP)
    trace = run.trace_mm(SPM)
    assert run.reason == "lost"
    # Followed to its end, and stopped within the sensors' reach of it: neither way from the end finds a line.
    assert path_length(trace) >= 0.95 * (line.length - math.dist(line.points[0], line.start))
    assert math.dist(trace[-1], line.points[-1]) <= RING.radius_mm
    assert distances(trace[::2], [line.points]).max() < width / 2 + 5.0


@pytest.mark.parametrize("width", WIDTHS)
def test_a_short_gap_is_crossed(core, width):
    line = circle(100.0, 100.0, 30.0)
    run = follow(core, Sheet(with_gap(line, 2.0), width), RING, line.start, along(line, width), SPM, CAP)
    assert run.reason == "home"
    assert 0.98 <= path_length(run.trace_mm(SPM)) / line.length <= 1.15


@pytest.mark.parametrize("width", WIDTHS)
def test_a_long_gap_loses_the_line_where_it_breaks_off(core, width):
    line = circle(100.0, 100.0, 30.0)
    pieces = with_gap(line, 40.0)
    run = follow(core, Sheet(pieces, width), RING, line.start, along(line, width), SPM, CAP)
    assert run.reason == "lost"
    assert math.dist(run.trace_mm(SPM)[-1], pieces[0][-1]) <= 5.0 + RING.radius_mm + width / 2 + 1.0


def test_it_stops_after_the_distance_asked_for(core):
    line = circle(100.0, 100.0, 30.0)
    run = follow(core, Sheet([line.points], 7.0), RING, line.start, along(line, 7.0, distance_mm=50.0),
                 SPM, CAP)
    assert run.reason == "distance"
    assert len(run.trace) - 1 == 50 * SPM


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("line", [square(100.0, 100.0, 60.0), square(150.0, 80.0, 40.0, ccw=False)],
                         ids=["square ccw", "square cw"])
def test_a_square_with_sharp_corners_is_followed_once_round_on_the_black(core, line, width):
    once_round_on_the_black(core, line, width)


# Vertices turning 30 to 60 degrees and 90, sides of 20 and 40 mm, both ways round; right angles rounded.
CORNERED = [(polygon(100.0, 100.0, n, side, ccw), width) for n in (12, 10, 9, 8, 6, 4) for side in (20.0, 40.0)
            for ccw in (True, False) for width in WIDTHS] + \
    [(rounded_rectangle(100.0, 100.0, 60.0, 60.0, r), width) for r in (2.0, 6.0, 10.0) for width in WIDTHS]


@pytest.mark.parametrize("line, width", CORNERED, ids=[f"{line.name} {width:g} mm" for line, width in CORNERED])
def test_the_corners_stated_are_followed_once_round_on_the_black(core, line, width):
    once_round_on_the_black(core, shifted(line, *SHIFT), width)


# Vertices the corner search does not always take (72 degrees) and never takes (120 degrees).
NOT_ALWAYS = [polygon(100.0, 100.0, n, side, ccw) for n in (5, 3) for side in (20.0, 40.0) for ccw in (True, False)]


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("line", NOT_ALWAYS, ids=[line.name for line in NOT_ALWAYS])
def test_a_corner_not_taken_stops_the_follow_and_never_sends_the_pen_round_for_ever(core, line, width):
    # Followed home, or stopped (lost where neither way from the corner finds the line, or reversed), within
    # less than twice the line's length: never round and round, until the harness gave up.
    run = follow(core, Sheet([line.points], width), RING, line.start, along(line, width), SPM, CAP)
    assert run.reason in ("home", "lost", "reversed")
    assert path_length(run.trace_mm(SPM)) < 2.0 * line.length


def test_coming_back_through_the_start_the_other_way_is_reported_reversed(core):
    # A lollipop: up the stem, round the loop, and back down the stem through the start.
    line = lollipop(100.0, 40.0, 50.0, 60.0, 10.0)
    run = follow(core, Sheet([line.points], 7.0), RING, line.start, along(line, 7.0), SPM, CAP)
    trace = run.trace_mm(SPM)
    assert run.reason == "reversed"
    assert abs(trace[-1][1] - line.start[1]) <= 1.0 and abs(trace[-1][0] - line.start[0]) <= 3.5
    assert max(y for _, y in trace) > 120.0                         # it had been round the loop


# --- the sheet and the arguments -------------------------------------------------------------

def test_the_sensors_read_black_only_within_half_the_width_of_a_line():
    sheet = Sheet([[(0.0, 0.0), (100.0, 0.0)]], 8.0)
    assert sheet.sensor_bits(50.0, 0.0, RING) == 0b111
    # 1.5 mm up: the sensor at +Y (3 mm further up) is 4.5 mm from the centre, off the black.
    assert sheet.sensor_bits(50.0, 1.5, RING) == 0b110
    # 3 mm down: the sensors at 210 and 330 degrees are 4.5 mm below the centre.
    assert sheet.sensor_bits(50.0, -3.0, RING) == 0b001
    assert sheet.sensor_bits(50.0, 20.0, RING) == 0
    assert sheet.black((50.0, 3.99)) and not sheet.black((50.0, 4.01))


def test_a_sheet_from_gcode_has_its_pen_down_moves(tmp_path: Path):
    program = tmp_path / "line.gcode"
    program.write_text("G21 G90\nG0 X10 Y10\nM3\nG1 X60 Y10 F1000\nG2 X60 Y50 I0 J20\nM5\nG0 X0 Y0\n")
    sheet = Sheet.from_gcode(str(program), 6.0)
    assert sheet.black((35.0, 10.0))
    assert sheet.black((40.0, 30.0))           # on the clockwise arc's far side
    assert not sheet.black((80.0, 30.0))
    assert not sheet.black((5.0, 5.0))         # the pen-up travel draws nothing


@pytest.mark.parametrize("width", [0.0, -1.0, float("nan")])
def test_a_sheet_needs_a_line_width(width):
    with pytest.raises(SheetError, match="line width"):
        Sheet([[(0.0, 0.0), (1.0, 0.0)]], width)


def test_a_line_narrower_than_the_ring_is_refused_with_the_width_it_needs(core):
    line = circle(100.0, 100.0, 30.0)
    with pytest.raises(SheetError, match="wider than 6 mm"):
        follow(core, Sheet([line.points], 5.0), RING, line.start, along(line, 5.0), SPM, CAP)


@pytest.mark.parametrize("args, what", [
    (FollowGoal(lost_mm=0.0), "lost distance"),
    (FollowGoal(lost_mm=-1.0), "lost distance"),
    (FollowGoal(lost_mm=1000.0), "lost distance"),
    (FollowGoal(distance_mm=float("inf")), "distance"),
])
def test_bad_arguments_are_refused_before_anything_moves(core, args, what):
    line = circle(100.0, 100.0, 30.0)
    with pytest.raises(FollowError, match=what):
        follow(core, Sheet([line.points], 7.0), RING, (130.0, 100.0), args, SPM, CAP)
