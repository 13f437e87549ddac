"""The real 8051 image (firmware/build/plotter.ihx) in the s51 simulator.

The simulated STC89C52RC (8052 core, 11.0592 MHz) gets typed command lines
through its UART, like a terminal would send them.  Checked:

- the banner and the replies (`$I`, `ok Q...`, the `?` status report);
- the position, read back from the board's RAM (pos_x, pos_y) and from the
  status report, exactly;
- the step and direction pulses on port 1, recorded as a VCD trace: the path
  rebuilt from them ends where it should, and step by step it is the path of
  the host build of the same core (libplotter_core.so) for the same
  commands, pen changes included;
- their timing: every interval between two pulses is the host core's
  (the timer schedule of the 8051 HAL) within the interrupt latency, and the
  intervals add up to the host core's total exactly.

Skipped when s51 (Debian package sdcc-ucsim) is missing, except on CI
(CI=true), where that is a failure.
"""
import re
import sys

import pytest

import vcd_trace
from firmware_build import FIRMWARE, QUIET_LATENCY, host_library, mcu_image, require_s51, uart_step_delay
from plotter_bridge.sim.firmware_core import FirmwareCore

sys.path.insert(0, str(FIRMWARE / "tools"))
import s51sim  # noqa: E402

STATUS = re.compile(r"<(\w+) X(-?\d+) Y(-?\d+) Q(\d+) N(\d+) S(\d+) P(\d+) U(\d+) A(\d+)>")
REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"

# Line, pen down, a clockwise quarter circle (centre 100 steps to the right of
# its start), pen up: typed lines, so the board answers with "ok Q<free>".
COMMANDS = ["L 300 -200", "P 1", "C 100 100 100 0", "P 0"]
END = (400, -100)


@pytest.fixture(scope="module")
def image():
    require_s51()
    return mcu_image()


def host_steps():
    """(dx, dy, cycles since the previous step, pen) per step of the host core."""
    core = FirmwareCore(host_library())
    try:
        core.transmitted()
        pen = False
        steps = []
        since = 0
        x1, y1 = core.position
        # the same loop as core_run_steps, watching the pen between ticks
        for due in core.interrupts(COMMANDS):
            since += due
            x0, y0 = x1, y1
            x1, y1 = core.position
            if (x1, y1) != (x0, y0):          # the pulse leaves first, then the port
                steps.append((x1 - x0, y1 - y0, since))     # takes a new pen state
                since = 0
            if core.pen_down != pen:
                pen = core.pen_down
                steps.append(("pen", pen))
        return steps, core.position
    finally:
        core.close()


def board_steps(vcd_path):
    """The same list, rebuilt from the port 1 trace of the 8051."""
    return [("pen", s.down) if isinstance(s, vcd_trace.Pen) else (s.dx, s.dy, s.cycles)
            for s in vcd_trace.steps(s51sim.read_vcd(vcd_path)["P1"])]


@pytest.fixture(scope="module")
def run(image, tmp_path_factory):
    vcd = str(tmp_path_factory.mktemp("s51") / "p1.vcd")
    with s51sim.Sim(image, vcd=vcd) as sim:
        banner = sim.read_until(rb"\r\n").decode()
        sim.vcd_start()
        sim.write(b"$I\n")
        info = sim.read_until(rb"\]").decode() + sim.read_until(REPLY).decode()
        replies = []
        for command in COMMANDS:
            sim.write(command.encode() + b"\n")
            replies.append(sim.read_until(REPLY).decode().strip())
        status = None
        for _ in range(100):                      # until the board is idle again
            sim.write(b"?")
            status = STATUS.search(sim.read_until(rb">[^\n]*\n").decode())
            if status.group(1) == "Idle":
                break
        sim.vcd_stop()
        ram = (sim.int32("_pos_x"), sim.int32("_pos_y"))
        max_sp = sim.max_sp()
        stack_start = int(re.search(r"Stack starts at: 0x([0-9a-fA-F]+)",
                                    (FIRMWARE / "build" / "plotter.mem").read_text()).group(1), 16)
    return dict(banner=banner, info=info, replies=replies, status=status, ram=ram,
                vcd=vcd, max_sp=max_sp, stack_start=stack_start)


def test_banner_and_replies(run):
    assert run["banner"].startswith("PLOTTER 8051 1.0 ready")
    assert re.match(r"\[PLOTTER 8051 1\.0 Q6 B64 R250 T12850 A100000\]\s*(\*\d+)?\r\nok Q6\b", run["info"])
    assert run["replies"][0].startswith("ok Q5")
    for reply in run["replies"]:
        assert re.match(r"ok Q[0-6]\b", reply), reply


def test_position_exact_in_ram_and_status(run):
    assert run["ram"] == END
    s = run["status"]
    assert s.group(1) == "Idle"
    assert (int(s.group(2)), int(s.group(3))) == END
    assert s.group(7) == "0"                      # pen up again
    assert s.group(9) == "0"                      # no alarm


def test_pulses_trace_the_host_cores_path(run):
    want, end = host_steps()
    assert end == END
    got = board_steps(run["vcd"])
    strip = [(s[0], s[1]) if s[0] != "pen" else s for s in got]
    assert strip == [(s[0], s[1]) if s[0] != "pen" else s for s in want]
    x = y = 0
    for s in got:
        if s[0] != "pen":
            x, y = x + s[0], y + s[1]
    assert (x, y) == END


def test_pulse_timing_matches_the_schedule(run):
    """Each interval between pulses is the host core's within the interrupt
    latency: a few cycles for the instruction the interrupt waits for, more
    when a status request masks interrupts to copy a value, and, while the
    UART works (the run is polled with `?`), one UART interrupt the chip
    takes first at their shared level.  And the intervals add up to the
    host's total within the latency: the timer reload of the 8051 HAL
    (TIMER_STOPPED_CYCLES) keeps the schedule without drift over the whole
    run."""
    want, _ = host_steps()
    got = board_steps(run["vcd"])
    w = [s[2] for s in want if s[0] != "pen"][1:]
    g = [s[2] for s in got if s[0] != "pen"][1:]
    assert len(w) == len(g)
    deviations = sorted(abs(a - b) for a, b in zip(g, w))
    assert deviations[-1] <= QUIET_LATENCY + uart_step_delay(mcu_image()), deviations[-1]
    assert deviations[len(deviations) // 2] <= 3          # typically 0..5
    assert abs(sum(g) - sum(w)) <= QUIET_LATENCY


def test_stack_stays_within_its_reserve(run):
    """tools/size.py keeps 40 bytes for the stack; the deepest use here must
    fit well inside (s51 reports the highest stack pointer)."""
    used = run["max_sp"] - run["stack_start"] + 1
    print(f"\ndeepest stack use: {used} of the 40 bytes kept")
    assert used <= 40, used


def test_position_copy_takes_a_step_between_its_reads():
    """stepper_snapshot copies X and Y for the status report and the LCD
    without masking the step interrupt, and copies again if a step came in
    between.  Stopped in s51 just after it has copied X, X is changed as a
    step would change it: the copy it returns must be the new X (SDCC once
    compiled the check as comparing pos_x with itself, and the stale X went
    out)."""
    require_s51()
    with s51sim.Sim(mcu_image()) as sim:
        sim.read_until(rb"ready[^\n]*\n")
        pos_x, copy = sim.sym["_pos_x"], sim.sym["_pos_copy"]
        sim.write(b"?")
        sim.run_to(sim.sym["_stepper_snapshot"])
        sim.set_iram(copy, b"\xaa" * 8)
        for _ in range(100):
            sim.cmd("step")
            if sim.iram(copy, 4) == sim.iram(pos_x, 4):
                break
        else:
            raise AssertionError("stepper_snapshot never copied X")
        sim.set_iram(pos_x, (1).to_bytes(4, "little"))
        sim.run_to(sim.sym.instructions("stepper", "_stepper_snapshot", "ret")[-1])
        assert sim.iram(copy, 8) == (1).to_bytes(4, "little") + bytes(4)
        status = STATUS.search(sim.read_until(rb"<[^>]*>[^\n]*\n").decode())
        assert status and status.group(2, 3) == ("1", "0")


def _memory_at_main(fill: int):
    """Internal RAM (above bank 0) and the 256 bytes of XRAM when main() is
    entered, every byte of both set to `fill` at reset."""
    require_s51()
    with s51sim.Sim(mcu_image()) as sim:
        for at in range(0, 256, 16):         # s51's command line is short
            sim.cmd(f"set memory xram 0x{at:x} " + " ".join([f"0x{fill:02x}"] * 16))
            if at >= 16:
                sim.cmd(f"set memory iram 0x{at:x} " + " ".join([f"0x{fill:02x}"] * 16))
        sim.cmd("set memory iram 0x08 " + " ".join([f"0x{fill:02x}"] * 8))
        sim.run_to(sim.sym["_main"])
        return sim.iram(0x08, 248), sim.dump("xram", 0, 256)


def test_start_up_leaves_the_same_memory_whatever_the_ram_held_at_power_on():
    """hal/mcs51/startup.asm clears all of internal RAM and XRAM before SDCC's
    initialisers run: main() starts from the same memory whether the chip's
    RAM came up all zeros, all ones or anything else."""
    zeros = _memory_at_main(0x00)
    for fill in (0xFF, 0xA5):
        iram, xram = _memory_at_main(fill)
        assert iram == zeros[0], f"internal RAM after power-on with 0x{fill:02X}"
        assert xram == zeros[1], f"XRAM after power-on with 0x{fill:02X}"
    assert zeros[1] == bytes(256)
