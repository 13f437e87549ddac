"""What the step interrupt and the UART leave each other and the main loop
on the chip (firmware/tools/isr_share.py, `make -C firmware share`): at the
fastest feed the image accepts, a share of the CPU of at most two thirds, no
cruise step over two periods, a UART interrupt costing the cruising steps at
most one period, and on any path a received byte read before the next one
is in.  The step timer, the UART and the e-stop share the high level (IP in
hal/mcs51/main.c), where the chip, as s51, takes pending interrupts in
polling order; the figures come from s51's cycle counts with one interrupt
source active and from the listings, so s51's arbitration plays no part.
Lines meet them at the ramp's top feed, arcs at theirs (core/ramp.h ARC_TOP).
Also the longest-path count of a listing, on made-up ones, and what a
streaming link costs the steps (tools/isr_loads.py)."""
import sys

import pytest

from firmware_build import FIRMWARE, QUIET_LATENCY, host_library, mcu_image, require_s51

sys.path.insert(0, str(FIRMWARE / "tools"))
import bench  # noqa: E402
import isr_loads  # noqa: E402
import isr_share  # noqa: E402
import s51sim  # noqa: E402


def listing(body: str) -> list:
    """An SDCC-style relocated listing of the given `label: mnemonic operands` lines."""
    out, addr = [], 0x100
    for n, line in enumerate(body.strip().splitlines(), 1):
        label, _, code = line.rpartition(":") if ":" in line.split()[0] else ("", "", line)
        if label and not code.strip():
            out.append(f"      {addr:06X}                        {n} {label.strip()}:")
            continue
        prefix = f"{label.strip()}:\t" if label else "\t"
        out.append(f"      {addr:06X} 00 00            [12]  {n} {prefix}{code.strip()}")
        addr += 2
    return out


def test_a_branch_counts_its_longer_side_and_a_call_its_callee():
    code = listing("""
_f:
jb _flag,1$
mov a,#1
mov r0,a
inc r0
1$: acall g
reti
g: push acc
pop acc
ret
""")
    # jb 2 + mov a 1 + mov r0 1 + inc 1 + acall 2 + (push 2 + pop 2 + ret 2) + reti 2
    assert isr_share.longest_path(*isr_share.module_code(code), "_f") == 15


def test_a_loop_counts_its_turns_and_an_unbounded_one_is_refused():
    code = listing("""
_f:
mov r3,#11
turn: movx a,@dptr
inc dptr
djnz r3,turn
reti
""")
    # mov 1 + 11 x (movx 2 + inc dptr 2 + djnz 2) + reti 2
    assert isr_share.longest_path(*isr_share.module_code(code), "_f", loops={"turn": 11}) == 69
    with pytest.raises(ValueError, match="loop"):
        isr_share.longest_path(*isr_share.module_code(code), "_f")


def test_cycles_of_the_data_sheet():
    assert [isr_share.cycles_of(m, o) for m, o in [("mov", "a,_x"), ("mov", "_x,_y"), ("mov", "r7,_SBUF"),
                                                   ("mov", "@r0,#1"), ("orl", "_P3,#0x10"), ("anl", "a,#0x0f"),
                                                   ("mul", "ab"), ("cjne", "r7,#0x18,1$"), ("setb", "_EA")]] == \
        [1, 2, 2, 1, 2, 1, 4, 2, 1]


def test_the_images_interrupts_have_bounded_longest_paths():
    sym = s51sim.Symbols(mcu_image())
    assert 40 < isr_share.uart_isr_cycles(sym) < 200
    assert 200 < isr_share.step_isr_cycles(sym) < 2000
    assert 5 < isr_share.estop_isr_cycles(sym) < 40
    assert 10 < isr_share.uart_rx_clear_cycles(sym) < 40


def test_a_received_byte_is_read_before_the_next_on_any_path():
    """Behind the step interrupt's longest path (a segment load with a quadrant change), an
    instruction, the e-stop's interrupt and another instruction, the UART clears RI within a byte
    time at 9600 baud."""
    arb = isr_share.arbitration(s51sim.Symbols(mcu_image()))
    window = 10 * isr_share.CYCLES_PER_S / isr_share.BAUD
    assert arb.image_byte_wait() <= window, arb


def test_the_step_timer_the_uart_and_the_e_stop_share_the_high_level():
    """The arbitration the figures assume, read from the running image: IP has PT2, PS and PX0 (the
    STC89C52RC's IPH is left at 0), and IE enables exactly those three."""
    require_s51()
    with s51sim.Sim(mcu_image()) as sim:
        sim.go()
        sim.read_until(rb"ready[^\n]*\n")
        sim.stop()
        ip, ie = sim.sfr(0xB8), sim.sfr(0xA8)
    assert ip == 0x31, hex(ip)
    assert ie == 0xB1, hex(ie)


@pytest.fixture(scope="module")
def figures():
    require_s51()
    host_library()
    base = mcu_image()
    arb = isr_share.arbitration(s51sim.Symbols(base))
    window = 10 * isr_share.CYCLES_PER_S / isr_share.BAUD
    return arb, window, {f.name: f for f in isr_share.measure_all(base)}


def report(figures, arb):
    return "\n".join(f"{f.name}: feed {f.feed}, share {100 * f.share:.1f} %, longest {f.longest}, "
                     f"a step's latest start {f.late_start(arb)}" for f in figures)


def test_lines_at_the_top_feed_leave_the_uart_and_the_main_loop_their_time(figures):
    arb, window, by_name = figures
    lines = [f for name, f in by_name.items() if "line" in name]
    assert len(lines) == 5 and {f.feed for f in lines} == {isr_share.RAMP_TOP}
    assert all(f.ok(window, arb) for f in lines), report(lines, arb)
    cruising = [f for f in lines if f.steps is not None]
    assert len(cruising) == 3 and all(len(f.steps) > 1000 for f in cruising)


def test_arcs_at_their_top_feed_leave_the_uart_and_the_main_loop_their_time(figures):
    arb, window, by_name = figures
    arcs = [f for name, f in by_name.items() if "arc" in name]
    assert len(arcs) == 5 and {f.feed for f in arcs} == {isr_share.ARC_TOP} and isr_share.ARC_TOP < isr_share.RAMP_TOP
    assert all(f.ok(window, arb) for f in arcs), report(arcs, arb)
    cruising = [f for f in arcs if f.steps is not None]
    assert len(cruising) == 3 and all(len(f.steps) > 1000 for f in cruising)


def test_each_criterion_can_fail():
    """Made-up figures: a share over two thirds, one step running into a second period, a step that
    a UART interrupt delays past two periods, and a cruise step too long for a byte's wait each fail
    on their own; the same figures without them pass."""
    window = 960
    arb = isr_share.Arbitration(uart=94, rx_clear=20, estop=11, step=854)
    ok = isr_share.PathFigures("arc", "A", 5000, 0.5, [90] * 20 + [300] + [90] * 20)
    assert ok.ok(window, arb) and ok.periods_lost_to_a_byte(arb) == 1
    assert not isr_share.PathFigures("arc", "A", 5000, 0.7, ok.steps).ok(window, arb)
    long = isr_share.PathFigures("arc", "A", 6400, 0.5, [90] * 20 + [300] + [90] * 20)
    assert long.spans_two_periods() and not long.ok(window, arb)
    slow_uart = isr_share.Arbitration(uart=260, rx_clear=20, estop=11, step=854)
    assert ok.periods_lost_to_a_byte(slow_uart) == 2 and not ok.ok(window, slow_uart)
    assert not ok.ok(300, arb)            # 300 cycles between bytes: the 300-cycle step leaves none
    line = isr_share.PathFigures("line", "L", 12850, 0.6, [56] * 40)
    assert line.ok(window, arb) and line.periods_lost_to_a_byte(arb) == 1


@pytest.mark.parametrize("command", ["L 3000 0 12850", "A 0 0 600 0 5000"])
def test_a_streaming_link_costs_the_steps_at_most_a_period_a_byte_time(command):
    """The run as commanded with the host streaming into the UART and the board answering, against
    the same run with the link quiet: every step there, and the run longer by at most one period
    for each 9600-baud byte time (isr_share's bound is one a byte; s51 takes bytes in nearly twice
    as often, and arbitrates as the chip at equal levels), or shorter by no more than an
    interrupt's latency (the steps' phase against the timer's)."""
    require_s51()
    host_library()
    quiet, more = isr_loads.stream_cost(mcu_image(), command)
    period = isr_share.CYCLES_PER_S / isr_share.feed_of(command)
    window = 10 * isr_share.CYCLES_PER_S / isr_share.BAUD
    assert -isr_share.LATENCY <= more <= period * quiet / window, (quiet, more, period)


# The images with core/stepper.c's interrupt on Timer 0, one of each interpolation method (the
# BAUD=115200 image is point-by-point with the front panel), at their own caps (core/ramp.h).
C_ISR_IMAGES = [{"BAUD": "115200"}, {"INTERP": "dda"}, {"INTERP": "compare"}]


@pytest.mark.parametrize("options", C_ISR_IMAGES, ids=lambda o: "-".join(o.values()))
def test_the_c_interrupt_images_at_their_caps_leave_the_main_loop_its_time_and_keep_the_schedule(options):
    """Their caps are below the board's (the C interrupt costs more an iteration), and at them every
    line and arc keeps the share and the cruising steps their periods (isr_share.CIsrFigures), and
    each run takes the host core's schedule: a run the interrupt cannot keep up with, or a period
    the timer takes a whole turn for, would be longer."""
    require_s51()
    base = mcu_image(**options)
    library = host_library(**options)
    line, arc = isr_share.image_caps(base)
    assert arc < line < isr_share.RAMP_TOP and arc < isr_share.ARC_TOP
    figures = isr_share.measure_c_isr(base)
    assert len(figures) == 8 and all(f.ok() for f in figures), figures
    assert {f.feed for f in figures if "line" in f.name} == {line}
    assert {f.feed for f in figures if "arc" in f.name} == {arc}
    for f in figures:
        if f.cruising:
            planned = sum(bench.host_schedule(library, f.command))
            assert planned <= f.run_cycles <= planned + 2 * f.period + 64, (f, planned)
    # The image's planner caps a faster feed there: a line asking for the ramp's top cruises at the
    # cap's period (the tenth shortest interval: a DDA iteration may step nothing).
    intervals, _ = bench.run(base, s51sim.CLOCK_HZ, f"L 6000 0 {isr_share.RAMP_TOP}", False)
    assert abs(sorted(intervals)[len(intervals) // 10] - isr_share.CYCLES_PER_S / line) <= QUIET_LATENCY


def test_the_c_interrupt_criteria_can_fail():
    """A share over two thirds fails anywhere; an interrupt over two periods fails a cruising path,
    not a segment load's."""
    ok = isr_share.CIsrFigures("line along X", "L", 3000, 0.5, 300, 0)
    assert ok.ok()
    assert not isr_share.CIsrFigures("line along X", "L", 3000, 0.7, 300, 0).ok()
    assert not isr_share.CIsrFigures("line along X", "L", 3000, 0.5, 700, 0).ok()
    assert isr_share.CIsrFigures("short lines, a segment load every 40 steps", "L", 3000, 0.5, 700, 0).ok()
