#!/usr/bin/env python3
"""The interpolation methods side by side, measured in the s51 simulator.

usage: tools/compare_interp.py        (make compare)

Builds the 8051 image of each interpolation option (make INTERP=...):
point-by-point comparison (the default), the digital differential analyser
and comparison-integration, and drives each through its simulated UART with
a line `L 3000 1700` and a full circle of radius 1000 (`A 0 0 1000 0`),
recording port 1 and PSW.3 (set only inside the step interrupt) as a VCD
trace, twice:

- paced: at a feed of 2000 iterations/s, where the timer sets every
  interrupt's moment: the path rebuilt from the pulses and its largest
  distance from the ideal line or circle; how evenly each axis steps (the
  largest gap between two pulses on one axis against their mean, on the
  line over the cruise, on the circle against the mean of the 8 gaps
  around it where that axis moves at least half its top speed), and the
  largest gap between pulses of either axis in interrupt periods (an
  iteration that steps neither axis);
- saturated: the cruise period overwritten in the queue by one far below
  what the CPU can do (each image caps a feed where its interrupt keeps
  up), so that the interrupts run back to back at cruise: the interrupt's
  own cycles per
  iteration (PSW.3 plus its fixed entry and exit, as tools/bench.py counts
  them), the cycles from one interrupt to the next, and the speed along the
  path in steps/s (the ideal path's length covered per second over the
  middle half of the move).

An iteration is one step interrupt; point-by-point comparison moves one
axis in each, the other two may move both or (the DDA) neither.
"""
import math
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402
import s51sim  # noqa: E402

METHODS = [("pbp", "point-by-point comparison"), ("dda", "DDA"), ("compare", "comparison-integration")]
LINE = (3000, 1700)
RADIUS = 1000
PACED_FEED = 2000                     # under every image's caps (core/ramp.h)
TOP_FEED = 12850                      # the ramp's top rate ($I field T), then saturated
CYCLES_PER_S = 921600
X_STEP, X_DIR, Y_STEP, Y_DIR = 0x01, 0x02, 0x04, 0x08
REPLY = rb"(?:ok|err|rs)[^\r\n]*\r\n"


def image(method):
    opts = [] if method == "pbp" else [f"INTERP={method}"]
    base = s51sim.FIRMWARE / "build" / ("" if method == "pbp" else method) / "plotter"
    subprocess.run(["make", "-s", "-C", str(s51sim.FIRMWARE), *opts,
                    str(base.with_suffix(".ihx").relative_to(s51sim.FIRMWARE))], check=True)
    return base


def run(base, command, end, vcd, saturate=False):
    """Run one command to its end (the step interrupt finding the queue
    empty) with the VCD recording on; saturated: with its cruise period
    overwritten in the queue by one far shorter than the interrupt
    (tools/bench.py), as each image caps a feed where its interrupt
    keeps up."""
    with s51sim.Sim(base, vcd=vcd, timeout=60) as sim:
        overhead = bench.isr_overhead(sim.sym)
        sim.read_until(rb"ready[^\n]*\n")
        if saturate:
            bench.measure(sim, command, True)
        else:
            stop, = sim.sym.instructions(bench.isr_module(sim.sym), "_stepper_isr", "clr", "_st_running")
            sim.cmd(f"tbreak 0x{stop:x}")
            sim.vcd_start()
            sim.go()
            sim.write(command.encode() + b"\n")
            reply = sim.read_until(REPLY).decode().strip()
            if not reply.startswith("ok"):
                raise RuntimeError(f"{command!r}: {reply!r}")
            sim.wait_stop(600)
            sim.vcd_stop()
        pos = (sim.int32("_pos_x"), sim.int32("_pos_y"))
        stack = sim.max_sp() - stack_start(base) + 1
    assert pos == end, (command, pos, end)
    assert stack <= 40, f"{base}: the stack took {stack} bytes, over the 40 tools/size.py keeps"
    return overhead


def stack_start(base):
    """The first byte of the stack, from the linker's memory summary."""
    text = Path(base).with_suffix(".mem").read_text()
    return int(re.search(r"Stack starts at: 0x([0-9a-fA-F]+)", text).group(1), 16)


def decode(vcd, overhead):
    """Steps (time in cycles, dx, dy) from the port 1 trace, and per
    interrupt (start in cycles, own cycles)."""
    ev = s51sim.read_vcd(vcd)
    steps, prev = [], None
    for t, v in ev["P1"]:
        if prev is not None:
            rising = v & ~prev & (X_STEP | Y_STEP)
            if rising:
                dx = ((-1 if v & X_DIR else 1) if rising & X_STEP else 0)
                dy = ((-1 if v & Y_DIR else 1) if rising & Y_STEP else 0)
                steps.append((s51sim.cycles(t), dx, dy))
        prev = v
    if overhead is None:
        # The hand-written interrupt (the board's image) keeps no register bank of its own to
        # trace: one axis step per iteration, each interrupt the time to the next pulse less the
        # main-loop instruction between (saturated, they run back to back; paced, only the count
        # is used).
        times = [t for t, _, _ in steps]
        gaps = [b - a - 1 for a, b in zip(times, times[1:])]
        return steps, list(zip(times, gaps + gaps[-1:]))
    isr, start = [], None
    for t, v in ev["PSW.3"]:
        if v and start is None:
            start = t
        elif not v and start is not None:
            isr.append((s51sim.cycles(start), s51sim.cycles(t - start) + overhead))
            start = None
    return steps, isr


def path(steps, start=(0, 0)):
    x, y = start
    out = []
    for t, dx, dy in steps:
        x, y = x + dx, y + dy
        out.append((t, x, y))
    return out


def line_deviation(pts):
    dx, dy = LINE
    length = math.hypot(dx, dy)
    return max(abs(x * dy - y * dx) / length for t, x, y in pts)


def circle_deviation(pts):
    return max(abs(math.hypot(x, y) - RADIUS) for t, x, y in pts)


def axis_times(steps, axis):
    return [t for t, dx, dy in steps if (dx if axis == 0 else dy)]


def line_smoothness(steps):
    """Per axis: the largest gap between its pulses over the mean, middle half."""
    n = len(steps)
    mid = steps[n // 4:3 * n // 4]
    out = []
    for axis in (0, 1):
        t = axis_times(mid, axis)
        gaps = [b - a for a, b in zip(t, t[1:])]
        out.append(max(gaps) / statistics.mean(gaps))
    return max(out)


def circle_smoothness(steps):
    """Per axis, where it moves at least half its top speed (the other
    coordinate at least R/2 from the centre): the largest gap between two of
    its pulses against the mean of the 8 gaps around it."""
    pts = path(steps, (-RADIUS, 0))
    worst = 0.0
    for axis in (0, 1):
        ts = [(p[0], abs(p[2] if axis == 0 else p[1])) for p, s in zip(pts, steps) if s[1 + axis]]
        for k in range(5, len(ts) - 5):
            if ts[k][1] < RADIUS / 2:
                continue
            gap = ts[k][0] - ts[k - 1][0]
            around = [ts[j + 1][0] - ts[j][0] for j in range(k - 5, k + 4) if j != k - 1]
            worst = max(worst, gap / statistics.mean(around))
    return worst


def gap_in_periods(steps, period):
    """The largest gap between pulses of either axis, in interrupt periods, middle half."""
    n = len(steps)
    t = [s[0] for s in steps[n // 4:3 * n // 4]]
    return max(b - a for a, b in zip(t, t[1:])) / period


def saturated(steps, isr, progress):
    """ISR cycles per iteration and cycles between interrupts (middle half of
    the interrupts), and the speed along the ideal path (middle half of the
    steps), steps/s."""
    n = len(isr)
    mid = isr[n // 4:3 * n // 4]
    own = statistics.mean(c for t, c in mid)
    between = statistics.mean(b[0] - a[0] for a, b in zip(mid, mid[1:]))
    pts = path(steps, progress["start"])
    m = len(pts)
    (t1, x1, y1), (t2, x2, y2) = pts[m // 4], pts[3 * m // 4]
    speed = (progress["along"](x2, y2) - progress["along"](x1, y1)) / ((t2 - t1) / CYCLES_PER_S)
    return own, between, speed


def main(argv):
    if not s51sim.s51_path():
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 1
    shapes = {
        "line": dict(cmd="L {} {} {{}}".format(*LINE), end=LINE, start=(0, 0),
                     along=lambda x, y: (x * LINE[0] + y * LINE[1]) / math.hypot(*LINE)),
        # counter-clockwise from (-R, 0) about the centre: the angle turned
        "circle": dict(cmd=f"A 0 0 {RADIUS} 0 {{}}", end=(0, 0), start=(-RADIUS, 0),
                       along=lambda x, y: RADIUS * ((math.atan2(y, x) - math.pi) % (2 * math.pi))),
    }
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for method, title in METHODS:
            base = image(method)
            for shape, spec in shapes.items():
                res = {}
                vcd = str(Path(tmp) / f"{method}-{shape}-paced.vcd")
                overhead = run(base, spec["cmd"].format(PACED_FEED), spec["end"], vcd)
                steps, isr = decode(vcd, overhead)
                # the interrupts that computed a step: the first loads the
                # segment, the trace ends inside the one that stops
                res["iterations"] = len(isr)
                res["diagonal"] = 100.0 * sum(1 for t, dx, dy in steps if dx and dy) / len(isr)
                axis_steps = sum(abs(dx) + abs(dy) for t, dx, dy in steps)
                if shape == "line":
                    res["deviation"] = line_deviation(path(steps))
                    res["smooth"] = line_smoothness(steps)
                else:
                    pts = path(steps, (-RADIUS, 0))
                    res["deviation"] = circle_deviation(pts)
                    res["smooth"] = circle_smoothness(steps)
                res["gap"] = gap_in_periods(steps, CYCLES_PER_S / PACED_FEED)
                vcd = str(Path(tmp) / f"{method}-{shape}-top.vcd")
                overhead = run(base, spec["cmd"].format(TOP_FEED), spec["end"], vcd, saturate=True)
                steps, isr = decode(vcd, overhead)
                res["isr"], res["between"], res["speed"] = saturated(steps, isr, spec)
                res["per_step"] = res["between"] * res["iterations"] / axis_steps
                res["time_ms"] = (steps[-1][0] - steps[0][0]) / CYCLES_PER_S * 1000
                results[(method, shape)] = res
                print(f"{title}, {shape}: " + ", ".join(
                    f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}" for k, v in res.items()),
                    flush=True)
    print()
    print(table(results))
    return 0


def table(results):
    rows = [
        ("iterations (step interrupts) for the move", "iterations", "{:d}"),
        ("of them moving both axes, %", "diagonal", "{:.0f}"),
        ("step interrupt, machine cycles per iteration at cruise", "isr", "{:.0f}"),
        ("saturated: machine cycles per axis step", "per_step", "{:.0f}"),
        ("saturated: speed along the path, steps/s", "speed", "{:.0f}"),
        ("saturated: the whole move with its ramps, ms", "time_ms", "{:.0f}"),
        ("largest distance from the ideal path, steps", "deviation", "{:.2f}"),
        ("largest gap between two pulses of an axis / their mean", "smooth", "{:.2f}"),
        ("largest gap between pulses of either axis, iterations", "gap", "{:.0f}"),
    ]
    out = []
    for shape, what in (("line", "`L {} {}`".format(*LINE)),
                        ("circle", f"full circle, radius {RADIUS} (`A 0 0 {RADIUS} 0`)")):
        out.append(f"| {what} | " + " | ".join(title for m, title in METHODS) + " |")
        out.append("|---" * (1 + len(METHODS)) + "|")
        for label, key, fmt in rows:
            cells = [fmt.format(results[(m, shape)][key]) for m, _ in METHODS]
            out.append(f"| {label} | " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
