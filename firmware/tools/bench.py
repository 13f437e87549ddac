#!/usr/bin/env python3
"""Machine cycles per step of the 8051 image, measured in the s51 simulator.

usage: tools/bench.py [--clock HZ] [--late] build/plotter        (make bench)

--clock 22118400 (make bench CPU6T=1): s51's crystal for an image built for
the chip's 6-clock mode, which s51 does not model: at twice the crystal its
12-clock cycles last as long as the chip's 6-clock ones at 11.0592 MHz.

Each command is queued through the board's UART like a host would, and s51
records a VCD trace of port 1 and of PSW.3 (the register bank bit only the
step interrupt sets, see tools/s51sim.py).  From the trace:

- cycles per step: the time between two step pulses;
- ISR cycles (the C interrupt of the option images): the time PSW.3 is set,
  plus the interrupt's fixed entry and exit (the hardware call, the pushes
  before `mov psw` and the pops after `pop psw`, counted from the listing).

Two kinds of run:

- as commanded (COMMANDED: a line and an arc at the ramp's top rate, T in
  `$I`, which the planner caps at ARC_TOP for the arc, the arc again at
  10000 steps/s, a circle too small to cruise, and the line with the
  other ramp shape and with a gentler acceleration): every step against
  the host core's schedule, the ramp table.  A step more than the interrupt latency
  slower than the table is late; the summary gives their count and the
  table interval of the slowest, below whose rate the table is kept, and
  the count of steps that come early (the auto-reloaded timer keeps the
  schedule's phase, so the steps after a late one catch up).
  --late lists each: its index, the table's interval and the measured one.
- saturated (SWEEP: lines in several directions, full circles of several
  radii both ways): the cruise period is overwritten in RAM by one far below
  what the interrupt needs (a feed "above what the CPU can do"), so that
  the interrupt runs back to back over the middle half, main loop included
  (the 8051 runs one main-loop instruction between two interrupts).

Ends with the two lines `line: N steps/s` and `arc: N steps/s`: the slowest
of each kind in the sweep, in real seconds (11.0592 MHz crystal, 12 or 6
clocks a cycle).
"""

import concurrent.futures
import os
import re
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import s51sim  # noqa: E402

STEP_BITS = 0x05                       # P1.0 X step, P1.2 Y step (core/config.h)


def segment_offsets(header):
    """Byte offsets of the fields of segment_t (core/segment.h)."""
    text = Path(header).read_text()
    body = re.search(r"typedef struct \{(.*?)\} segment_t;", text, re.S).group(1)
    sizes = {"uint8_t": 1, "int8_t": 1, "uint16_t": 2, "int16_t": 2}
    off, out = 0, {}
    for m in re.finditer(r"(u?int\d+_t)\s+([^;]+);", body):
        for name in m.group(2).split(","):
            out[name.strip()] = off
            off += sizes[m.group(1)]
    return out


def isr_module(sym):
    """The listing that holds the step interrupt: the hand-written one
    (hal/mcs51/stepper_isr.asm) in the board's image, core/stepper.c's in
    the others."""
    return "stepper_isr" if "stepper_isr" in sym.rst else "stepper"


def isr_overhead(sym):
    """Cycles of the step interrupt outside the PSW.3 window: the hardware
    LCALL (2), the LJMP at the vector for the hand-written one, the
    instructions up to and including `mov psw,#0x08`, and those after
    `pop psw` up to and including `reti`."""
    module = isr_module(sym)
    if module == "stepper_isr":
        return None
    lines = sym.rst[module]
    start = next(i for i, l in enumerate(lines) if re.match(r"\s+[0-9A-F]{6}\s+\d+\s+_stepper_isr:", l))
    code = []
    for line in lines[start + 1:]:
        m = re.match(r"\s+[0-9A-F]{6}\s+(?:[0-9A-F]{2}\s)+\s*\[(\d+)\]\s+\d+\s+(\w+)\s*([^;]*)", line)
        if m:
            code.append((int(m.group(1)) // 12, m.group(2), m.group(3).strip()))
            if m.group(2) == "reti":
                break
    entry = next(i for i, c in enumerate(code) if c[1] == "mov" and c[2].lower().startswith("psw,"))
    exit_ = max(i for i, c in enumerate(code) if c[1] == "pop" and c[2].lower() == "psw")
    vector = 2 if module == "stepper_isr" else 0
    return 2 + vector + sum(c[0] for c in code[:entry + 1]) + sum(c[0] for c in code[exit_ + 1:])


def lines_of(command):
    """A bench command is one line, or several separated by `;` (settings
    first: `$1=1; L 30000 0 12850`)."""
    return [line.strip() for line in command.split(";")]


def saturate_queue(sim, offs=None):
    """A cruise period far below what the interrupt needs, written into the
    queued segments of a stopped simulator: from the cruise level on, the
    interrupt runs back to back.  In every queue slot (7 of 22 bytes,
    core/planner.h): the command's is one of them."""
    offs = offs or segment_offsets(s51sim.FIRMWARE / "core" / "segment.h")
    for slot in range(7):
        addr = sim.sym["_queue"] + 22 * slot + offs["cruise_period"]
        sim.cmd(f"set memory xram 0x{addr:x} 0xff 0xff")


def measure(sim, command, saturate, before_run=None, stream=b""):
    """Run one command to its end with the VCD recording, from a stopped
    simulator.  The command is queued under a feed hold and released with
    `~`, so that it can be changed in the queue before the motion starts.
    before_run(sim): called with the simulator stopped, just before the run
    is released.  stream: bytes written to the
    board's UART right after the release, which s51 takes in at the baud
    rate while the run goes on, without s51's flow control: the stream
    outlasts the run."""
    offs = segment_offsets(s51sim.FIRMWARE / "core" / "segment.h")
    sim.write(b"!!?")
    sim.read_until(rb"<Hold[^\n]*\n")
    for line in lines_of(command):
        sim.write(line.encode() + b"\n")
        reply = sim.read_until(rb"(?:ok|err|rs)[^\r\n]*\r\n").decode().strip()
        if not reply.startswith("ok"):
            raise RuntimeError(f"{line!r}: {reply!r}")
    if saturate:
        saturate_queue(sim, offs)
    # The end of the motion: the interrupt finds the queue empty and stops.
    stop, = sim.sym.instructions(isr_module(sim.sym), "_stepper_isr", "clr", "_st_running")
    sim.cmd(f"tbreak 0x{stop:x}")
    if before_run is not None:
        before_run(sim)
    if stream:
        sim.flow_control(False)
    sim.vcd_start()
    sim.go()
    sim.write(b"~~" + stream)
    sim.wait_stop(timeout=300)
    sim.vcd_stop()


def analyse(vcd_path, overhead, clock_hz):
    ev = s51sim.read_vcd(vcd_path)
    pulses = []
    prev = 0xFF
    for t, v in ev["P1"]:
        if v & STEP_BITS and not prev & STEP_BITS:
            pulses.append(t)
        prev = v
    intervals = [s51sim.cycles(b - a, clock_hz) for a, b in zip(pulses, pulses[1:])]
    isr = []
    start = None
    for t, v in ev["PSW.3"] if overhead is not None else ():
        if v and start is None:
            start = t
        elif not v and start is not None:
            isr.append(s51sim.cycles(t - start, clock_hz) + overhead)
            start = None
    return [round(x) for x in intervals], [round(x) for x in isr]


def host_schedule(library, command):
    """The step intervals of the host build of the core for the command,
    queued under a feed hold as measure() queues it: the ramp table's
    schedule, what the board should keep to."""
    sys.path.insert(0, str(s51sim.FIRMWARE.parent / "ros_ws" / "src" / "plotter_bridge"))
    from plotter_bridge.sim.firmware_core import FirmwareCore
    core = FirmwareCore(library)
    try:
        core.receive(b"!!")
        core.poll(3)
        for line in lines_of(command):
            core.receive(line.encode() + b"\n")
            core.poll(5)
        core.receive(b"~~")
        out, since = [], 0
        x1, y1 = core.position
        while True:
            core.poll()
            if not core.timer_running():
                return out[1:]
            since += core.period()
            core.tick()
            x0, y0 = x1, y1
            x1, y1 = core.position
            if (x1, y1) != (x0, y0):
                out.append(since)
                since = 0
    finally:
        core.close()


def summary(values):
    return (f"min {min(values)}  median {statistics.median(values):g}  "
            f"mean {statistics.mean(values):.1f}  max {max(values)}  (n={len(values)})")


# Each step of these, as commanded, against the host core's schedule.
COMMANDED = [
    ("line", "L 30000 0 12850"),
    ("arc", "A 0 0 1500 0 12850"),
    ("arc at 10000", "A 0 0 1500 0 10000"),
    ("small arc", "A 0 0 0 -200 12850"),     # never cruises: on the ramp throughout
    ("line, exponential ramp", "$1=1; L 30000 0 12850"),
    ("line, acceleration divisor 10", "$0=10; L 30000 0 12850"),
]
# The sustained rates, saturated: the figure is the slowest of each kind.  A
# Y step costs two cycles more than an X one (the pulse tests X first), so
# the lines run along both axes, the diagonal and between; the arcs are full
# circles of several radii, both ways, from an axis and from between two, all
# long enough to cruise through their middle half (checked against the
# host's schedule).
SWEEP = {
    "line": ["L 30000 0 12850", "L 0 30000 12850", "L -30000 -30000 12850",
             "L 30000 -10000 12850", "L -10000 30000 12850", "L 3 -30000 12850"],
    "arc": ["A 0 0 1500 0 12850", "C 0 0 -1500 0 12850", "A 0 0 0 -600 12850",
            "C 0 0 0 3000 12850", "A 0 0 1000 1000 12850", "C 0 0 -700 700 12850"],
}


def run(base, clock_hz, command, saturate, stream=b""):
    """Step intervals and ISR cycles of one command in s51 (stream: see measure)."""
    with tempfile.TemporaryDirectory() as tmp:
        vcd = str(Path(tmp) / "trace.vcd")
        with s51sim.Sim(base, vcd=vcd, clock_hz=clock_hz) as sim:
            overhead = isr_overhead(sim.sym)
            sim.read_until(rb"ready[^\n]*\n")
            measure(sim, command, saturate, stream=stream)
        return analyse(vcd, overhead, clock_hz)


def cruise_of(library, command, n):
    """The middle half of a run of n intervals, checked to lie where the host
    core's schedule cruises (so that it measures cruise, not a ramp)."""
    want = host_schedule(library, command)
    middle = range(n // 4, 3 * n // 4)
    if len(want) != n or any(want[k] != min(want) for k in middle):
        raise RuntimeError(f"{command!r}: its middle half is not all at cruise")
    return middle


def main(argv):
    args = list(argv[1:])
    clock_hz = s51sim.CLOCK_HZ
    late = "--late" in args
    if late:
        args.remove("--late")
    if "--clock" in args:
        k = args.index("--clock")
        clock_hz = int(args[k + 1])
        del args[k:k + 2]
    cycles_per_s = clock_hz // 12
    base = Path(args[0]) if args else s51sim.FIRMWARE / "build" / "plotter"
    library = base.parent / "libplotter_core.so"
    if not s51sim.s51_path():
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 1
    jobs = [(command, False) for _, command in COMMANDED]
    jobs += [(command, True) for kind in SWEEP for command in SWEEP[kind]]
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        runs = dict(zip(jobs, pool.map(lambda job: run(base, clock_hz, *job), jobs)))

    for name, command in COMMANDED:
        # The ramp as its table says, at every rate up to the top one: each
        # step as commanded (accelerating, cruising at the top rate,
        # braking) no slower than the host core's schedule, beyond the
        # interrupt latency.
        got, isr = runs[(command, False)]
        want = host_schedule(library, command)
        print(f"{name}: {command!r}, as commanded")
        print(f"  cycles per step     {summary(got)}")
        if isr:
            print(f"  ISR cycles per step {summary(isr)}")
        slow = [(k, g - w) for k, (g, w) in enumerate(zip(got, want)) if g > w + 8]
        ramp = {k for k, w in enumerate(want) if w > min(want)}
        print(f"  {len(slow)} of {len(want)} steps slower than the table "
              f"(by up to {max((d for _, d in slow), default=0)} cycles; "
              f"{len([k for k, _ in slow if k in ramp])} of them on the ramps; "
              f"steps {len(got) + 1} vs {len(want) + 1} in the table)")
        # The timer reloads itself, so it keeps the schedule's phase: the
        # steps after a late one come early until it is caught up.
        early = [(k, w - g) for k, (g, w) in enumerate(zip(got, want)) if g < w - 8]
        print(f"  {len(early)} steps faster than the table "
              f"(by up to {max((d for _, d in early), default=0)} cycles), catching up after late ones")
        print(f"  the whole run took {sum(got)} cycles, the table {sum(want)} "
              f"({100 * (sum(got) - sum(want)) / sum(want):+.1f} %)")
        if slow:
            first = max(want[k] for k, _ in slow)
            print(f"  the slowest of them is due at a table interval of {first} cycles "
                  f"({cycles_per_s / first:.0f} steps/s): the table is kept below that rate")
        if late:
            for k, _ in slow:
                print(f"    step {k}: table {want[k]}, measured {got[k]} cycles")
    print()
    print(f"s51 at {clock_hz} Hz, 12 clocks a cycle: {cycles_per_s} machine cycles/s")
    print("saturated (cruise period overwritten): machine cycles per step over the middle half, at cruise")
    rates = {}
    for kind, commands in SWEEP.items():
        for command in commands:
            intervals, isr = runs[(command, True)]
            middle = cruise_of(library, command, len(intervals))
            per_step = statistics.mean(intervals[k] for k in middle)
            rate = int(cycles_per_s / per_step)
            rates[kind] = min(rates.get(kind, rate), rate)
            mid_isr = isr[middle.start:middle.stop]
            detail = f", ISR {min(mid_isr)}..{max(mid_isr)}" if mid_isr else ""
            print(f"  {kind} {command!r}: {per_step:.1f} cycles{detail} -> {rate} steps/s")
    for kind in SWEEP:
        print(f"{kind}: {rates[kind]} steps/s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
