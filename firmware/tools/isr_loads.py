#!/usr/bin/env python3
"""What segment loads and a streaming link do to each other: the step
interrupt's cycles at every interrupt of runs in which segments follow each
other at speed, the longest a received byte waits behind them, and what the
UART's interrupts cost the steps while the host streams.

usage: tools/isr_loads.py [--command "A ...; C ..."] [build/plotter]

--command: that run alone, with its longest interrupts.

tools/isr_share.py bounds the cruise and gives the arbitration: the step
timer, the UART and the e-stop pin share the high level (IP in
hal/mcs51/main.c), so a received byte waits for at most the one interrupt
under way, however many steps are due, and a step for at most one UART
interrupt.  Here every step interrupt of a run is timed: a breakpoint at its
entry reads uCsim's ISR timer (which counts only while an interrupt is in
service; the UART is quiet during the run), so the clocks between two
entries are the first one's.  The longest of them, under way when a byte
comes in, sets that byte's wait (Arbitration.byte_wait), which must end
within a byte time.

Then each run again while the host streams (blank lines, which the board
reads and drops, and a status query every 64 bytes, which it answers: both
directions of the UART busy): the run's time against the same run with the
link quiet, in periods of its feed for each 9600-baud byte time of the run.
s51 takes bytes in at its own pace, about one every 0.55 ms (the 6T test
in tests/test_firmware_6t.py), nearly twice as often as 9600 baud brings
them, so the figure is on the high side.  The arbitration is the chip's in
s51 too (equal levels, polling order); isr_share.py's criterion bounds the
cost at one period a byte.
"""
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402
import isr_share  # noqa: E402
import s51sim  # noqa: E402
from isr_share import ARC_TOP, BAUD, CYCLES_PER_S, RAMP_TOP, arbitration  # noqa: E402


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
        sim.read_until(rb"ready[^\n]*\n")
        sim.write(b"!!?")
        sim.read_until(rb"<Hold[^\n]*\n")
        for line in bench.lines_of(command):
            reply = sim.line(line)
            if not reply.startswith("ok"):
                raise RuntimeError(f"{line!r}: {reply!r}")
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


# What the host sends while a run goes on: a byte every byte time, RX and TX interrupts both.
STREAM = (b"\n" * 63 + b"?") * 40


def stream_cost(base, command):
    """(the run's cycles with the link quiet, cycles more while the host streams) of one command
    as commanded."""
    quiet, _ = bench.run(base, s51sim.CLOCK_HZ, command, False)
    busy, _ = bench.run(base, s51sim.CLOCK_HZ, command, False, stream=STREAM)
    if len(busy) != len(quiet):
        raise RuntimeError(f"{command!r}: {len(busy)} steps with the link streaming, {len(quiet)} without")
    return sum(quiet), sum(busy) - sum(quiet)


def show_command(base, command, arb, window):
    isrs = interrupts(base, command)
    worst = sorted(range(len(isrs)), key=lambda k: -isrs[k][1])[:5]
    print(f"{command}: {len(isrs)} interrupts; the longest {isrs[worst[0]][1]} cycles, a byte behind it waits "
          f"{arb.byte_wait(isrs[worst[0]][1])} of {window:.0f}")
    print()
    print("| interrupt | starts, cycles after the first | cycles |")
    print("|---|---|---|")
    for k in sorted(worst):
        print(f"| {k} | {isrs[k][0] - isrs[0][0]} | {isrs[k][1]} |")


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
    arb = arbitration(s51sim.Symbols(base))
    window = 10 * CYCLES_PER_S / BAUD
    if command:
        show_command(base, command, arb, window)
        return 0
    print(f"`python3 firmware/tools/isr_loads.py`: {base.name}, a byte every {window:.0f} cycles at {BAUD} "
          f"baud; a byte waits for the interrupt under way and {arb.byte_wait(0)} cycles more; the UART "
          f"interrupt's longest path {arb.uart} cycles")
    print()
    print("| path | interrupts | longest interrupt cycles | a byte's longest wait cycles | run cycles, link quiet | "
          "more while the host streams | periods lost a byte time |")
    print("|---|---|---|---|---|---|---|")
    ok = True
    for name, command in paths().items():
        isrs = interrupts(base, command)
        longest = max(d for _, d in isrs)
        wait = arb.byte_wait(longest)
        quiet, more = stream_cost(base, command)
        period = CYCLES_PER_S / isr_share.feed_of(command)
        per_byte = max(0, more) / period / (quiet / window)
        ok &= wait <= window and per_byte <= 1
        print(f"| {name} | {len(isrs)} | {longest} | {wait}{'' if wait <= window else ' (fails)'} | {quiet} | "
              f"{more} | {per_byte:.2f} |")
    print()
    print(f"a byte waits less than a byte time, and the streaming costs the steps at most a period a byte time: "
          f"{'met' if ok else 'NOT met'}")
    return 0 if ok else 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
