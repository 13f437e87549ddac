#!/usr/bin/env python3
"""What segment loads leave the UART: the step interrupt's cycles at every
interrupt of runs in which segments follow each other at speed, and the
least time they leave free in any byte time.

usage: tools/isr_loads.py [--command "A ...; C ..."] [build/plotter]

--command: that run alone, with the interrupts of its worst byte time.

tools/isr_share.py bounds the cruise; a segment load is the interrupt's
longest path (879 cycles by its listing), and short segments joined at
speed bring loads close together.  Here every step interrupt of a run is
timed: a breakpoint at its entry reads uCsim's ISR timer (which counts only
while an interrupt is in service; the UART is quiet during the run), so
the clocks between two entries are the first one's.  On the chip a pending
step interrupt always wins over the UART (IP in hal/mcs51/main.c), so the
UART interrupt waits for every step interrupt that starts before it can
run: in any stretch of one byte time, the steps' cycles must leave the
UART interrupt's longest path free (the receiver holds one byte).
"""
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402
import isr_share  # noqa: E402
import s51sim  # noqa: E402
from isr_share import ARC_TOP, BAUD, CYCLES_PER_S, RAMP_TOP, uart_isr_cycles  # noqa: E402


def paths():
    """isr_share's two paths with segment loads, and two more: shorter lines, longer arcs."""
    t, a = RAMP_TOP, ARC_TOP
    share = isr_share.paths()
    return {
        "lines of 40 steps joined at the lines' top feed": share["short lines, a segment load every 40 steps"],
        "lines of 4 steps joined at the lines' top feed": "; ".join([f"L 4 0 {t} {t}"] * 5 + [f"L 4 0 {t}"]),
        "half circles r 100 joined at the arcs' top feed":
            f"A -200 0 -100 0 {a} {a}; C 200 0 100 0 {a} {a}; A -200 0 -100 0 {a} {a}; L 100 0 {a}",
        "quarter arcs r 30 joined at the arcs' top feed": share["quarter arcs r 30, a load every 60 steps"],
    }


def interrupts(base, command):
    """(entry, cycles) of every step interrupt of the command's run, in machine cycles."""
    with s51sim.Sim(base) as sim:
        sim.go()
        sim.read_until(rb"ready[^\n]*\n")
        sim.write(b"!!?")
        sim.read_until(rb"<Hold[^\n]*\n")
        for line in bench.lines_of(command):
            reply = sim.line(line)
            if not reply.startswith("ok"):
                raise RuntimeError(f"{line!r}: {reply!r}")
        sim.stop()
        sim.cmd("timer add isr_run 1 isr")
        entry = sim.sym["_stepper_isr"]
        stop, = sim.sym.instructions("stepper_isr", "_stepper_isr", "clr", "_st_running")
        sim.cmd(f"break 0x{entry:x}")
        sim.cmd(f"break 0x{stop:x}")
        sim.go()
        sim.write(b"~~")
        marks = []
        while True:
            at = int(re.search(r"Stop at 0x([0-9a-f]+)", sim.wait_stop(timeout=120)).group(1), 16)
            clocks = int(re.search(r'"isr_run"\) ON,ISR [\d.]+ sec \((\d+) clks\)',
                                   sim.cmd("timer get")).group(1))
            marks.append((sim.ticks() // 12, clocks // 12))
            if at == stop:
                break
            sim.go()
    return [(t, c1 - c0) for (t, c0), (_, c1) in zip(marks, marks[1:])]


def worst_window(isrs, window):
    """(busy cycles, index of the first interrupt) of the stretch of `window` cycles, from an
    entry, in which the interrupts take the most."""
    worst = (0, 0)
    for k, (t0, _) in enumerate(isrs):
        busy = 0
        for t, d in isrs[k:]:
            if t >= t0 + window:
                break
            busy += min(d, t0 + window - t)
        worst = max(worst, (busy, k))
    return worst


def least_free(isrs, window):
    """The fewest cycles the interrupts leave in any stretch of `window` cycles (from an entry)."""
    return window - worst_window(isrs, window)[0]


def show_worst(base, command, window):
    isrs = interrupts(base, command)
    busy, k = worst_window(isrs, window)
    print(f"{command}: {len(isrs)} interrupts; the worst byte time starts at interrupt {k} and leaves "
          f"{window - busy:.0f} cycles free")
    print()
    print("| interrupt | starts, cycles after the first | cycles |")
    print("|---|---|---|")
    for j in range(k, len(isrs)):
        if isrs[j][0] >= isrs[k][0] + window:
            break
        print(f"| {j} | {isrs[j][0] - isrs[k][0]} | {isrs[j][1]} |")


def main(argv):
    args = list(argv[1:])
    command = None
    if "--command" in args:
        k = args.index("--command")
        command = args[k + 1]
        del args[k:k + 2]
    base = Path(args[0]) if args else s51sim.FIRMWARE / "build" / "plotter"
    if not s51sim.s51_path():
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 1
    uart = uart_isr_cycles(s51sim.Symbols(base))
    window = 10 * CYCLES_PER_S / BAUD
    if command:
        show_worst(base, command, window)
        return 0
    print(f"`python3 firmware/tools/isr_loads.py`: {base.name}, a byte every {window:.0f} cycles at {BAUD} "
          f"baud; the UART interrupt's longest path {uart} cycles")
    print()
    print("| path | interrupts | longest interrupt cycles | least free in a byte time |")
    print("|---|---|---|---|")
    ok = True
    for name, command in paths().items():
        isrs = interrupts(base, command)
        free = least_free(isrs, window)
        ok &= free >= uart
        print(f"| {name} | {len(isrs)} | {max(d for _, d in isrs)} | {free:.0f}"
              f"{'' if free >= uart else ' (fails)'} |")
    print()
    print(f"at least the UART interrupt's {uart} cycles free in every byte time: {'met' if ok else 'NOT met'}")
    return 0 if ok else 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
