#!/usr/bin/env python3
"""What a command costs the main loop on the chip, and how many commands a
second the chip can take while it steps: the ceiling the link's speed does
not lift.

usage: tools/plan_cost.py [build/plotter]        (make plancost)

Each command is sent in machine form (sequence number and CRC, as the host
sends it) to the image in s51 under a feed hold, so no step interrupt runs
while it is measured, and timed with breakpoints:

- receive: protocol.c's receive_byte over the line's bytes (the CRC and the
  copy into the line buffer), byte by byte as they come in;
- parse: from execute_line's entry to the planner's (the checksum's and
  the sequence number's check, the number parser);
- plan: from the planner's entry to the reply (the feed's and the exit's
  periods and ramp levels, an arc's quadrants and square roots, the queue);
- reply: the reply's bytes into the transmit ring (`ok N<seq> Q<free>`
  with its CRC, every digit by repeated subtraction); apart, the wait for
  room in the 16-byte ring (hal_putc's rounds, counted by s51's fetch
  statistic), which the last bytes of a 17-byte reply spend while the
  first leave at the baud rate.

The main loop gets what the interrupts leave: the step interrupt's share
at the feed (isr_share.share_run, a line as commanded: ramps and cruise) and
the UART interrupt's, counted at its longest path for every byte in and out.
The ceiling is that remainder over a command's cycles.  A benchmark: it
prints its figures and asserts nothing.
"""
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import List

sys.path.insert(0, str(Path(__file__).resolve().parent))
import isr_share  # noqa: E402
import s51sim  # noqa: E402
from isr_share import BAUD, CYCLES_PER_S, arbitration  # noqa: E402

sys.path.insert(0, str(s51sim.FIRMWARE.parent / "ros_ws" / "src" / "plotter_bridge"))
from plotter_bridge.link.protocol import machine_line  # noqa: E402

# What the streamer sends for 1 mm chords at F6000 (80 steps/mm: 8000 steps/s), and the other kinds.
COMMANDS = (
    ("chord, feed and exit", "L 80 -3 8000 6500"),
    ("chord, feed, stop at its end", "L 79 5 8000"),
    ("line, long", "L 12000 -9000 8000 6500"),
    ("arc, feed and exit", "A 80 0 40 0 5000 4000"),
    ("pen down", "P 1"),
)
FEEDS = (2000, 4000, 6000, 8000, 12850)
CHORD_STEPS = 80          # a 1 mm chord at 80 steps/mm
SPIN_CYCLES = 5           # one round of hal_putc's wait for room in the ring (mov, clr, subb, jb)


@dataclass(frozen=True)
class Cost:
    name: str
    wire: bytes
    reply: bytes
    receive: int          # machine cycles
    parse: int
    plan: int
    answer: int
    wait: int             # of the reply's, spent waiting for room in the transmit ring

    @property
    def total(self) -> int:
        return self.receive + self.parse + self.plan + self.answer + self.wait


def _cycles(sim, start, stop, send=b""):
    """Machine cycles from the instruction at start to the one at stop, `send` written once it runs."""
    sim.cmd(f"break 0x{start:x}")
    sim.go()
    if send:
        sim.write(send)
    sim.wait_stop(timeout=60)
    t0 = sim.ticks()
    sim.cmd("delete")
    sim.run_to(stop, timeout=60)
    return (sim.ticks() - t0) // 12


def measure_commands(base) -> List[Cost]:
    out = []
    with s51sim.Sim(base) as sim:
        sim.read_until(rb"ready[^\n]*\n")
        sim.write(b"!!?")
        sim.read_until(rb"<Hold[^\n]*\n")
        sym = sim.sym
        receive = sym["_receive_byte"]
        after_receive = sym.instructions("protocol", "_protocol_poll", "lcall", "_receive_byte")[0] + 3
        execute = sym["_execute_line"]
        answer = sym["_reply"]
        after_execute = sym.instructions("protocol", "_receive_byte", "acall", "_execute_line")[0] + 2
        putc = sym["_hal_putc"]
        full, = sym.instructions("main", "_hal_putc", "jb", "acc.4,00101$")    # the ring-full test's branch
        planner = {"L": sym["_planner_line"], "A": sym["_planner_arc"], "C": sym["_planner_arc"],
                   "P": sym["_planner_pen"]}
        for seq, (name, command) in enumerate(COMMANDS):
            wire = machine_line(seq, command)
            rx = 0
            for b in wire[:-1]:
                rx += _cycles(sim, receive, after_receive, bytes([b]))
            parse = _cycles(sim, execute, planner[command[0]], wire[-1:])
            t0 = sim.ticks()
            sim.run_to(answer, timeout=60)
            plan = (sim.ticks() - t0) // 12
            t0 = sim.ticks()
            spins0 = sim.fetches(full, full).get(full, 0) - sim.fetches(putc, putc).get(putc, 0)
            sim.run_to(after_execute, timeout=60)
            reply_cycles = (sim.ticks() - t0) // 12
            spins = sim.fetches(full, full).get(full, 0) - sim.fetches(putc, putc).get(putc, 0) - spins0
            wait = SPIN_CYCLES * spins
            reply = sim.read_until(rb"\r\n")
            if not reply.startswith(b"ok"):
                raise RuntimeError(f"{wire!r}: {reply!r}")
            out.append(Cost(name, wire, reply, rx, parse, plan, reply_cycles - wait, wait))
    return out


def line_share(base, feed) -> float:
    isr, total, _ = isr_share.share_run(base, f"L {min(4 * feed, 30000)} 0 {feed}")
    return isr / total


def arc_share(base, feed=isr_share.ARC_TOP) -> float:
    """The step interrupt's share on a cruising arc at `feed` (isr_share's full circle)."""
    isr, total, _ = isr_share.share_run(base, isr_share.paths(arc_feed=feed)["arc, counter-clockwise"])
    return isr / total


@dataclass(frozen=True)
class Model:
    """The host's figures for the board's CPU (plotter_bridge.motion.planner.BoardCpu), measured."""
    command_cycles: int       # a chord: its main loop's cycles and its bytes' UART interrupts
    arc_command_cycles: int   # an arc, likewise
    step_cycles: float        # the step interrupt's cycles per step of a line at MODEL_FEED
    arc_step_cycles: float    # ... of a cruising arc at the arcs' top feed


MODEL_FEED = 8000             # 100 mm/s at 80 steps/mm


def model(base, costs=None) -> Model:
    costs = costs or measure_commands(base)
    uart = arbitration(s51sim.Symbols(base)).uart
    by_name = {c.name: c for c in costs}

    def cycles(name):
        c = by_name[name]
        return c.total + uart * (len(c.wire) + len(c.reply))
    return Model(cycles("chord, feed and exit"), cycles("arc, feed and exit"),
                 line_share(base, MODEL_FEED) * CYCLES_PER_S / MODEL_FEED,
                 arc_share(base) * CYCLES_PER_S / isr_share.ARC_TOP)


def main(argv):
    base = Path(argv[1]) if len(argv) > 1 else s51sim.FIRMWARE / "build" / "plotter"
    if not s51sim.s51_path():
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 1
    costs = measure_commands(base)
    uart = arbitration(s51sim.Symbols(base)).uart
    byte_time = 10 * CYCLES_PER_S / BAUD
    print(f"`make -C firmware plancost`: {base.name}, {CYCLES_PER_S} machine cycles/s, {BAUD} baud (a byte "
          f"every {byte_time:.0f} cycles); machine cycles of the main loop per command")
    print()
    print("| command | bytes on the wire | reply bytes | receive | parse | plan | reply | reply's wait for the "
          "ring | in all |")
    print("|---|---|---|---|---|---|---|---|---|")
    for c in costs:
        print(f"| {c.name}: `{c.wire.decode().strip()}` | {len(c.wire)} | {len(c.reply)} | {c.receive} | "
              f"{c.parse} | {c.plan} | {c.answer} | {c.wait} | {c.total} |")
    chord = costs[0]
    print()
    print(f"Chords like the first ({CHORD_STEPS} steps, a 1 mm chord at 80 steps/mm), back to back: the step "
          f"interrupt's share at each feed (a line as commanded) and its cycles a step, the UART interrupt's "
          f"at its longest path ({uart} cycles) for every byte in and out, the chords a second the main loop "
          f"can take in what the steps leave at that feed, and the pace the chords then keep: the feed, or "
          f"slower, where each chord's time holds its own steps' interrupts and the next chord's main-loop "
          f"work ({CHORD_STEPS} F / (C + c {CHORD_STEPS})); against what {BAUD} baud carries:")
    print()
    print("| feed steps/s | chords/s the feed asks for | step interrupt share | cycles a step | chords/s the main "
          f"loop takes at that feed | chords back to back, mm/s | chords/s {BAUD} baud carries |")
    print("|---|---|---|---|---|---|---|")
    link = BAUD / 10 / len(chord.wire)
    per_chord = chord.total + uart * (len(chord.wire) + len(chord.reply))
    for feed in FEEDS:
        share = line_share(base, feed)
        per_step = share * CYCLES_PER_S / feed
        at_feed = (1 - share) * CYCLES_PER_S / per_chord
        pace = min(feed, CHORD_STEPS * CYCLES_PER_S / (per_chord + per_step * CHORD_STEPS))
        print(f"| {feed} | {feed / CHORD_STEPS:.0f} | {100 * share:.1f} % | {per_step:.1f} | {at_feed:.0f} | "
              f"{pace / CHORD_STEPS:.1f} | {link:.0f} |")
    m = model(base, costs)
    print()
    print(f"The host's model of it (plotter_bridge.motion.planner.BoardCpu): a chord {m.command_cycles} cycles, "
          f"an arc {m.arc_command_cycles} (their main loop's and their bytes' UART interrupts); a line step "
          f"{m.step_cycles:.1f} cycles at {MODEL_FEED} steps/s, an arc step {m.arc_step_cycles:.1f} at "
          f"{isr_share.ARC_TOP} (a full circle)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
