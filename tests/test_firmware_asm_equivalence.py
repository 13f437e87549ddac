"""The hand-written step interrupt (firmware/hal/mcs51/stepper_isr.asm, in
the board's default image and its 6-clock build) against the C one it
transcribes (core/stepper.c), which the host library, the mock board and
the other tests run.

The same command batches go to the 8051 image in s51 and to the host build
of the core.  Each batch is queued under a feed hold (`!`) and released with
`~`, so that on both the queue holds the whole batch when the motion starts
(the serial line of the simulator is far slower than the steps, and a queue
that runs dry changes the ramp).  From the VCD trace of port 1:

- the step sequence (axis and direction of every pulse, the pen changes) is
  the host core's exactly;
- every pulse is on the host's schedule within the interrupt latency, or
  late after a long interrupt by less than the period then in force and
  back on it within RECOVERY steps: the auto-reloaded timer loses no
  period.  The one exception, measured and bounded: segments joined at the
  arcs' top feed, whose load takes more than two periods (LOADS_AT_SPEED);
- the pins keep the times step/direction drivers need (DRIVERS).

Batches: lines in all eight octants and along the axes, with exits at
junction speed; arcs through every quadrant both ways (full circles, quarter
and three-quarter arcs, ends off the axes and off the staircase), and at
the arcs' top feed; both ramp shapes, with level counts above 255; a long
dwell and the pen; a queue that wraps round, one that runs dry, the limit
switches.  A feed hold and an e-stop are typed at a set step of a cruising
line and of an arc on its fast path: the board's pulses are the host's with
the same byte at some step, no later than the bytes' time on the wire
allows, so they also show how soon the machine stops.  Last, every
instruction of the interrupt has run (or is named in NEVER_RUN, with why).
"""
import collections
import ctypes
import functools
import math
import re
import sys
from dataclasses import dataclass

import pytest

import vcd_trace
from firmware_build import FIRMWARE, host_library, mcu_image, require_s51
from plotter_bridge.sim.firmware_core import FirmwareCore

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402
from isr_share import ARC_TOP, module_code  # noqa: E402  (core/ramp.h)

LATENCY = 8          # machine cycles: the instruction an interrupt waits for, and a little
LOAD_OVERRUN = 64    # how much later than its time a pulse may come after a long interrupt, below the top feeds
# A long interrupt (a segment load, a level change at a high rate, an arc's
# turn into its final quadrant: about 320 cycles at cruise, under two
# periods at the arcs' top feed) makes its pulse late; the interrupts after
# it, each shorter than a period, catch up within RECOVERY steps.
RECOVERY = 4
BAUD = 9600

# The two builds of the image: s51's clock, and the build options.
IMAGES = {"12t": (s51sim.CLOCK_HZ, {}), "6t": (s51sim.CLOCK_HZ_6T, {"CPU6T": "1"})}

BATCHES = {
    "octants": ["L 120 50 4000 2500", "L 50 120 4000 2500", "L -50 120 4000 2500",
                "L -120 50 4000 2500", "L -120 -50 4000 2500", "L -50 -120 4000 0"],
    "octants2": ["L 50 -120 3000 2000", "L 120 -50 3000 1500", "L 0 90 3000 1000",
                 "L -90 0 3000 500", "L 0 -90", "L 90 0 4000"],
    "arcs": ["A 0 0 60 0 3000 1500", "C 0 0 60 0 3000 1500", "A 70 70 0 70 3000 1000",
             "C -70 70 -70 0 3000 800", "A -50 -50 0 -50 2000 500", "C 70 10 30 40 2500"],
    "arcs2": ["C 0 0 -45 -20 3000 1000", "A 0 0 25 -60 3000", "A -6 8 -3 4", "C 7 1 3 4 1500"],
    # Ends within a step of the circle but off the staircase: the final
    # quadrant's last steps go straight to the end (and enter it with a +Y move).
    "arcs_off_staircase": ["A -4 5 -5 0", "C -4 -5 -5 0", "A -5 6 -5 0", "A -2 3 -5 0", "C -2 -3 -5 0"],
    "exponential": ["$1=1", "L 400 -150 4000 2000", "A 0 0 -80 0 3000 1000", "L -400 150 4000"],
    # Arcs asking for 8000 steps/s, which the planner caps at the arcs' top
    # feed (core/ramp.h ARC_TOP), cruising on the fast path (st_arcfast).
    # Full circles both ways and arcs ending on and off the axes, each from
    # a stop to a stop; then the same with exits at junction speed, so that
    # they cruise to their ends, where an axis reaching its end coordinate
    # leaves the fast path; and arcs that end at speed on the fast path's ramp.
    "arcs_fast": ["A 0 0 300 0 8000", "C 0 0 -300 0 8000", "A -512 212 -300 0 8000",
                  "C 300 -300 300 0 8000", "A 0 0 0 -1 8000"],
    "arcs_fast_junctions": ["A 0 0 300 0 8000 8000", "C 0 0 -300 0 8000 8000",
                            "A -512 212 -300 0 8000 8000", "C 300 -300 300 0 8000 8000",
                            "A 0 0 0 -1 8000 8000", "L 200 0 8000 0"],
    "arcs_fast_ramp_ends": ["A 0 0 200 201 8000 8000", "C 0 0 -190 171 8000 8000", "L 100 0 8000 0"],
    # Ramp levels held so long that their step counts pass 255: $0 = 32
    # makes the trapezoid's 8-step levels 256 steps, $0 = 3 the exponential
    # ramp's top levels over 300; and a dwell of more than 255 ms.
    "long_levels": ["$0=32", "L 0 -6000 4500", "D 700", "L 1500 0 1500"],
    "long_levels_exp": ["$1=1", "$0=3", "L 8000 0 12000"],
    "pen": ["$1=0", "P 1", "L 30 -20 2000 1000", "D 3", "L -30 20 2000", "P 0"],
}
# Batches that need a state of the board a test reaches only after a long
# run, set in its variables while it is idle (preset), or its limit
# switches closed (switches: X, Y).
SPECIAL = {
    # The queue's slots from 5 on: the batch wraps round its end.
    "queue_wrap": dict(lines=["L 40 0 3000 2000", "L 0 40 3000 2000", "D 20", "L -40 0 3000 2000",
                              "C -20 -20 0 -20 3000 1000", "L 20 -20 3000"],
                       preset={"_q_head": b"\x05", "_q_tail": b"\x05"}),
    # Nothing queued behind a segment that asks to leave at speed: it
    # brakes to a stop and counts an underrun (the count's low byte at 255).
    "underrun": dict(lines=["L 300 -100 3000 2000"], preset={"_st_underruns": b"\xff\x00"}),
    # Both limit switches closed: a move away from them runs whole ...
    "limits_behind": dict(lines=["L 100 60 3000"], switches=(True, True)),
    # ... and one towards the closed X switch gives not one pulse.
    "limit_ahead": dict(lines=["L -100 60 3000"], switches=(True, False)),
}
# Bytes typed (hold: "!!", then "~~" once the pen stands; e-stop: ESC) as
# the interrupt enters the cruise (the label `at`): a line's, and an arc's,
# which then cruises on its fast path.
TYPED = {
    "hold_line": dict(lines=["L 3000 1300 3000"], at="cruise_set", typed=b"!!"),
    "hold_arc": dict(lines=["A 0 0 700 0 8000"], at="cruise_set", typed=b"!!"),
    "estop_line": dict(lines=["L 3000 1300 3000"], at="cruise_set", typed=b"\x1b"),
    "estop_arc": dict(lines=["A 0 0 700 0 8000"], at="cruise_set", typed=b"\x1b"),
}
# Segments joined at the arcs' top feed: the next segment's load runs over
# two periods, so that the pace dips there by whole periods (at most
# LOST_PER_LOAD a junction).
LOADS_AT_SPEED = {"arcs_fast_junctions", "arcs_fast_ramp_ends"}
LOST_PER_LOAD = 2
# Batches at the top feeds: a pulse after the turn into an arc's final
# quadrant, or after a ramp level change at a line's top rate, may be late
# by up to the period (more than LOAD_OVERRUN).
AT_TOP_FEED = {"arcs_fast", "hold_arc", "estop_arc", "long_levels_exp"} | LOADS_AT_SPEED

# What the step and direction inputs of common drivers need, in ns, from
# their data sheets: STEP high and low, DIR set up before and held after
# STEP's rising edge.  TB6600 modules (and the DM542 their manuals follow):
# DIR 5 us ahead of the pulse, pulses at least 2.5 us high and low.
DRIVERS = {
    "A4988": dict(high=1000, low=1000, setup=200, hold=200),
    "DRV8825": dict(high=1900, low=1900, setup=650, hold=650),
    "TB6600": dict(high=2500, low=2500, setup=5000, hold=0),
}

# Instructions no command batch can reach, each with why (keyed by the label
# they follow and the instruction, as the listing spells it).
NEVER_RUN = {
    ("cruise_end", "mov", "(_st_seg + 12),#1"):
        "an arc's step count running out at cruise before its final quadrant, where the count "
        "becomes exact: the count of the quadrants before is not short by more than the final "
        "quadrant's steps (no arc found, ends on and just past the axes, at the top feed); "
        "kept as the C's guard (core/stepper.c, cruise_end)",
    ("arc_endtest", "sjmp", "in_quadrant"):
        "a quadrant's staircase moves its ending coordinate one way only, so it meets that "
        "axis on the quadrant's own side; kept as the C's guard (core/stepper.c, the end test)",
    ("load_brake", "mov", "RCAP2L,#<(-64)"): "an empty segment: the planner queues none "
        "(no line of no steps, no dwell of 0 ms, an arc counts at least 1, a pen waits $3 >= 1 ms)",
    ("load_brake", "mov", "RCAP2H,#>(-64)"): "the same empty segment",
    ("load_brake", "jmp", "exit"): "the same empty segment",
}


@dataclass
class BoardRun:
    end: tuple          # the position counters after the run
    report: str         # a status report after it
    typed_ps: int       # when the typed bytes were written (s51's time), else 0


def spec(batch):
    if batch in SPECIAL:
        return SPECIAL[batch]
    if batch in TYPED:
        return TYPED[batch]
    return dict(lines=BATCHES[batch])


def run_host(lines, switches=(False, False), options=None, typed=None):
    """(dx, dy, cycles since the previous step, what changed since then:
    "level" of the ramp, "load" of a segment, "resume") per step, pen
    changes, and ("resume",) where a hold's resume starts the pen again; switches: the X
    and Y limit switches closed; typed: (k, bytes) received after the k-th
    step (a hold "!!" is resumed with "~~" once the pen stands)."""
    core = FirmwareCore(host_library(**(options or {})))
    try:
        assert core.has_panel or switches == (False, False)
        core.set_switches(*switches)
        core.transmitted()
        settings = [l for l in lines if l.startswith("$")]
        moves = [l for l in lines if not l.startswith("$")]
        for line in settings:
            core.receive(line.encode() + b"\n")
            core.poll(5)
        core.receive(b"!!")
        core.poll(3)
        for line in moves:
            core.receive(line.encode() + b"\n")
            core.poll(5)
        core.receive(b"~~")
        out, since, pen, steps = [], 0, core.pen_down, 0
        at, data = typed or (None, b"")
        resumed = False
        x1, y1 = core.position
        level = ctypes.c_uint8.in_dll(core._lib, "st_level")
        tail = ctypes.c_uint8.in_dll(core._lib, "q_tail")
        marks, state = set(), (level.value, tail.value)
        while True:
            core.poll()
            if steps == at:
                core.receive(data)
                core.poll(3)
                at = None
            if not core.timer_running():
                if data == b"!!" and at is None and not resumed:
                    core.receive(b"~~")
                    core.poll(3)
                    resumed = True
                    out.append(("resume",))
                    marks.add("resume")
                    continue
                break
            since += core.period()
            core.tick()
            if level.value != state[0]:
                marks.add("level")
            if tail.value != state[1]:
                marks.add("load")
            state = (level.value, tail.value)
            x0, y0 = x1, y1
            x1, y1 = core.position
            if (x1, y1) != (x0, y0):
                out.append((x1 - x0, y1 - y0, since, frozenset(marks)))
                since, steps, marks = 0, steps + 1, set()
            if core.pen_down != pen:
                pen = core.pen_down
                out.append(("pen", pen))
        return out
    finally:
        core.close()


def board_events(vcd, clock_hz):
    """Steps (dx, dy, cycles since the previous one, in the image's own
    machine cycles) and pen changes, from the VCD trace of port 1."""
    scale = clock_hz / s51sim.CLOCK_HZ       # vcd_trace counts 11.0592 MHz cycles
    return [("pen", s.down) if isinstance(s, vcd_trace.Pen)
            else (s.dx, s.dy, None if s.cycles is None else s.cycles * scale, s.t)
            for s in vcd_trace.steps(s51sim.read_vcd(vcd)["P1"])]


@pytest.fixture(scope="module", params=sorted(IMAGES))
def build(request):
    """(name, image base path, s51 clock, build options)."""
    require_s51()
    clock_hz, options = IMAGES[request.param]
    return request.param, mcu_image(**options), clock_hz, options


@functools.lru_cache(maxsize=None)
def isr_listing(image):
    """The step interrupt's instructions (stepper_isr.asm) in the image, and its labels."""
    return module_code(s51sim.Symbols(image).rst["stepper_isr"])


def isr_instructions(image):
    return isr_listing(image)[0]


def isr_label(image, name):
    return isr_listing(image)[1][("", name)]


# How many times each instruction of the step interrupt ran, per image,
# over every board run of this module (the coverage test at its end reads it).
EXECUTED = collections.defaultdict(collections.Counter)
RAN = collections.defaultdict(set)


def type_bytes(sim, data):
    """Bytes typed while the simulation is stopped, each taken by the receive
    interrupt before the next is written: s51 hands a byte to the UART as
    soon as it reads it, and one written while the step interrupt runs
    would overwrite the one before (on the wire each takes a byte time)."""
    reti, = sim.sym.instructions("main", "_uart_isr", "reti")
    for byte in data:
        sim.write(bytes([byte]))
        sim.cmd(f"tbreak 0x{reti:x}")
        sim.go()
        sim.wait_stop(timeout=30)


def run_board(build, batch, vcd):
    """The batch on the simulated board, as spec(batch) says."""
    name, image, clock_hz, _ = build
    run = spec(batch)
    switches = run.get("switches", (False, False))
    typed_ps = 0
    with s51sim.Sim(image, vcd=vcd, clock_hz=clock_hz) as sim:
        sim.read_until(rb"ready[^\n]*\n")
        if run.get("preset") or any(switches):
            for variable, data in run.get("preset", {}).items():
                sim.set_iram(sim.sym[variable], data)
            sim.cmd(f"set hw port[1] 0x{0xFF & ~(0x20 * switches[0]) & ~(0x80 * switches[1]):02x}")
        settings = [l for l in run["lines"] if l.startswith("$")]
        moves = [l for l in run["lines"] if not l.startswith("$")]
        for line in settings:
            assert sim.line(line).startswith("ok"), line
        sim.write(b"!!")
        sim.write(b"?")
        sim.read_until(rb"<Hold[^\n]*\n")
        for line in moves:
            reply = sim.line(line)
            assert reply.startswith("ok"), (line, reply)
        vcd_ticks = sim.ticks()               # the trace's times count from here
        sim.vcd_start()
        stopped, = sim.sym.instructions("stepper_isr", "_stepper_isr", "clr", "_st_running")
        if "at" in run:
            sim.cmd(f"tbreak 0x{isr_label(image, run['at']):x}")
            sim.go()
            sim.write(b"~~")
            sim.wait_stop(timeout=120)
            typed_ps = round((sim.ticks() - vcd_ticks) * 1e12 / clock_hz)
            type_bytes(sim, run["typed"])
            if run["typed"] == b"!!":
                # the pen stands: resume, and on to the end
                sim.cmd(f"tbreak 0x{isr_label(image, 'pause'):x}")
                sim.go()
                sim.wait_stop(timeout=120)
                type_bytes(sim, b"~~")
        if "at" not in run or run["typed"] == b"!!":
            if any(switches):
                if "at" not in run:
                    sim.write(b"~~")
                sim.run_for(1.5)         # a limit stops the timer, not the queue
            else:
                sim.cmd(f"tbreak 0x{stopped:x}")
                sim.go()
                if "at" not in run:
                    sim.write(b"~~")
                sim.wait_stop(timeout=120)
                sim.cmd("step")          # the queue's end: the interrupt's last two
                sim.cmd("step")          # instructions, for the coverage count
        else:
            sim.run_for(1.5)             # an e-stop: nothing more moves
        sim.vcd_stop()
        code = isr_instructions(image)
        counts = sim.fetches(code[0].addr, code[-1].addr)
        EXECUTED[name].update({i.addr: counts.get(i.addr, 0) for i in code})
        RAN[name].add(batch)
        end = sim.int32("_pos_x"), sim.int32("_pos_y")
        sim.write(b"?")
        return BoardRun(end, sim.read_until(rb"<[^\n]*>[^\n]*\n").decode(), typed_ps)


def strip(events):
    return [e[:2] if e[0] not in ("pen", "resume") else e for e in events if e[0] != "resume"]


def schedule(batch, got, want, moves):
    """Check each pulse's time against the host's schedule.  The board's
    lag behind it, error, is at each step its baseline (the least lag over
    this and the next RECOVERY steps) plus the pulse's own lateness, which
    a long interrupt causes and the next ones make up.  Lateness stays under
    the period in force (under LOAD_OVERRUN below the top feeds).  The
    baseline moves where a ramp level's period takes effect an interrupt
    late (the ramp runs behind or ahead of its table: drift), by less than
    a period (at the top feeds, where a level change may run over two
    periods, less than two); and at a segment load at speed, by whole
    periods the timer lost (only LOADS_AT_SPEED, at most LOST_PER_LOAD a
    load).  (A cruise keeps its schedule: firmware/tools/isr_share.py
    proves no cruise step runs over two periods.)  Returns the largest
    lateness, the late pulses, the drift and the periods lost."""
    steps = [e for e in want if e[0] not in ("pen", "resume")]
    w = [None if "resume" in e[3] else e[2] for e in steps][1:]
    marks = [e[3] for e in steps][1:]
    g = [e[2] for e in got if e[0] != "pen"][1:]
    assert len(g) == len(w)
    errors, error = [], 0.0
    for a, b in zip(g, w):
        error = 0.0 if b is None else error + a - b
        errors.append(error)
    base = [min(errors[k:k + RECOVERY + 1]) for k in range(len(errors))]
    events = []                             # [first step, last step, shift]: moves of the baseline
    worst, late = 0.0, 0
    for k, (e, b) in enumerate(zip(errors, w)):
        if b is None:
            continue
        shift = base[k] - base[k - 1] if k else 0.0
        if abs(shift) > LATENCY:
            if events and k - events[-1][1] <= RECOVERY + 1:
                events[-1][1:] = [k, events[-1][2] + shift]
            else:
                events.append([k, k, shift])
        lateness = e - base[k]
        assert lateness <= b - LATENCY, (k, lateness, b)
        if batch not in AT_TOP_FEED:
            assert lateness <= LOAD_OVERRUN, (k, lateness)
        worst = max(worst, lateness)
        late += lateness > LATENCY
    drift, lost = 0.0, 0
    for first, last, shift in events:
        b = w[first]
        loads = any("load" in marks[j] for j in range(max(first - RECOVERY - 1, 0), min(last + 2, len(marks))))
        n = round(shift / b)
        if loads and n > 0:
            assert abs(shift - n * b) <= 2 * LATENCY, (first, shift, b)
            assert batch in LOADS_AT_SPEED and n <= LOST_PER_LOAD, (first, shift, b)
            lost += n
        else:
            assert abs(shift) < (2 * b if batch in AT_TOP_FEED else b) - LATENCY, (first, shift, b)
            drift += shift
    assert lost <= LOST_PER_LOAD * moves, lost
    return worst, late, drift, lost


def on_schedule(batch, got, want, moves):
    try:
        schedule(batch, got, want, moves)
    except AssertionError:
        return False
    return True


# The shortest of each pin time over every run of this module, per image (ps).
SHORTEST = collections.defaultdict(dict)


def check_driver_timing(vcd, name):
    """The step and direction pins' times in the trace against every
    driver's needs; the shortest are kept for the summary."""
    timing = vcd_trace.pulse_timing(s51sim.read_vcd(vcd)["P1"])
    for axis, t in timing.items():
        for field in ("high", "low", "setup", "hold"):
            ps = getattr(t, field)
            if ps is None:
                continue
            SHORTEST[name][field] = min(ps, SHORTEST[name].get(field, ps))
            for driver, need in DRIVERS.items():
                assert ps >= need[field] * 1000, (axis, field, ps / 1e6, "us", driver)


@pytest.mark.parametrize("batch", sorted(BATCHES) + sorted(SPECIAL))
def test_pulse_for_pulse(build, tmp_path, batch):
    name, image, clock_hz, options = build
    run = spec(batch)
    want = run_host(run["lines"], run.get("switches", (False, False)), options)
    vcd = str(tmp_path / "p1.vcd")
    board = run_board(build, batch, vcd)
    got = board_events(vcd, clock_hz)
    assert strip(got) == strip(want)
    if batch == "underrun":
        assert re.search(r"\bU256\b", board.report), board.report     # both bytes, read together
    if batch == "limit_ahead":
        assert not got and "Alarm" in board.report, board.report
    steps = [e for e in want if e[0] != "pen"]
    assert board.end == (sum(e[0] for e in steps), sum(e[1] for e in steps))
    moves = len([l for l in run["lines"] if l[0] in "LAC"])
    if batch == "arcs_fast":
        assert min(e[2] for e in steps[1:]) == round(clock_hz / 12 / ARC_TOP)    # the planner's cap, on both
    worst, late, drift, lost = schedule(batch, got, want, moves)
    check_driver_timing(vcd, name)
    print(f"\n{name} {batch}: {len(steps)} steps, {late} pulses late after a long interrupt (at most "
          f"{worst:.0f} cycles), the ramp {drift:+.0f} cycles off its table, {lost} periods lost")


@pytest.mark.parametrize("batch", sorted(TYPED))
def test_hold_and_estop_stop_on_the_hosts_ramp_and_in_time(build, tmp_path, batch):
    """A feed hold or an e-stop typed while a line cruises, or an arc on its
    fast path (the hold leaves it for the full path's braking).  The board's
    pulses are the host's with the same bytes received after some step k:
    k is no later than the bytes' time on the wire (and one more byte time
    for the main loop) allows at the cruise rate.  After a hold the board
    brakes on the host's ramp, stands, and resumes to the end; after an
    e-stop no pulse follows."""
    name, image, clock_hz, options = build
    run = TYPED[batch]
    vcd = str(tmp_path / "p1.vcd")
    board = run_board(build, batch, vcd)
    got = board_events(vcd, clock_hz)
    before = len([e for e in got if e[0] != "pen" and e[3] <= board.typed_ps])
    period = min(e[2] for e in got[1:] if e[0] != "pen")
    wire = (len(run["typed"]) + 1) * 10 / BAUD * clock_hz / 12      # in machine cycles
    latest = before + math.ceil(wire / period)
    for k in range(before, latest + 1):
        want = run_host(run["lines"], options=options, typed=(k, run["typed"]))
        if strip(got) == strip(want) and on_schedule(batch, got, want, 1):
            break
    else:
        pytest.fail(f"no step from {before} to {latest} after which the host's {run['typed']!r} "
                    "gives the board's pulses and their times")
    if run["typed"] == b"\x1b":
        assert "Alarm" in board.report and len(got) == k, (board.report, len(got), k)
        assert k < len(strip(run_host(run["lines"], options=options)))
    else:
        assert board.end == tuple(map(sum, zip(*[e[:2] for e in want if e[0] not in ("pen", "resume")])))
    check_driver_timing(vcd, name)
    print(f"\n{name} {batch}: typed after step {before}, took effect after step {k} (at most {latest})")


@pytest.mark.parametrize("options", [{}, {"CPU6T": "1"}], ids=["12t", "6t"])
@pytest.mark.parametrize("f, bit", [("_st_lf", "LF_SIGN"), ("_st_af", "AF_SIGN")])
def test_sign_bits_are_the_high_bytes_of_f(options, f, bit):
    """stepper_isr.asm tests the signs of the line's and the arc's F as bits
    LF_SIGN and AF_SIGN, which are bit 7 of their high bytes only where the
    linker put st_lf and st_af: in bit-addressable RAM, at 0x25 and 0x27."""
    base = mcu_image(**options)
    size = {"_st_lf": 2, "_st_af": 4}[f]
    high = s51sim.Symbols(base)[f] + size - 1
    sign = int(re.search(rf"^{bit}\s*=\s*0x([0-9a-f]+)",
                         (FIRMWARE / "hal/mcs51/stepper_isr.asm").read_text(), re.M).group(1), 16)
    assert 0x20 <= high <= 0x2F, hex(high)
    assert sign == (high - 0x20) * 8 + 7, (hex(high), hex(sign))


def test_zz_every_instruction_of_the_step_interrupt_ran(build, tmp_path):
    """Every instruction of the step interrupt ran in this module's batches
    (s51's count of fetches per address), but those NEVER_RUN names.  Run
    alone, it runs the batches itself."""
    name, image, _, _ = build
    for batch in sorted(BATCHES) + sorted(SPECIAL) + sorted(TYPED):
        if batch not in RAN[name]:
            run_board(build, batch, str(tmp_path / f"{batch}.vcd"))

    def key(i):
        return (i.scope, "jmp" if i.mnemonic in ("ajmp", "ljmp") else i.mnemonic, i.operands)
    code = isr_instructions(image)
    excluded = {key(i): i for i in code if key(i) in NEVER_RUN}
    assert set(excluded) == set(NEVER_RUN), set(NEVER_RUN) - set(excluded)     # each names one that exists
    missing = [f"0x{i.addr:04x} {i.scope}: {i.mnemonic} {i.operands}" for i in code
               if not EXECUTED[name][i.addr] and key(i) not in NEVER_RUN]
    assert not missing, missing
    ran_anyway = [k for k, i in excluded.items() if EXECUTED[name][i.addr]]
    assert not ran_anyway, ran_anyway                    # an exclusion that is not true any more
    print(f"\n{name}: {len(code) - len(excluded)} of {len(code)} instructions ran, "
          f"{len(excluded)} cannot: {sorted(set(NEVER_RUN.values()))}")
    print(f"{name}: shortest pin times over the runs, us: " +
          ", ".join(f"{k} {v / 1e6:.1f}" for k, v in sorted(SHORTEST[name].items())))
