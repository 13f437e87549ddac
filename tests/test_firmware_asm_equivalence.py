"""The hand-written step interrupt (firmware/hal/mcs51/stepper_isr.asm,
image `make ISR=asm`) against the C one it transcribes (core/stepper.c), which
the host library, the mock board and the other tests run.

The same command batches go to the 8051 image in s51 and to the host build
of the core.  Each batch is queued under a feed hold (`!`) and released with
`~`, so that on both the queue holds the whole batch when the motion starts
(the serial line of the simulator is far slower than the steps, and a queue
that runs dry changes the ramp).  From the VCD trace of port 1:

- the step sequence (axis and direction of every pulse, the pen changes) is
  the host core's exactly;
- every interval between two pulses is the host's schedule within the
  interrupt latency, and the intervals add up to the host's total.

Batches: lines in all eight octants and along the axes, with exits at
junction speed; arcs through every quadrant both ways (full circles, quarter
and three-quarter arcs, ends off the axes); both ramp shapes; a dwell and
the pen.  Then a feed hold and resume in the middle of a line, and an
e-stop (ESC) in the middle of another, whose pulses must be a prefix of the
host's path (their moment depends on the serial line, so not the timing).
"""
import re
import subprocess
import sys
import time

import pytest

import vcd_trace
from firmware_build import FIRMWARE, host_library, mcu_image, require_s51
from plotter_bridge.sim.firmware_core import FirmwareCore

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"
LATENCY = 8          # machine cycles: the instruction an interrupt waits for, and a little
LOAD_OVERRUN = 64    # how much longer than a period the interrupt that loads a segment may run

BATCHES = {
    "octants": ["L 120 50 4000 2500", "L 50 120 4000 2500", "L -50 120 4000 2500",
                "L -120 50 4000 2500", "L -120 -50 4000 2500", "L -50 -120 4000 0"],
    "octants2": ["L 50 -120 3000 2000", "L 120 -50 3000 1500", "L 0 90 3000 1000",
                 "L -90 0 3000 500", "L 0 -90", "L 90 0 4000"],
    "arcs": ["A 0 0 60 0 3000 1500", "C 0 0 60 0 3000 1500", "A 70 70 0 70 3000 1000",
             "C -70 70 -70 0 3000 800", "A -50 -50 0 -50 2000 500", "C 70 10 30 40 2500"],
    "arcs2": ["C 0 0 -45 -20 3000 1000", "A 0 0 25 -60 3000", "A -6 8 -3 4", "C 7 1 3 4 1500"],
    "exponential": ["$1=1", "L 400 -150 4000 2000", "A 0 0 -80 0 3000 1000", "L -400 150 4000"],
    "pen": ["$1=0", "P 1", "L 30 -20 2000 1000", "D 3", "L -30 20 2000", "P 0"],
}


def run_host(lines, prefix_only=False):
    """(dx, dy, cycles since the previous step) per step, and pen changes."""
    core = FirmwareCore(host_library())
    try:
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
        out, since, pen = [], 0, core.pen_down
        x1, y1 = core.position
        while True:
            core.poll()
            if not core.timer_running():
                break
            since += core.period()
            core.tick()
            x0, y0 = x1, y1
            x1, y1 = core.position
            if (x1, y1) != (x0, y0):
                out.append((x1 - x0, y1 - y0, since))
                since = 0
            if core.pen_down != pen:
                pen = core.pen_down
                out.append(("pen", pen))
        return out
    finally:
        core.close()


def board_events(vcd):
    return [("pen", s.down) if isinstance(s, vcd_trace.Pen) else (s.dx, s.dy, s.cycles)
            for s in vcd_trace.steps(s51sim.read_vcd(vcd)["P1"])]


@pytest.fixture(scope="module")
def image():
    require_s51()
    return mcu_image()


def run_board(image, lines, vcd, interrupt=None):
    """The batch on the simulated board; interrupt: bytes typed once the
    motion is under way (then run for a while rather than to the end)."""
    with s51sim.Sim(image, vcd=vcd) as sim:
        sim.go()
        sim.read_until(rb"ready[^\n]*\n")
        settings = [l for l in lines if l.startswith("$")]
        moves = [l for l in lines if not l.startswith("$")]
        for line in settings:
            assert sim.line(line).startswith("ok"), line
        sim.write(b"!!")
        sim.write(b"?")
        sim.read_until(rb"<Hold[^\n]*\n")
        for line in moves:
            reply = sim.line(line)
            assert reply.startswith("ok"), (line, reply)
        sim.stop()
        sim.vcd_start()
        stopped, = (sim.sym.instructions("stepper_isr", "_stepper_isr", "clr", "_st_running") if "stepper_isr" in sim.sym.rst else sim.sym.instructions("stepper", "_stepper_isr", "clr", "_st_running"))
        if not interrupt:
            sim.cmd(f"tbreak 0x{stopped:x}")
        sim.go()
        sim.write(b"~~")
        if interrupt:
            for data in interrupt:
                time.sleep(0.4)
                sim.write(data)
            time.sleep(1.5)
            sim.stop()
        else:
            sim.wait_stop(timeout=120)
        sim.vcd_stop()
        return sim.int32("_pos_x"), sim.int32("_pos_y")


def strip(events):
    return [e[:2] if e[0] != "pen" else e for e in events]


@pytest.mark.parametrize("batch", sorted(BATCHES))
def test_pulse_for_pulse(image, tmp_path, batch):
    lines = BATCHES[batch]
    want = run_host(lines)
    vcd = str(tmp_path / "p1.vcd")
    end = run_board(image, lines, vcd)
    got = board_events(vcd)
    assert strip(got) == strip(want)
    steps = [e for e in want if e[0] != "pen"]
    assert end == (sum(e[0] for e in steps), sum(e[1] for e in steps))
    w = [e[2] for e in want if e[0] != "pen"][1:]
    g = [e[2] for e in got if e[0] != "pen"][1:]
    assert len(g) == len(w)
    # The board's pulse times against the host's schedule: within the
    # latency, except where one interrupt ran longer than a period (a
    # segment load, a ramp level change at a high rate): that pulse and the
    # next may be late, and then the pulses are back on the schedule (the
    # auto-reloaded timer does not drift).
    errors, error = [], 0.0
    for a, b in zip(g, w):
        error += a - b
        errors.append(error)
    late = [k for k, e in enumerate(errors) if abs(e) > LATENCY]
    for k in late:
        assert abs(errors[k]) <= LOAD_OVERRUN, (k, errors[k])
        assert any(abs(e) <= LATENCY for e in errors[k + 1:k + 3]) or k + 1 >= len(errors), (k, errors[k:k + 3])
    worst = max(abs(e) for e in errors)
    print(f"\n{batch}: {len(g) + 1} steps, largest deviation from the schedule "
          f"{worst:.1f} cycles, {len(late)} pulses late after a long interrupt")


@pytest.mark.parametrize("typed", [[b"!!", b"~~"], [b"\x1b"]], ids=["hold", "estop"])
def test_hold_and_estop_keep_to_the_path(image, tmp_path, typed):
    lines = ["L 20000 9000 3000"]
    want = strip(run_host(lines))
    vcd = str(tmp_path / "p1.vcd")
    run_board(image, lines, vcd, interrupt=typed)
    got = strip(board_events(vcd))
    assert 0 < len(got) < len(want)
    assert got == want[:len(got)]


@pytest.mark.parametrize("options", [{}, {"CPU6T": "1"}], ids=["12t", "6t"])
def test_line_sign_bit_is_st_lf_high_byte(options):
    """stepper_isr.asm tests F's sign as bit LF_SIGN, which is bit 7 of
    st_lf's high byte only where the linker put st_lf: at 0x2d."""
    subprocess.run(["make", "-s", "-C", str(FIRMWARE), *(f"{k}={v}" for k, v in options.items()),
                    "build/6t/plotter.ihx" if options else "build/plotter.ihx"], check=True)
    base = FIRMWARE / "build" / ("6t/plotter" if options else "plotter")
    st_lf = s51sim.Symbols(base)["_st_lf"]
    lf_sign = int(re.search(r"^LF_SIGN\s*=\s*0x([0-9a-f]+)",
                            (FIRMWARE / "hal/mcs51/stepper_isr.asm").read_text(), re.M).group(1), 16)
    assert 0x20 <= st_lf + 1 <= 0x2F, hex(st_lf)
    assert lf_sign == (st_lf + 1 - 0x20) * 8 + 7, (hex(st_lf), hex(lf_sign))
