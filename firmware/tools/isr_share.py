#!/usr/bin/env python3
"""What the step interrupt leaves to the UART and the main loop, at the
fastest feed the image accepts on each path, in figures that hold on the
chip and not only in s51.

usage: tools/isr_share.py [--arc-feed N] [build/plotter]        (make share)
       tools/isr_share.py build/<options>/plotter   (make share INTERP=... or any option)

--arc-feed N: the arcs at N steps/s instead of their top feed, ARC_TOP
(the image caps them there, so N is at most ARC_TOP).

The arbitration (IP in hal/mcs51/main.c): the step timer, the UART and the
e-stop pin share the high level, so none interrupts another, and of those
pending when one returns the chip takes them in polling order (INT0, the
UART, Timer 2: the STC89C52RC's data sheet), as s51 does.  After a `reti`
one main-loop instruction runs before the next interrupt.  So:

- a received byte waits at most for the interrupt under way (any step
  interrupt, a segment load included), an instruction, the e-stop's
  interrupt and another instruction, and its own entry up to clearing RI;
  that must come before the next byte is in (the receiver holds one, a
  byte time: 960 cycles at 9600 baud).  The bound is counted from the
  listings, so it holds on every path at every feed;
- a step waits at most for one UART interrupt (and the e-stop's) beyond
  what the steps before it take: the auto-reloaded timer keeps the
  schedule's phase, and loses a period only when a step starts more than a
  period after its overflow, so the criterion is that one step's overrun of
  its period and one UART interrupt stay under two periods: a byte then
  costs the steps at most one period, and the position is exact.

Figures, none relying on s51's arbitration:

- the share: the step interrupt's clocks over a run (uCsim's ISR timer,
  which counts only while an interrupt is in service) against the run's
  clocks from its first step to its end.  Nothing else interrupts meanwhile
  (the UART is quiet after the `~~` that starts the run), so the figure is
  the step interrupt's own, the same on the chip; the main loop and the
  UART have the rest;
- the longest step while cruising, from a saturated run (the cruise period
  of every queued segment overwritten in RAM by one far shorter than the
  interrupt, tools/bench.py): its steps come back to back, so each interval
  is one interrupt and one main-loop instruction.  The shortest gap between
  two step interrupts at the path's fastest feed is that feed's period less
  the longest step;
- the longest paths of the UART, e-stop and step interrupts, counted from
  their listings (every branch both ways, calls included, the segment
  load's one loop at its count): bounds for any path, feasible or not.

The criteria (firmware/README.md), on every path at its fastest feed (lines
RAMP_TOP, arcs ARC_TOP, core/ramp.h): the share is at most SHARE_MAX, so
the main loop and the UART keep a third of the CPU; no cruise step runs
over two periods; a cruise step's overrun and one UART interrupt stay under
two periods; and, for the image, a received byte's longest wait is under a
byte time.
"""
import concurrent.futures
import os
import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402
import s51sim  # noqa: E402

SHARE_MAX = 2 / 3
BAUD = 9600               # the default image's UART (hal/mcs51/main.c)
# Candidate rates (Timer 1 at 11.0592 MHz with SMOD: TH1 0xFA, 0xFD and 0xFF; 38400 would need 254.5)
BAUDS = (9600, 19200, 38400, 57600)
CYCLES_PER_S = s51sim.CLOCK_HZ // 12


def _board_caps():
    """The board image's caps (core/ramp.h, its STEPPER_ASM branch): the ramp's top for a line, and
    ARC_TOP."""
    text = (s51sim.FIRMWARE / "core" / "ramp.h").read_text()
    top = int(re.search(r"#define\s+RAMP_TOP\s+(\d+)", text).group(1))
    m = re.search(r"#if defined\(STEPPER_ASM\)\s+#define LINE_TOP RAMP_TOP\s+#define ARC_TOP\s+(\d+)", text)
    return top, int(m.group(1))


RAMP_TOP, ARC_TOP = _board_caps()   # the fastest feeds the board's image accepts for a line and an arc


def image_caps(base):
    """(line, arc) caps of any image, from the host build of its options beside it (core/ramp.h:
    they follow the step interrupt the image runs)."""
    sys.path.insert(0, str(s51sim.FIRMWARE.parent / "ros_ws" / "src" / "plotter_bridge"))
    from plotter_bridge.sim.firmware_core import FirmwareCore
    core = FirmwareCore(Path(base).parent / "libplotter_core.so")
    try:
        return core.feed_caps
    finally:
        core.close()


LATENCY = 8               # machine cycles an interrupt may wait for the instruction under way, and a little

# 8051 machine cycles of the instructions that take two (MUL and DIV four); every other takes one.
TWO_CYCLES = {"ajmp", "ljmp", "sjmp", "jmp", "acall", "lcall", "ret", "reti", "jc", "jnc", "jb", "jnb",
              "jbc", "jz", "jnz", "cjne", "djnz", "movc", "movx", "push", "pop"}
JUMPS = {"ajmp", "ljmp", "sjmp"}
BRANCHES = {"jc", "jnc", "jb", "jnb", "jbc", "jz", "jnz", "cjne", "djnz"}


def cycles_of(mnemonic, operands):
    """Machine cycles of one 8051 instruction (the data sheet's table)."""
    ops = [o.strip().lower() for o in operands.split(",")] if operands else []
    if mnemonic in ("mul", "div"):
        return 4
    if mnemonic in TWO_CYCLES:
        return 2
    if mnemonic == "inc" and ops == ["dptr"]:
        return 2
    if mnemonic == "mov":
        dst, src = ops[0], ops[1]
        if dst == "dptr":
            return 2
        if dst == "c" or src == "c":
            return 2 if src == "c" else 1
        register = re.fullmatch(r"a|r[0-7]|@r[01]", dst) is not None
        if dst == "a":
            return 1
        if register:
            return 2 if not (src == "a" or src.startswith("#")) else 1
        return 1 if src == "a" else 2                   # mov direct, ...
    if mnemonic in ("anl", "orl", "xrl"):
        if ops[0] == "c":
            return 2
        return 2 if ops[0] != "a" and ops[1].startswith("#") else 1
    return 1


@dataclass(frozen=True)
class Instruction:
    addr: int
    mnemonic: str
    operands: str
    cycles: int
    scope: str            # the function it is in: SDCC's local labels (00101$) are its own


LABEL = re.compile(r"\s+([0-9A-F]{6})\s+\d+\s+([\w$]+):{1,2}\s*(?:;.*)?$")
CODE = re.compile(r"\s+([0-9A-F]{6})\s+(?:[0-9A-F]{2}\s)+\s*\[\d+\]\s+\d+\s+(?:([\w$]+):{1,2})?\s*(\w+)\s*([^;]*)")


def module_code(rst_lines):
    """The instructions of a listing and its labels' addresses, keyed (scope, name): a local
    label (00101$) by the function it is in, every other by ''."""
    code, labels, scope = [], {}, ""

    def label(name: str, addr: int) -> None:
        nonlocal scope
        if name.endswith("$"):
            labels[(scope, name)] = addr
        else:
            scope = name
            labels[("", name)] = addr
    for line in rst_lines:
        m = LABEL.match(line)
        if m:
            label(m.group(2), int(m.group(1), 16))
            continue
        m = CODE.match(line)
        if m:
            addr = int(m.group(1), 16)
            if m.group(2):
                label(m.group(2), addr)
            mnemonic, operands = m.group(3).lower(), m.group(4).strip()
            code.append(Instruction(addr, mnemonic, operands, cycles_of(mnemonic, operands), scope))
    return code, labels


def longest_path(code, labels, entry, loops=None):
    """Cycles of the longest path from the label `entry` to its reti (or ret), every conditional
    branch taken both ways and every call's own longest path added.  A loop counts only if it is
    named in `loops` ({head label: iterations}: a `djnz` back to the head closes it), each time
    round its longest body; any other loop, a computed jump or a call out of the listing is
    refused (its cost is not bounded here)."""
    index = {ins.addr: k for k, ins in enumerate(code)}
    heads = {index[labels[("", name)]]: n for name, n in (loops or {}).items()}
    memo = {}

    def target(ins):
        name = ins.operands.split(",")[-1].strip()
        key = (ins.scope if name.endswith("$") else "", name)
        if key not in labels:
            raise ValueError(f"{ins.mnemonic} {ins.operands} at 0x{ins.addr:04x}: not in the listing")
        return index[labels[key]]

    def cost(k, seen=frozenset(), stop=None):
        if k == stop:                          # a loop body ends at its closing djnz
            return code[k].cycles
        if stop is None and k in memo:
            return memo[k]
        if k in seen:
            raise ValueError(f"a loop at 0x{code[k].addr:04x} without a bound")
        ins = code[k]
        seen = seen | {k}
        if k in heads and stop is None:
            close = next(j for j in range(k, len(code))
                         if code[j].mnemonic == "djnz" and target(code[j]) == k)
            total = heads[k] * cost(k, frozenset(), close) + cost(close + 1, seen)
            memo[k] = total
            return total
        if ins.mnemonic == "jmp":
            raise ValueError(f"computed jump at 0x{ins.addr:04x}")
        if ins.mnemonic in ("reti", "ret"):
            after = 0
        elif ins.mnemonic in JUMPS:
            after = cost(target(ins), seen, stop)
        elif ins.mnemonic in BRANCHES:
            after = max(cost(target(ins), seen, stop), cost(k + 1, seen, stop))
        elif ins.mnemonic in ("acall", "lcall"):
            after = cost(target(ins)) + cost(k + 1, seen, stop)
        else:
            after = cost(k + 1, seen, stop)
        if stop is None:
            memo[k] = ins.cycles + after
        return ins.cycles + after
    return cost(index[labels[("", entry)]])


def uart_isr_cycles(sym):
    """The UART interrupt's longest path, with the hardware's call into it and the vector's jump
    (2 cycles each)."""
    return 2 + 2 + longest_path(*module_code(sym.rst["main"]), "_uart_isr")


def estop_isr_cycles(sym):
    """The e-stop pin's interrupt's longest path, with the hardware's call and the vector's jump (0 in
    an image without it)."""
    code, labels = module_code(sym.rst["main"])
    return 2 + 2 + longest_path(code, labels, "_estop_isr") if ("", "_estop_isr") in labels else 0


def uart_rx_clear_cycles(sym):
    """Cycles from the UART interrupt's call to the end of the instruction that clears RI (its
    `jbc RI`): from then the receiver can take the next byte."""
    code, labels = module_code(sym.rst["main"])
    k = next(j for j, ins in enumerate(code) if ins.addr == labels[("", "_uart_isr")])
    total = 2 + 2
    for ins in code[k:]:
        total += ins.cycles
        if ins.mnemonic == "jbc" and ins.operands.split(",")[0].strip() == "_RI":
            return total
        if ins.mnemonic in BRANCHES | JUMPS | {"reti"}:
            raise ValueError(f"{ins.mnemonic} at 0x{ins.addr:04x} before the UART interrupt clears RI")
    raise ValueError("the UART interrupt does not clear RI")


# The longest instruction (MUL, DIV): after a `reti` one main-loop instruction runs before the
# next interrupt is taken.
INSTRUCTION = 4


@dataclass(frozen=True)
class Arbitration:
    """The interrupts' longest paths in machine cycles, from the image's listings."""
    uart: int            # the UART interrupt, whole
    rx_clear: int        # the UART interrupt up to clearing RI
    estop: int           # the e-stop pin's interrupt
    step: int            # the step interrupt, any path (a segment load with a quadrant change)

    def byte_wait(self, under_way):
        """The longest a received byte waits, from RI up to its clearing, behind an interrupt of
        `under_way` cycles: that interrupt, an instruction, the e-stop's interrupt (first in
        polling order), an instruction, and the UART's own entry."""
        return under_way + INSTRUCTION + self.estop + INSTRUCTION + self.rx_clear

    def uart_delay(self):
        """What the interrupts taken before a step in polling order add to its wait: the e-stop's
        and the UART's, an instruction after each."""
        return self.estop + INSTRUCTION + self.uart + INSTRUCTION

    def step_wait(self):
        """The most a step interrupt waits, once its predecessor is done: uart_delay and its own
        entry."""
        return self.uart_delay() + LATENCY

    def image_byte_wait(self):
        return self.byte_wait(max(self.step, self.uart))


def arbitration(sym):
    return Arbitration(uart_isr_cycles(sym), uart_rx_clear_cycles(sym), estop_isr_cycles(sym),
                       step_isr_cycles(sym))


def step_isr_cycles(sym):
    """The step interrupt's longest path, with the hardware's call and the vector's jump: its one
    loop copies a segment from the queue two bytes a turn (SEG_SIZE / 2 turns)."""
    lines = sym.rst["stepper_isr"]
    size = next(int(m.group(1)) for m in (re.search(r"\bSEG_SIZE\s*=\s*(\d+)", line) for line in lines) if m)
    return 2 + 2 + longest_path(*module_code(lines), "_stepper_isr", loops={"load_byte": size // 2})


def load_paths(t, a):
    """Segments joined at speed, a load every few dozen steps: lines at t, arcs at a."""
    quarter = ["A 30 30 0 30", "A -30 30 -30 0", "A -30 -30 0 -30", "A 30 -30 30 0"]
    return {
        "short lines, a segment load every 40 steps": "; ".join([f"L 40 0 {t} {t}"] * 5 + [f"L 40 0 {t}"]),
        "quarter arcs r 30, a load every 60 steps": "; ".join([f"{q} {a} {a}" for q in quarter]
                                                              + [f"{quarter[0]} {a}"]),
    }


# Each path at the fastest feed the image accepts for it.  Settings first (`$k=v; ...`).
def paths(arc_feed=ARC_TOP, line_feed=RAMP_TOP):
    t, a = line_feed, arc_feed
    return {
        "line along X": f"L 30000 0 {t}",
        "line along Y": f"L 0 30000 {t}",
        "line, diagonal": f"L 20000 -20000 {t}",
        "line, exponential ramp": f"$1=1; L 30000 0 {t}",
        "arc, counter-clockwise": f"A 0 0 1500 0 {a}",
        "arc, clockwise": f"C 0 0 0 3000 {a}",
        "arc ending off the axes": f"A -2561 1061 -1500 0 {a}",
        "arc on the ramp throughout": f"A 0 0 0 -25 {a}",
        **load_paths(t, a),
    }


def feed_of(command):
    """The fastest rate a path's commands ask for."""
    return max(int(line.split()[5 if line[0] in "AC" else 3]) for line in bench.lines_of(command)
               if line[0] in "LAC")


def share_run(base, command):
    """(step interrupt clocks, run clocks from its first step to its end, each step interrupt's
    cycles) of one command, as commanded.  The last only for core/stepper.c's interrupt, whose
    register bank (PSW.3) the trace shows."""
    with tempfile.TemporaryDirectory() as tmp:
        vcd = str(Path(tmp) / "trace.vcd")
        with s51sim.Sim(base, vcd=vcd) as sim:
            sim.read_until(rb"ready[^\n]*\n")
            sim.cmd("timer add isr_run 1 isr")
            sim.cmd("timer add all_run 1")

            def zero(sim):
                sim.cmd("timer set isr_run 0")
                sim.cmd("timer set all_run 0")
            bench.measure(sim, command, False, before_run=zero)
            text = sim.cmd("timer get")
        isr = int(re.search(r'"isr_run"\) ON,ISR [\d.]+ sec \((\d+) clks\)', text).group(1))
        total = int(re.search(r'"all_run"\) ON [\d.]+ sec \((\d+) clks\)', text).group(1))
        ev = s51sim.read_vcd(vcd)
        prev, first = 0xFF, None
        for t, v in ev["P1"]:
            if v & bench.STEP_BITS and not prev & bench.STEP_BITS:
                first = t
                break
            prev = v
        idle = round(first * s51sim.CLOCK_HZ / 10**12) if first is not None else 0
        overhead = bench.isr_overhead(s51sim.Symbols(base))
        each = bench.analyse(vcd, overhead, s51sim.CLOCK_HZ)[1] if overhead is not None else []
        return isr, total - idle, each


def cruise_interrupts(base, command):
    """Cycles of each step interrupt while cruising, in order, from a saturated run of a command
    long enough to cruise: its back-to-back intervals over the middle half (checked to be cruise
    against the host core's schedule), less the one main-loop instruction between two."""
    intervals, _ = bench.run(base, s51sim.CLOCK_HZ, command, True)
    middle = bench.cruise_of(base.parent / "libplotter_core.so", command, len(intervals))
    return [intervals[k] - 1 for k in middle]


@dataclass
class PathFigures:
    name: str
    command: str
    feed: int
    share: float
    steps: Optional[List[int]]      # cycles of each cruise step (None: the path never cruises long)

    @property
    def period(self):
        return CYCLES_PER_S / self.feed

    @property
    def longest(self):
        return None if self.steps is None else max(self.steps)

    @property
    def gap(self):
        """The shortest gap between two cruise steps (below 0: a step longer than the period, which
        the next follows at once)."""
        return None if self.steps is None else self.period - self.longest

    def spans_two_periods(self):
        """A cruise step that runs into a second period: the auto-reloaded timer then loses one."""
        return self.steps is not None and self.longest > 2 * self.period - LATENCY

    def late_start(self, arb):
        """The most a cruise step starts after its timer overflow when a UART interrupt comes
        between it and the step before (None: the path never cruises long)."""
        return None if self.steps is None else max(0.0, self.longest - self.period) + arb.step_wait()

    def periods_lost_to_a_byte(self, arb):
        """Periods the auto-reloaded timer can lose to one UART interrupt: one for each period the
        delayed step starts past its overflow."""
        delay = self.late_start(arb)
        return None if delay is None else int(delay // self.period)

    def ok(self, window, arb):
        if self.share > SHARE_MAX or self.spans_two_periods():
            return False
        return self.steps is None or (arb.byte_wait(self.longest) <= window
                                      and self.periods_lost_to_a_byte(arb) <= 1)


CRUISING = ("line along X", "line along Y", "line, diagonal", "arc, counter-clockwise", "arc, clockwise",
            "arc ending off the axes")


def measure_all(base, arc_feed=ARC_TOP):
    jobs = paths(arc_feed)
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        shares = dict(zip(jobs, pool.map(lambda c: share_run(base, c), jobs.values())))
        steps = dict(zip(CRUISING, pool.map(lambda name: cruise_interrupts(base, jobs[name]), CRUISING)))
    return [PathFigures(name, command, feed_of(command), shares[name][0] / shares[name][1], steps.get(name))
            for name, command in jobs.items()]


# The images with core/stepper.c's interrupt (the option images, BAUD=115200) at their own caps:
# the same kinds of path, shorter, as their feeds are lower.
def c_isr_paths(line_feed, arc_feed):
    t, a = line_feed, arc_feed
    return {
        "line along X": f"L 6000 0 {t}",
        "line along Y": f"L 0 6000 {t}",
        "line, diagonal": f"L 4000 -4000 {t}",
        "arc, counter-clockwise": f"A 0 0 600 0 {a}",
        "arc, clockwise": f"C 0 0 0 1200 {a}",
        "arc ending off the axes": f"A -1024 424 -600 0 {a}",
        **load_paths(t, a),
    }


@dataclass
class CIsrFigures:
    """One path of an image with core/stepper.c's interrupt.  There the UART and the e-stop are
    above the step timer (IP, hal/mcs51/main.c) and interrupt it anywhere but in its 12-cycle
    timer reload, so a received byte waits for no step: what the step interrupt must leave is the
    main loop's time, and the timer's periods."""
    name: str
    command: str
    feed: int
    share: float
    longest: int        # cycles of the longest step interrupt over the middle half of the run
    run_cycles: int     # from the first step to the end
    typical: int = 0    # the median step interrupt over the middle half

    @property
    def period(self):
        return CYCLES_PER_S / self.feed

    @property
    def cruising(self):
        return self.name in CRUISING

    def ok(self):
        """The share on every path; on a cruising path no interrupt over two periods.  A segment
        load may run longer (about 490-540 cycles): HAL_TIMER_ADVANCE then fires the next step at
        once, so the step after a load comes late by the overrun, and the position stays exact."""
        return self.share <= SHARE_MAX and (not self.cruising or self.longest <= 2 * self.period - LATENCY)


def measure_c_isr(base, names=None):
    """Each path (all of c_isr_paths, or those named) at the image's own caps."""
    line, arc = image_caps(base)
    jobs = {k: v for k, v in c_isr_paths(line, arc).items() if names is None or k in names}
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        runs = dict(zip(jobs, pool.map(lambda c: share_run(base, c), jobs.values())))
    out = []
    for name, command in jobs.items():
        isr, total, each = runs[name]
        middle = each[len(each) // 4: 3 * len(each) // 4]
        out.append(CIsrFigures(name, command, feed_of(command), isr / total, max(middle), round(total / 12),
                               sorted(middle)[len(middle) // 2]))
    return out


def main_c_isr(base):
    line, arc = image_caps(base)
    figures = measure_c_isr(base)
    print(f"`tools/isr_share.py {base}`: core/stepper.c's step interrupt on Timer 0, below the UART and "
          f"the e-stop; its caps (core/ramp.h): lines {line}, arcs {arc} iterations/s")
    print()
    print("| path | feed | period cycles | step interrupt share | step interrupt cycles, middle half: median | "
          "longest |")
    print("|---|---|---|---|---|---|")
    for f in figures:
        print(f"| {f.name} | {f.feed} | {f.period:.1f} | {100 * f.share:.1f} % | {f.typical} | {f.longest}"
              f"{'' if f.ok() else ' (fails)'} |")
    ok = all(f.ok() for f in figures)
    print()
    print(f"criteria: share at most {100 * SHARE_MAX:.1f} % on every path, and no step interrupt in the "
          f"middle of a cruising run over two periods (a segment load's may be: the step after it comes "
          f"that much late): {'met' if ok else 'NOT met'}")
    return 0 if ok else 2


def main(argv):
    args = list(argv[1:])
    arc_feed = ARC_TOP
    if "--arc-feed" in args:
        k = args.index("--arc-feed")
        arc_feed = int(args[k + 1])
        del args[k:k + 2]
        if arc_feed > ARC_TOP:
            print(f"--arc-feed {arc_feed}: the image caps arcs at ARC_TOP, {ARC_TOP} steps/s (core/ramp.h); "
                  "build it with a higher ARC_TOP to measure a faster one", file=sys.stderr)
            return 1
    base = Path(args[0]) if args else s51sim.FIRMWARE / "build" / "plotter"
    if not s51sim.s51_path():
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 1
    if bench.isr_module(s51sim.Symbols(base)) == "stepper":
        return main_c_isr(base)
    arb = arbitration(s51sim.Symbols(base))
    window = 10 * CYCLES_PER_S / BAUD
    figures = measure_all(base, arc_feed)
    print(f"`make -C firmware share`: {base.name}, {CYCLES_PER_S} machine cycles/s, a byte every {window:.0f} "
          f"cycles at {BAUD} baud; longest paths from the listings: UART interrupt {arb.uart} cycles "
          f"({arb.rx_clear} to clearing RI), e-stop {arb.estop}, step interrupt {arb.step} (a segment load with "
          f"an arc's quadrant change)")
    print()
    print("| path | feed steps/s | period cycles | step interrupt share | longest cruise step cycles | "
          "shortest gap cycles | a byte's longest wait cycles | a step's latest start after a UART interrupt | "
          "periods a byte may cost |")
    print("|---|---|---|---|---|---|---|---|---|")
    for f in figures:
        wait = None if f.steps is None else arb.byte_wait(f.longest)
        cells = ["-" if v is None else f"{v:.0f}" for v in (f.longest, f.gap, wait, f.late_start(arb),
                                                            f.periods_lost_to_a_byte(arb))]
        print(f"| {f.name} | {f.feed} | {f.period:.1f} | {100 * f.share:.1f} % | {' | '.join(cells)}"
              f"{'' if f.ok(window, arb) else ' (fails)'} |")
    image_wait = arb.image_byte_wait()
    print()
    print(f"A received byte's longest wait on any path (the step interrupt's longest, {arb.step} cycles, under "
          f"way): {image_wait} cycles, of {window:.0f} in a byte time.  At the baud rates Timer 1 gives with "
          "SMOD, the longest wait while cruising and on any path, against the byte time:")
    print()
    print("| baud | byte time cycles | lines, cruising | arcs, cruising | any path |")
    print("|---|---|---|---|---|")
    for baud in BAUDS:
        w = 10 * CYCLES_PER_S / baud
        waits = [arb.byte_wait(max(f.longest for f in figures if f.steps is not None and kind in f.name))
                 for kind in ("line", "arc")] + [image_wait]
        cells = [f"{v}{'' if v <= w else ' (fails)'}" for v in waits]
        print(f"| {baud} | {w:.0f} | {' | '.join(cells)} |")
    ok = all(f.ok(window, arb) for f in figures) and image_wait <= window
    print()
    print(f"criteria: share at most {100 * SHARE_MAX:.1f} % on every path, no cruise step over two periods, "
          "a byte costs the cruising steps at most one period, and a received byte waits less than a byte "
          f"time on any path: {'met' if ok else 'NOT met'}")
    return 0 if ok else 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
