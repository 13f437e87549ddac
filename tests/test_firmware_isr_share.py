"""What the step interrupt leaves the UART and the main loop on the chip
(firmware/tools/isr_share.py, `make -C firmware share`): at the fastest feed
the image accepts, a share of the CPU of at most two thirds, and while
cruising the UART interrupt's longest path free in every byte time.
Measured from s51's cycle counts with one interrupt source active, so s51's
arbitration (polling order, where the chip obeys priority) plays no part.
Lines meet it at the ramp's top feed, arcs at theirs (core/ramp.h ARC_TOP),
and no cruise step runs over two periods.
Also the longest-path count of a listing, on made-up ones."""
import sys

import pytest

from firmware_build import FIRMWARE, host_library, mcu_image, require_s51

sys.path.insert(0, str(FIRMWARE / "tools"))
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


@pytest.fixture(scope="module")
def figures():
    require_s51()
    host_library()
    base = mcu_image()
    uart = isr_share.uart_isr_cycles(s51sim.Symbols(base))
    window = 10 * isr_share.CYCLES_PER_S / isr_share.BAUD
    return uart, window, {f.name: f for f in isr_share.measure_all(base)}


def report(figures, window):
    return "\n".join(f"{f.name}: feed {f.feed}, share {100 * f.share:.1f} %, longest {f.longest}, "
                     f"least free {f.least_free(window)}" for f in figures)


def test_lines_at_the_top_feed_leave_the_uart_and_the_main_loop_their_time(figures):
    uart, window, by_name = figures
    lines = [f for name, f in by_name.items() if "line" in name]
    assert len(lines) == 5 and {f.feed for f in lines} == {isr_share.RAMP_TOP}
    assert all(f.ok(window, uart) for f in lines), report(lines, window)
    cruising = [f for f in lines if f.steps is not None]
    assert len(cruising) == 3 and all(len(f.steps) > 1000 for f in cruising)


def test_arcs_at_their_top_feed_leave_the_uart_and_the_main_loop_their_time(figures):
    uart, window, by_name = figures
    arcs = [f for name, f in by_name.items() if "arc" in name]
    assert len(arcs) == 5 and {f.feed for f in arcs} == {isr_share.ARC_TOP} and isr_share.ARC_TOP < isr_share.RAMP_TOP
    assert all(f.ok(window, uart) for f in arcs), report(arcs, window)
    cruising = [f for f in arcs if f.steps is not None]
    assert len(cruising) == 3 and all(len(f.steps) > 1000 for f in cruising)


def test_each_criterion_can_fail():
    """Made-up figures: a share over two thirds, too little left in a byte time, and one step running
    into a second period each fail on their own; the same figures without them pass."""
    window, uart = 960, 98
    ok = isr_share.PathFigures("arc", "A", 5000, 0.5, [90] * 20 + [300] + [90] * 20)
    assert ok.ok(window, uart)
    assert not isr_share.PathFigures("arc", "A", 5000, 0.7, ok.steps).ok(window, uart)
    assert not isr_share.PathFigures("arc", "A", 5000, 0.5, [150] * 40).ok(window, uart)
    long = isr_share.PathFigures("arc", "A", 6400, 0.5, [90] * 20 + [300] + [90] * 20)
    assert long.spans_two_periods() and not long.ok(window, uart)
