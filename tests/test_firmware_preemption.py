"""The images with the C step interrupt on Timer 0 (the option images and
BAUD=115200) put the UART and the e-stop pin above the step timer (IP in
firmware/hal/mcs51/main.c), so that a saturated step timer, first in
polling order, cannot shut them out.  They may then interrupt the step
interrupt anywhere; the one place where that would undo their work is the
timer's reload (HAL_TIMER_ADVANCE stops Timer 0, adds the period and starts
it again: a halt in between would be started again), so the reload masks
interrupts.  Checked in s51 on the BAUD=115200 image, which has the e-stop
pin: at each instruction of the reload in turn, the running move is stopped
there, the e-stop pin pulled low, and the move must stop for good.  The
move's cruise period is cut in the queue far below what this interrupt can
do (the image caps a feed where it keeps up), so that the reload also takes
its path for a late interrupt."""
import sys

import pytest

from firmware_build import FIRMWARE, mcu_image, require_s51

sys.path.insert(0, str(FIRMWARE / "tools"))
import bench  # noqa: E402
import isr_share  # noqa: E402
import s51sim  # noqa: E402

TCON, TR0 = 0x88, 0x10
IP = 0xB8


@pytest.fixture(scope="module")
def image():
    require_s51()
    return mcu_image(BAUD="115200")


def reload_window(sym):
    """Addresses of the step interrupt's instructions from the one after `clr EA` to `setb EA`."""
    code, _ = isr_share.module_code(sym.rst["stepper"])
    start, = sym.instructions("stepper", "_stepper_isr", "clr", "_EA")
    k = next(j for j, ins in enumerate(code) if ins.addr == start)
    window = []
    for ins in code[k + 1:]:
        window.append(ins.addr)
        if ins.mnemonic == "setb" and ins.operands == "_EA":
            return window
    raise AssertionError("no setb EA after the reload's clr EA")


def test_the_uart_and_the_e_stop_are_above_the_step_timer(image):
    with s51sim.Sim(image) as sim:
        sim.read_until(rb"ready[^\n]*\n")
        assert sim.sfr(IP) == 0x11          # PS, PX0; PT0 low


def test_an_e_stop_at_any_instruction_of_the_timer_reload_stops_the_move(image):
    """At each instruction of the reload: the e-stop's interrupt runs, and when the step interrupt
    it came into returns, Timer 0 is stopped (an unmasked reload would have started it again; the
    main loop would halt it once more, but late, when a saturated step timer starves it).  Then
    the move stays stopped, one step on at most (the pulse of the step interrupt under way), and
    the board reports the alarm."""
    sym = s51sim.Symbols(image)
    window = reload_window(sym)
    assert len(window) >= 8                  # clr TR0 ... setb TR0, setb EA
    retis = sym.instructions("stepper", "_stepper_isr", "reti")
    for addr in window:
        with s51sim.Sim(image) as sim:
            sim.read_until(rb"ready[^\n]*\n")
            # Queued under a hold with its cruise period cut far below the interrupt's cost: the
            # image caps a line where its interrupt keeps up, and the late path runs only beyond.
            sim.write(b"!!?")
            sim.read_until(rb"<Hold[^\n]*\n")
            assert sim.line(f"L 30000 0 {isr_share.RAMP_TOP}").startswith("ok")
            bench.saturate_queue(sim)
            sim.write(b"~~")
            sim.run_for(0.5)
            sim.run_to(addr, timeout=120)           # the late path: near the top of the climb
            sim.cmd("set hw port[3] 0xfb")   # INT0 (P3.2) falls
            sim.run_to(sym["_estop_isr"])
            x0 = sim.int32("_pos_x")
            for reti in retis:
                sim.cmd(f"tbreak 0x{reti:x}")
            sim.go()
            sim.wait_stop()
            tcon = sim.sfr(TCON)
            sim.run_for(0.3)
            sim.write(b"?")
            status = sim.read_until(rb"<[^>]*>").decode()
            x1 = sim.int32("_pos_x")
        assert not tcon & TR0, f"0x{addr:04x}: Timer 0 running when the step interrupt returned"
        assert 0 < x0 <= x1 <= x0 + 1, f"0x{addr:04x}: X {x0} at the e-stop, then {x1}"
        assert "<Alarm" in status, f"0x{addr:04x}: {status}"
