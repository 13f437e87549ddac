"""The command F of the FOLLOW=1 build (firmware/PROTOCOL.md, "Line
following"), on the host build of that core: typed on the wire, queued,
steered by the sensors at every step period and ended with a state in the
status report.

The harness plays the board: before each step interrupt it sets the three
sensors from a virtual sheet where the pen is and runs the main loop's part
(follow_service), as the chip's main loop does between two steps.
"""
from __future__ import annotations

import math
import re

import pytest

from firmware_build import host_library
from follow_lines import LINES, circle, distances, path_length, sine_wave
from plotter_bridge.link.protocol import parse_reply
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.sim.sheet import SensorRing, Sheet

SPM = 80.0
RING = SensorRing(3.0)
WIDTH = 7.0
CAP = 200_000
STATUS = re.compile(r"<(\w+) X(-?\d+) Y(-?\d+) .* A(\d+) B(\d+) F(\d+) W(\d+)>")


@pytest.fixture()
def core():
    c = FirmwareCore(host_library(FOLLOW="1"))
    c.transmitted()                   # the banner
    yield c
    c.close()


def send(core: FirmwareCore, line: str) -> str:
    core.receive(line.encode() + b"\n")
    core.poll(4)
    return core.transmitted().decode()


def status(core: FirmwareCore) -> dict:
    core.receive(b"?")
    core.poll()
    m = STATUS.search(core.transmitted().decode())
    assert m, "no status report"
    state, x, y, alarm, bits, follow, walked = m.groups()
    return {"state": state, "x": int(x), "y": int(y), "alarm": int(alarm), "bits": int(bits),
            "follow": int(follow), "walked": int(walked)}


def run(core: FirmwareCore, sheet: Sheet, start: tuple, until=None):
    """Step the board until it stops (or until(ticks) is true); the pen in mm at each step.
    The sensors follow the pen at every step, whenever the main loop reads them."""
    def sense():
        core.set_sensors(sheet.sensor_bits_from(start, core.position, SPM, RING))

    trace = [start]
    ticks = 0
    sense()
    while core.timer_running() and ticks < CAP and not (until and until(ticks)):
        core.follow_service()
        if core.tick():
            x, y = core.position
            trace.append((start[0] + x / SPM, start[1] + y / SPM))
            sense()
        ticks += 1
        if ticks % 64 == 0:
            core.poll()
    core.poll()
    return trace


def notch(deg: float) -> int:
    return round(deg / 15) % 24


@pytest.mark.parametrize("feed", [0, 120, 250])
@pytest.mark.parametrize("line", LINES, ids=[line.name for line in LINES])
def test_f_follows_a_closed_line_once_round_and_reports_home(core, line, feed):
    sheet = Sheet([line.points], WIDTH)
    gate = round(WIDTH / 2 * SPM)
    assert send(core, f"F {notch(line.heading_deg)} 400 0 {gate}" + (f" {feed}" if feed else "")).startswith("ok")
    trace = run(core, sheet, line.start)
    s = status(core)
    assert (s["state"], s["follow"]) == ("Idle", 2)
    assert s["walked"] == len(trace) - 1
    assert 0.98 <= path_length(trace) / line.length <= 1.15
    assert distances(trace[::2], [line.points]).max() < WIDTH / 2
    assert math.dist(trace[-1], line.start) <= WIDTH / 2 + 1.0 / SPM


def test_the_feed_sets_the_step_period_up_to_the_start_rate(core):
    line = circle(100.0, 100.0, 30.0)
    sheet = Sheet([line.points], WIDTH)
    for feed, rate in ((100, 100), (250, 250), (5000, 250), (0, 250)):
        core.reset()
        core.transmitted()
        send(core, "F 6 400 200 280" + (f" {feed}" if feed else ""))
        run(core, sheet, line.start, until=lambda t: t > 20)
        assert abs(core.period() - 921_600 / rate) <= 1, feed


def test_a_line_that_ends_is_reported_lost_where_it_ends(core):
    line = sine_wave(20.0, 100.0, 120.0, 10.0, 60.0)
    sheet = Sheet([line.points], WIDTH)
    send(core, f"F {notch(line.heading_deg)} 400 0 280")
    trace = run(core, sheet, line.start)
    s = status(core)
    assert (s["state"], s["follow"]) == ("Idle", 3)
    assert math.dist(trace[-1], line.points[-1]) < 12.0


def test_the_distance_stop_and_the_sensor_bits(core):
    line = circle(100.0, 100.0, 30.0)
    sheet = Sheet([line.points], WIDTH)
    send(core, "F 6 400 800 280")
    run(core, sheet, line.start)
    s = status(core)
    assert (s["follow"], s["walked"]) == (4, 800)
    # The host's reader of the board's replies takes the follow's fields too.
    core.receive(b"?")
    core.poll()
    reply = parse_reply(core.transmitted().decode().strip())
    assert (reply.follow, reply.followed, reply.sensors) == (4, 800, s["bits"])
    core.set_sensors(0b101)
    assert status(core)["bits"] == 5


def test_an_estop_ends_the_follow_and_the_queue_takes_commands_again(core):
    line = circle(100.0, 100.0, 30.0)
    sheet = Sheet([line.points], WIDTH)
    send(core, "F 6 400 0 280")
    run(core, sheet, line.start, until=lambda t: t > 300)
    assert status(core)["follow"] == 1
    core.receive(b"\x1b")
    core.poll()
    s = status(core)
    assert (s["state"], s["alarm"], s["follow"]) == ("Alarm", 1, 5)
    core.receive(b"\n\x18\x18")
    core.poll(2)
    core.transmitted()
    assert send(core, "L 10 0").startswith("ok")


@pytest.mark.parametrize("line, error", [
    ("F 24 400 0 280", "E11"),        # heading: 0..23
    ("F 6 0 0 280", "E11"),           # lost: at least a step
    ("F 6 400 0", "E6"),              # too few arguments
    ("F 6 400 0 280 100 7", "E6"),    # too many
    ("F -6 400 0 280", "E11"),        # no negative numbers
    ("F 6 400 0 16384", "E11"),       # gate: 0..16383
])
def test_bad_f_commands_are_refused_and_nothing_moves(core, line, error):
    assert error in send(core, line)
    assert not core.timer_running()
    assert status(core)["follow"] == 0


def test_nothing_queues_behind_an_f_and_f_waits_for_rest(core):
    line = circle(100.0, 100.0, 30.0)
    sheet = Sheet([line.points], WIDTH)
    assert "E10" in send(core, "L 400 0\nF 6 400 0 280").split("\n")[-2]
    run(core, sheet, (0.0, 0.0))
    core.transmitted()
    assert send(core, "F 6 400 0 280").startswith("ok")
    assert "E10" in send(core, "L 10 0")
    assert "E10" in send(core, "P 1")
    run(core, sheet, line.start, until=lambda t: t > 100)
    assert "E10" in send(core, "F 6 400 0 280")


def test_a_hold_pauses_the_follow_and_resume_goes_on_the_same_way(core):
    line = circle(100.0, 100.0, 12.0)
    sheet = Sheet([line.points], WIDTH)
    send(core, "F 6 400 0 280")
    straight = run(core, sheet, line.start)
    core.reset()
    core.transmitted()
    send(core, "F 6 400 0 280")
    first = run(core, sheet, line.start, until=lambda t: t > 2000)
    core.receive(b"!!")
    core.poll()
    held = run(core, sheet, line.start)            # runs until the timer stops: the hold
    assert status(core)["state"] == "Hold"
    assert len(first) + len(held) - 2 < 2100        # stopped at once: the feed is the start rate
    x, y = core.position
    for _ in range(100):                            # nothing moves while held
        core.follow_service()
        core.poll()
    assert core.position == (x, y) and not core.timer_running()
    core.receive(b"~~")
    core.poll()
    rest = run(core, sheet, line.start)
    assert status(core)["follow"] == 2
    assert first + held[1:] + rest[1:] == straight


# --- the follow key (P2.3 on the board) ---------------------------------------------------------------

KEY_PASSES = 200                       # core/follow.h FOLLOW_KEY_PASSES
QUEUED, IDLE = 0xFC, 0xFD              # core/follow.h: the mailbox with an F queued, and with none
BAR = ((100.0, 100.0), (160.0, 100.0))  # a straight line along X


def press(core: FirmwareCore, passes: int) -> None:
    core.set_follow_key(True)
    core.poll(passes)


def test_the_follow_key_held_at_rest_starts_a_follow_along_x_before_any_f(core):
    sheet = Sheet([BAR], WIDTH)
    core.set_sensors(sheet.sensor_bits_from((110.0, 100.0), (0, 0), SPM, RING))
    press(core, KEY_PASSES - 1)                   # a bounce's worth: nothing
    assert core.follow_mailbox == IDLE and not core.timer_running()
    core.poll()                                   # the pass that queues it; the next starts it
    assert core.follow_mailbox == QUEUED
    core.set_follow_key(False)
    core.poll()
    assert core.timer_running()
    trace = run(core, sheet, (110.0, 100.0))
    s = status(core)
    # Heading 0 (+X) to the bar's end at X160, and lost there (the lost distance is FOLLOW_KEY_LOST, 5 mm).
    assert (s["state"], s["follow"]) == ("Idle", 3)
    assert all(b[0] >= a[0] for a, b in zip(trace[:400], trace[1:400]))       # setting out along +X
    assert 159.0 <= max(x for x, _ in trace) <= 160.0 + WIDTH / 2 + RING.radius_mm + 5.0


def test_the_follow_key_repeats_the_last_f_once_a_press_and_not_while_busy(core):
    sheet = Sheet([BAR], WIDTH)
    start = (150.0, 100.0)
    assert send(core, "F 12 400 800 280").startswith("ok")           # heading 12: -X, 800 steps
    press(core, KEY_PASSES)                                         # held while it runs: not at rest, nothing
    run(core, sheet, start)
    assert (status(core)["follow"], core.position) == (4, (-800, 0))
    core.poll(2 * KEY_PASSES)                                       # still held: no second follow
    assert core.follow_mailbox == IDLE and not core.timer_running()
    core.set_follow_key(False)
    core.poll()
    press(core, KEY_PASSES)                                         # a new press: the same F again
    core.set_follow_key(False)
    assert core.follow_mailbox == QUEUED
    core.poll()
    run(core, sheet, start)
    s = status(core)
    assert (s["follow"], s["walked"], core.position) == (4, 800, (-1600, 0))
