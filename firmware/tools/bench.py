#!/usr/bin/env python3
"""Machine cycles per step of the 8051 image, measured in the s51 simulator.

usage: tools/bench.py [--clock HZ] [--late] build/plotter        (make bench)

--clock 22118400 (make bench CPU6T=1): s51's crystal for an image built for
the chip's 6-clock mode, which s51 does not model: at twice the crystal its
12-clock cycles last as long as the chip's 6-clock ones at 11.0592 MHz.

For a long line and for an arc the board is driven through its UART like a
host would (and for the arc again at 10000 steps/s, a feed it can keep), and s51 records a VCD trace of port 1 and of PSW.3 (the register
bank bit only the step interrupt sets, see tools/s51sim.py).  From the trace:

- cycles per step: the time between two step pulses;
- ISR cycles: the time PSW.3 is set, plus the interrupt's fixed entry and
  exit (the hardware call, the pushes before `mov psw` and the pops after
  `pop psw`, counted from the listing) - one interrupt computes one step;
- the ramp is run twice: as commanded (feed at the ramp's top rate, T in
  `$I`), and with the cruise period overwritten in RAM by one far below what
  the interrupt needs (a feed "above what the CPU can do"), so that the
  interrupt runs back to back: the period it can sustain, main loop included
  (the 8051 runs one main-loop instruction between two interrupts).

--late lists every step as commanded that came slower than the table: its
index, the table's interval and the measured one, in cycles.

Ends with the two lines `line: N steps/s` and `arc: N steps/s`, the
sustained rates in real seconds (11.0592 MHz crystal, 12 or 6 clocks a cycle).
"""
import collections
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


def measure(sim, command, saturate):
    """Run one command to its end with the VCD recording.  The command is
    queued under a feed hold and released with `~`, so that it can be
    changed in the queue before the motion starts (the simulator stops
    long after it is asked to)."""
    offs = segment_offsets(s51sim.FIRMWARE / "core" / "segment.h")
    sim.go()
    sim.write(b"!!?")
    sim.read_until(rb"<Hold[^\n]*\n")
    sim.write(command.encode() + b"\n")
    reply = sim.read_until(rb"(?:ok|err|rs)[^\r\n]*\r\n").decode().strip()
    if not reply.startswith("ok"):
        raise RuntimeError(f"{command!r}: {reply!r}")
    sim.stop()
    if saturate:
        # A cruise period far below what the interrupt needs: from the
        # cruise level on, it runs back to back.  In every queue slot
        # (7 of 22 bytes, core/planner.h): the command's is one of them.
        for slot in range(7):
            addr = sim.sym["_queue"] + 22 * slot + offs["cruise_period"]
            sim.cmd(f"set memory xram 0x{addr:x} 0xff 0xff")
    # The end of the motion: the interrupt finds the queue empty and stops.
    stop, = sim.sym.instructions(isr_module(sim.sym), "_stepper_isr", "clr", "_st_running")
    sim.cmd(f"tbreak 0x{stop:x}")
    sim.vcd_start()
    sim.go()
    sim.write(b"~~")
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
        core.receive(command.encode() + b"\n")
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
    if not s51sim.s51_path():
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 1
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        cases = [
            ("line", "L 30000 0 12850", True),
            ("arc", "A 0 0 1500 0 12850", True),
            ("arc at 10000", "A 0 0 1500 0 10000", False),
        ]
        for name, command, saturated_too in cases:
            for saturate in (False, True) if saturated_too else (False,):
                vcd = str(Path(tmp) / f"{name}{int(saturate)}.vcd")
                with s51sim.Sim(base, vcd=vcd, clock_hz=clock_hz) as sim:
                    overhead = isr_overhead(sim.sym)
                    sim.go()
                    sim.read_until(rb"ready[^\n]*\n")
                    sim.stop()
                    measure(sim, command, saturate)
                intervals, isr = analyse(vcd, overhead, clock_hz)
                results[(name, saturate)] = (intervals, isr)
                label = "saturated (cruise period overwritten)" if saturate else "as commanded"
                print(f"{name}: {command!r}, {label}")
                print(f"  steps recorded      {len(intervals) + 1}")
                print(f"  cycles per step     {summary(intervals)}")
                if isr:
                    print(f"  ISR cycles per step {summary(isr)}")
                    common = collections.Counter(isr).most_common(8)
                    print("  ISR cycles, most frequent: " + ", ".join(f"{c} ({n}x)" for c, n in common))
    print()
    library = base.parent / "libplotter_core.so"
    for name, command, _ in cases:
        # The ramp as its table says, at every rate up to the top one: each
        # step as commanded (accelerating, cruising at the top rate,
        # braking) no slower than the host core's schedule, beyond the
        # interrupt latency.
        got = results[(name, False)][0]
        want = host_schedule(library, command)
        slow = [(k, g - w) for k, (g, w) in enumerate(zip(got, want)) if g > w + 8]
        ramp = [k for k, w in enumerate(want) if w > min(want)]
        print(f"{name}: {len(slow)} of {len(want)} steps as commanded slower than the table "
              f"(by up to {max((d for _, d in slow), default=0)} cycles; "
              f"{len([k for k, _ in slow if k in set(ramp)])} of them on the ramps, "
              f"steps {len(got) + 1} vs {len(want) + 1} in the table)")
        if late:
            for k, _ in slow:
                print(f"  step {k}: table {want[k]}, measured {got[k]} cycles")
    print()
    print(f"s51 at {clock_hz} Hz, 12 clocks a cycle: {cycles_per_s} machine cycles/s")
    rates = {}
    for name in ("line", "arc"):
        intervals, isr = results[(name, True)]
        # Cruise: the middle half of the segment (each ramp takes well under
        # a tenth of it).  Steps there come as fast as the interrupt can go.
        n = len(intervals)
        cruise = intervals[n // 4:3 * n // 4]
        cruise_isr = isr[n // 4:3 * n // 4]
        per_step = statistics.mean(cruise)
        rates[name] = int(cycles_per_s / per_step)
        detail = (f" (ISR {min(cruise_isr)}..{max(cruise_isr)} cycles per step, "
                  f"{min(isr)}..{max(isr)} over the whole segment incl. ramps and segment load)") if isr else ""
        print(f"{name} at saturation, cruise: {per_step:.1f} machine cycles per step{detail}")
    for name in ("line", "arc"):
        print(f"{name}: {rates[name]} steps/s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
