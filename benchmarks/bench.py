#!/usr/bin/env python3
"""Benchmark of the plotter: drawing time against the time-optimal bound,
throughput of the serial link, position latency, the host nodes' load, and
the hanging plotter's accuracy over its work area.

Run through benchmarks/run (sets the project up first).  Two boards:

- mock: the node graph as processes (mock board, serial_bridge,
  gcode_streamer) in real time, measured from the mock board's step trace,
  the position topic and /proc;
- sim: the same firmware core and the host's BoardLink on a simulated clock
  (simboard.py), exact and fast, no ROS.

Both send the board's replies at the baud rate and hold the firmware's main
loop while its transmit ring is full, as the 8051 does.

The output ends with the line
`figures: time_ratio_max=R link_utilization_min=U underruns=N
hanging_deviation_max_mm=D hanging_lines_per_m=L` (one line).
"""
from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

from plotter_bridge.motion.commands import FIRMWARE_ACCEL
from plotter_bridge.motion.compiler import StreamerConfig
from plotter_bridge.link.protocol import machine_line

from bound import Limits, program_time
from hanging_sweep import HANGING_AREA, Drawn, by_group, draw_cases, hanging_config, sweep_cases
from hanging_sweep import summary as sweep_summary
from latency import report_ages
from programs import (Program, bound_items, compile_for, figure_programs, motion_count,
                      polygon_program, spiral_program, staircase_program)
from simrun import SimSession, StreamResult, mean_wire_bytes, sustained_rate

ROOT = Path(__file__).resolve().parent.parent
START_RATE = 250.0            # the ramp's level 0, steps/s (firmware/tools/gen_ramp.py R0)
TARGET_RATIO = 1.10
TARGET_LINK = 0.90
SLOW_FACTOR = 1.25            # "slow" link rows: each segment lasts this much longer than its line on the wire


def bound_limits(config: StreamerConfig = StreamerConfig()) -> Limits:
    """The board's own limits, in its rate space: its trapezoid ramp (at
    $0 = 1), the streamer's junction deviation, its start rate."""
    return Limits(float(FIRMWARE_ACCEL), config.junction_deviation * config.steps_per_mm, START_RATE)


# ------------------------------------------------------------------ results

@dataclass
class DrawRow:
    name: str
    segments: int
    bound: float
    stop_bound: float
    sim: Optional[StreamResult] = None
    sim_stop: Optional[StreamResult] = None
    sim_exp: Optional[StreamResult] = None
    mock: Optional[float] = None
    mock_exp: Optional[float] = None
    mock_underruns: int = 0
    mock_exp_underruns: int = 0
    mock_late: Optional[float] = None      # part of the run the mock board was behind real time
    mock_stalls: Optional[int] = None      # its loop passes 3 ms or more late


@dataclass
class LinkCase:
    label: str
    baud: int
    chord: float
    feed: float
    segments: int
    link_bound: bool          # segments shorter than their line takes on the wire
    link_cap: bool = True     # the streamer's link_baud (default: the bridge's): the planner slows commands to the link
    status_scaled: bool = True  # BoardLink holds status polls to a share of the link's bytes (it knows the baud)

    @property
    def variant(self) -> str:
        parts = ([] if self.link_cap else ["no planner link cap"]) + \
                ([] if self.status_scaled else ["status 25 Hz whatever the baud"])
        return ", ".join(parts) or "defaults"

    @property
    def default(self) -> bool:
        return self.link_cap and self.status_scaled


@dataclass
class LinkRow:
    case: LinkCase
    board: str                # "mock" or "sim"
    seg_per_s: Optional[float]
    limit: float              # segments/s the baud rate allows for these lines
    bytes_per_segment: float
    segment_ms: float         # how long one segment lasts on the board at its feed
    underruns: int
    reply_share: Optional[float] = None    # sim: reply bytes / command bytes
    late: Optional[float] = None           # mock: part of the run it was behind real time
    stalls: Optional[int] = None           # mock: loop passes 3 ms or more late

    @property
    def utilization(self) -> Optional[float]:
        return None if self.seg_per_s is None else self.seg_per_s / self.limit


@dataclass
class HostRow:
    label: str
    latency_recv: List[float] = field(default_factory=list)
    latency_stamp: List[float] = field(default_factory=list)
    unmatched: int = 0
    topic_hz: float = 0.0
    cpu: Dict[str, float] = field(default_factory=dict)
    rss_mb: Dict[str, float] = field(default_factory=dict)


# ------------------------------------------------------------------ helpers

def pct(values: Sequence[float], q: float) -> float:
    s = sorted(values)
    if not s:
        return math.nan
    k = min(len(s) - 1, max(0, math.ceil(q * len(s)) - 1))
    return s[k]


def fmt(v: Optional[float], spec: str = ".3f", none: str = "-") -> str:
    return none if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def percent(v: Optional[float]) -> str:
    return "-" if v is None else f"{100 * v:.0f}%"


def link_feed(baud: int, chord_mm: float, wire_bytes: float, factor: float) -> float:
    """Feed (mm/min) at which a chord lasts `factor` times its line's time on the wire."""
    return 60.0 * chord_mm / (factor * wire_bytes * 10.0 / baud)


def link_cases() -> List[LinkCase]:
    probe = polygon_program(20, 1.0, 1500.0)
    b1 = mean_wire_bytes([c.text for c in compile_for(probe, (0, 0)) if c.is_motion])
    probe = polygon_program(20, 0.1, 1500.0)
    b01 = mean_wire_bytes([c.text for c in compile_for(probe, (0, 0)) if c.is_motion])
    slow9600 = round(link_feed(9600, 1.0, b1, SLOW_FACTOR))
    return [
        LinkCase("9600, 1 mm, faster than the link", 9600, 1.0, 6000.0, 150, True),
        LinkCase(f"9600, 1 mm, {SLOW_FACTOR:g}x the line time", 9600, 1.0, slow9600, 150, False),
        LinkCase("115200, 1 mm at F6000", 115200, 1.0, 6000.0, 400, False),
        LinkCase("115200, 0.1 mm, faster than the link", 115200, 0.1, 6000.0, 1200, True),
        LinkCase(f"115200, 0.1 mm, {SLOW_FACTOR:g}x the line time", 115200, 0.1,
                 round(link_feed(115200, 0.1, b01, SLOW_FACTOR)), 1200, False),
    ]


def link_row(case: LinkCase, board: str, commands, seg_ends: Sequence[float], underruns: int,
             wire_bytes: Sequence[int], reply_share: Optional[float] = None) -> LinkRow:
    b = statistics.mean(b for b, c in zip(wire_bytes, commands) if c.is_motion)
    seg_ms = 1000.0 * 60.0 * case.chord / case.feed
    return LinkRow(case, board, sustained_rate(seg_ends), case.baud / 10.0 / b, b, seg_ms,
                   underruns, reply_share)


# ------------------------------------------------------------------ the simulator

def sim_drawings(programs: Sequence[Program], limits: Limits) -> List[DrawRow]:
    rows = []
    sessions = {"trap": SimSession(), "exp": SimSession(settings=("1=1",)), "stop": SimSession()}
    try:
        for prog in programs:
            pos = sessions["trap"].position
            cmds = compile_for(prog, pos)
            items = bound_items(cmds)
            row = DrawRow(prog.name, motion_count(cmds), program_time(items, limits),
                          program_time(items, limits, stop_every_move=True))
            row.sim = sessions["trap"].stream(cmds)
            row.sim_exp = sessions["exp"].stream(compile_for(prog, sessions["exp"].position))
            row.sim_stop = sessions["stop"].stream(compile_for(prog, sessions["stop"].position, lookahead=False))
            rows.append(row)
    finally:
        for s in sessions.values():
            s.close()
    return rows


def sim_link(case: LinkCase) -> LinkRow:
    session = SimSession(baud=case.baud, scale_status=case.status_scaled)
    try:
        prog = polygon_program(case.segments, case.chord, case.feed)
        config = StreamerConfig(link_baud=case.baud if case.link_cap else 0, link_seq=session.link.next_seq,
                                fit_arcs=False, board_cpu=False)     # the link's pace: SimBoard plans in no time
        cmds = compile_for(prog, session.position, config=config)
        r = session.stream(cmds)
    finally:
        session.close()
    ends = [r.load_times[k + 1] for k, c in enumerate(cmds) if c.is_motion and k + 1 < len(r.load_times)]
    return link_row(case, "sim", cmds, ends, r.underruns, r.wire_bytes,
                    r.bytes_from_board / max(1, r.bytes_to_board))


def sim_latency(baud: int) -> HostRow:
    """Status reports on the simulated board: how old the position they
    report is when BoardLink parses them, and how many arrive per second."""
    session = SimSession(baud=baud, record_steps=True)
    try:
        t0 = session.board.now
        session.stream(compile_for(polygon_program(300, 1.0, 1500.0), session.position))
        ages, unmatched = report_ages(session.board.stats.positions, session.statuses)
        n = sum(1 for t, _, _ in session.statuses if t >= t0)
        row = HostRow(f"sim, {baud} baud, 300 x 1 mm at F1500")
        row.latency_stamp, row.unmatched = ages, unmatched
        row.topic_hz = n / (session.board.now - t0)
        return row
    finally:
        session.close()


# ------------------------------------------------------------------ the mock board

def mock_runs(args, programs: Sequence[Program], cases: Sequence[LinkCase], limits: Limits,
              draw: Dict[str, DrawRow], log) -> Tuple[List[LinkRow], List[HostRow]]:
    from rosgraph import BenchGraph, position_latencies, segment_end_times
    links: List[LinkRow] = []
    hosts: List[HostRow] = []
    tmp = tempfile.TemporaryDirectory(prefix="plotter-bench-")   # step traces: tens of MB
    work = Path(tmp.name)

    def host_row(label: str, runs) -> HostRow:
        row = HostRow(label)
        msgs, secs = 0, 0.0
        for r in runs:
            rl, sl, un = position_latencies(r)
            row.latency_recv += rl
            row.latency_stamp += sl
            row.unmatched += un
            msgs += sum(1 for p in r.positions if r.t_sent <= p.recv <= r.t_done)
            secs += r.t_done - r.t_sent
        row.topic_hz = msgs / secs if secs else 0.0
        for name in ("serial_bridge", "gcode_streamer", "mock_board"):
            vals = [r.cpu[name] for r in runs if name in r.cpu]
            weights = [r.t_done - r.t_sent for r in runs if name in r.cpu]
            if vals:
                row.cpu[name] = sum(v * w for v, w in zip(vals, weights)) / sum(weights)
                row.rss_mb[name] = max(r.rss_mb[name] for r in runs if name in r.rss_mb)
        return row

    for baud in sorted({c.baud for c in cases} | {115200}, reverse=True):
        log(f"mock board at {baud} baud: starting the nodes")
        graph = BenchGraph(work / f"b{baud}", baud=baud)
        try:
            if baud == 115200:
                for prog in programs:
                    log(f"  drawing {prog.name}")
                    r = graph.run(prog)
                    if not r.ok:
                        raise RuntimeError(f"{prog.name}: {r.message}")
                    draw[prog.name].mock = r.board_time
                    draw[prog.name].mock_underruns = r.underruns
                    draw[prog.name].mock_late = r.late
                    draw[prog.name].mock_stalls = r.stalls
                    if prog.name.startswith("spiral"):
                        hosts.append(host_row(f"mock, 115200 baud, {prog.name}", [r]))
            runs = []
            for case in cases:
                if case.baud != baud:
                    continue
                log(f"  link: {case.label}")
                prog = polygon_program(case.segments, case.chord, case.feed)
                r = graph.run(prog)
                if not r.ok:
                    raise RuntimeError(f"{case.label}: {r.message}")
                runs.append(r)
                wire = [len(machine_line(r.first_seq + k, c.text)) for k, c in enumerate(r.commands)]
                links.append(link_row(case, "mock", r.commands, segment_end_times(r), r.underruns, wire))
                links[-1].late = r.late
                links[-1].stalls = r.stalls
            if baud != 115200 and runs:
                hosts.append(host_row(f"mock, {baud} baud, link rows", runs))
        finally:
            graph.close()
    if args.mock_exponential:
        log("mock board at 115200 baud with $1=1 (exponential ramp)")
        graph = BenchGraph(work / "exp", settings=("1=1",))
        try:
            for prog in programs:
                log(f"  drawing {prog.name}")
                r = graph.run(prog)
                draw[prog.name].mock_exp = r.board_time
                draw[prog.name].mock_exp_underruns = r.underruns
        finally:
            graph.close()
    tmp.cleanup()
    return links, hosts


def hanging_accuracy() -> List[Drawn]:
    """The hanging plotter's sweep over its default work area (hanging_sweep.py)."""
    return draw_cases(sweep_cases(), hanging_config())


def hanging_report(drawn: List[Drawn]) -> List[str]:
    config = hanging_config()
    g = config.hanging
    out = ["## 5. Hanging plotter (seed 003): accuracy over the work area", "",
           f"Circles and lines over a grid of places covering `--machine hanging`'s default work area "
           f"({HANGING_AREA.describe()}; pulleys at X{g.left[0]:g} Y{g.left[1]:g} and X{g.right[0]:g} "
           f"Y{g.right[1]:g}, {g.steps_per_mm:.2f} steps per mm of string), corners and edges included "
           f"(benchmarks/hanging_sweep.py), compiled as gcode_streamer compiles them (tolerance "
           f"{config.tolerance:g} mm) and stepped by the firmware core: deviation = the largest "
           f"distance of a step drawn with the pen down from the programmed path; board lines per "
           f"metre drawn, pen down.", ""]
    head = ["cases", "count", "drawn m", "board lines", "lines per m", "worst deviation mm", "at X, Y mm",
            "in"]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "|".join("---" for _ in head) + "|")
    groups = list(by_group(drawn).items()) + [("all", drawn)]
    for name, rows in groups:
        worst, where, per_metre = sweep_summary(rows)
        metres = sum(d.case.length for d in rows) / 1000.0
        out.append("| " + " | ".join([
            name, str(len(rows)), f"{metres:.1f}", str(sum(d.commands for d in rows)), f"{per_metre:.1f}",
            f"{worst:.4f}", f"{where.where[0]:.1f}, {where.where[1]:.1f}", where.case.name]) + " |")
    out.append("")
    return out


# ------------------------------------------------------------------ the table

def report(draw: List[DrawRow], links: List[LinkRow], hosts: List[HostRow], mock: bool,
           mock_exp: bool) -> Tuple[List[str], float, float, int]:
    out: List[str] = []
    w = out.append
    lim = bound_limits()
    w("## 1. Drawing time against the time-optimal bound")
    w("")
    w(f"Bound: computed in benchmarks/bound.py from the same commands (steps, per-command cruise "
      f"rates, directions): trapezoid at {lim.acceleration:g} steps/s^2 (the firmware's ramp, $0=1), "
      f"junction deviation {lim.junction_deviation:g} steps, start/stop at {lim.start_rate:g} steps/s, "
      f"pen delays 150 ms. Board time: first to last step. sim = simulated board at 115200 baud; "
      f"mock = the node graph on the mock board in real time. \"stop\" = every command ends at rest "
      f"(look-ahead off). \"fast exits\": commands the board left more than two ramp levels (400 "
      f"steps/s) faster than planned, and the worst ratio of board to planned exit rate (sim, $1=0). "
      f"\"mock late\": part of the run the mock board ran more than 5 ms behind real time (a "
      f"busy machine starves it; its figures then measure the machine); \"mock stalls\": passes of "
      f"its loop that ran 3 ms or more after they were due (its steps catch up, but its replies "
      f"went out and the host's lines came in that much late).")
    w("")
    head = ["program", "cmds", "bound s", "sim $1=0 s", "ratio"]
    if mock:
        head += ["mock $1=0 s", "ratio", "mock late", "mock stalls"]
    head += ["sim $1=1 s", "ratio"]
    if mock_exp:
        head += ["mock $1=1 s", "ratio"]
    head += ["stop bound s", "sim stop s", "stop/bound", "fast exits", "fast exits, stop"]
    w("| " + " | ".join(head) + " |")
    w("|" + "|".join("---" for _ in head) + "|")
    ratios: List[float] = []
    underruns = 0
    for r in draw:
        cells = [r.name, str(r.segments), f"{r.bound:.3f}", f"{r.sim.board_time:.3f}",
                 f"{r.sim.board_time / r.bound:.3f}"]
        ratios.append(r.sim.board_time / r.bound)
        underruns += r.sim.underruns
        if mock:
            cells += [fmt(r.mock), fmt(None if r.mock is None else r.mock / r.bound),
                      percent(r.mock_late), fmt(r.mock_stalls, "d")]
            if r.mock is not None:
                ratios.append(r.mock / r.bound)
            underruns += r.mock_underruns
        cells += [f"{r.sim_exp.board_time:.3f}", f"{r.sim_exp.board_time / r.bound:.3f}"]
        if mock_exp:
            cells += [fmt(r.mock_exp), fmt(None if r.mock_exp is None else r.mock_exp / r.bound)]
            underruns += r.mock_exp_underruns
        cells += [f"{r.stop_bound:.3f}", f"{r.sim_stop.board_time:.3f}",
                  f"{r.sim_stop.board_time / r.bound:.2f}",
                  f"{r.sim.exits_over}/{r.sim.exits_checked} (max {r.sim.exit_over_max:.1f}x)",
                  f"{r.sim_stop.exits_over}/{r.sim_stop.exits_checked} (max {r.sim_stop.exit_over_max:.1f}x)"]
        w("| " + " | ".join(cells) + " |")
    w("")
    w("Underruns while drawing (status U): sim $1=0 "
      f"{sum(r.sim.underruns for r in draw)}, sim $1=1 {sum(r.sim_exp.underruns for r in draw)}"
      + (f", mock $1=0 {sum(r.mock_underruns for r in draw)}" if mock else "")
      + (f", mock $1=1 {sum(r.mock_exp_underruns for r in draw)}" if mock_exp else "") + ".")
    w("")

    w("## 2. Serial link: 1 mm segments (and 0.1 mm to outrun 115200 baud)")
    w("")
    w("Chords of a circle (r = 80 mm), every command the same length. Link limit = baud / 10 / "
      "(bytes per command on the wire: `N<seq>L<dx> <dy> <feed> <exit>*<sum>\\n`, a zero exit left "
      "out). Segments/s: middle half of the run, from when each command's last step was taken; "
      "segment ms: at the programmed feed. \"link-bound\" rows: at that feed each segment is "
      "shorter than its line's time on the wire; by default gcode_streamer's planner slows such "
      "commands to the link's pace (planner.cap_for_link: 97 % of its bytes), with \"no planner "
      "link cap\" the board runs dry and brakes to a stop at the end of each (underruns expected); "
      "the utilisation is the measure. The other rows: segments last longer than the link needs to "
      "deliver them, so the board should never run dry (target: 0 underruns). \"status 25 Hz "
      "whatever the baud\": BoardLink not told the baud, so its status polls are not held to a "
      "share of the link. Both boards send their replies at the baud rate through the 16-byte "
      "transmit ring (reply/cmd bytes: what the simulated board sent per byte received).")
    w("")
    head = ["case", "board", "configuration", "segment ms", "bytes/cmd", "link limit seg/s", "seg/s",
            "utilisation", "underruns", "reply/cmd bytes", "mock late", "mock stalls"]
    w("| " + " | ".join(head) + " |")
    w("|" + "|".join("---" for _ in head) + "|")
    util_min = math.inf
    for r in links:
        u = r.utilization
        kind = "link-bound" if r.case.link_bound else "board-bound"
        w("| " + " | ".join([
            f"{r.case.label} ({kind})", r.board, r.case.variant, f"{r.segment_ms:.1f}",
            f"{r.bytes_per_segment:.1f}", f"{r.limit:.1f}", fmt(r.seg_per_s, ".1f"), fmt(u, ".3f"),
            str(r.underruns), fmt(r.reply_share, ".2f"),
            percent(r.late), fmt(r.stalls, "d")]) + " |")
        if r.case.default and r.case.link_bound and u is not None:
            util_min = min(util_min, u)
        if r.case.default and not r.case.link_bound:
            underruns += r.underruns
    w("")

    if hosts:
        w("## 3. Position latency and topic rate")
        w("")
        w("Per /plotter/position message received while the pen moved: receive time in a "
          "subscriber process minus the time of the step that brought the pen to the reported "
          "position (from the step trace); \"step->bridge\": the message's header stamp (when "
          "serial_bridge parsed the status report) minus the same step time. sim rows: the "
          "same up to BoardLink parsing the report (no ROS). Both boards send the report at the "
          "baud rate: 4.3 ms at 115200, 52 ms at 9600. Hz: status reports per second.")
        w("")
        head = ["run", "messages", "step->subscriber median ms", "p99 ms", "step->bridge median ms",
                "p99 ms", "topic Hz"]
        w("| " + " | ".join(head) + " |")
        w("|" + "|".join("---" for _ in head) + "|")
        for h in hosts:
            w("| " + " | ".join([
                h.label, str(max(len(h.latency_recv), len(h.latency_stamp))),
                fmt(1000 * statistics.median(h.latency_recv) if h.latency_recv else None, ".1f"),
                fmt(1000 * pct(h.latency_recv, 0.99), ".1f"),
                fmt(1000 * statistics.median(h.latency_stamp) if h.latency_stamp else None, ".1f"),
                fmt(1000 * pct(h.latency_stamp, 0.99), ".1f"), f"{h.topic_hz:.1f}"]) + " |")
        w("")
    if any(h.cpu for h in hosts):
        w("## 4. Host nodes while streaming (mock board)")
        w("")
        w("CPU: user + system time over the run, in % of one core; RSS: largest resident set "
          "seen (sampled from /proc every 0.2 s). The mock board is the simulated board, not a "
          "host node; shown for scale.")
        w("")
        head = ["run", "serial_bridge CPU %", "RSS MB", "gcode_streamer CPU %", "RSS MB",
                "mock_board CPU %", "RSS MB"]
        w("| " + " | ".join(head) + " |")
        w("|" + "|".join("---" for _ in head) + "|")
        for h in hosts:
            if not h.cpu:
                continue
            cells = [h.label]
            for name in ("serial_bridge", "gcode_streamer", "mock_board"):
                cells += [fmt(h.cpu.get(name), ".1f"), fmt(h.rss_mb.get(name), ".0f")]
            w("| " + " | ".join(cells) + " |")
        w("")
    return out, max(ratios), util_min, underruns


NOTES_MARK = "<!-- notes: kept when the results above are recorded again -->"


def record(path: Path, table: str, summary: str, seconds: float, load: float) -> None:
    """Write the table and the command that made it; keep hand-written notes
    below NOTES_MARK."""
    cmd = " ".join(["benchmarks/run", *sys.argv[1:]])
    notes = ""
    if path.exists():
        old = path.read_text()
        if NOTES_MARK in old:
            notes = old[old.index(NOTES_MARK):]
    header = [
        "# Benchmark results",
        "",
        f"Produced by `{cmd}` on {datetime.date.today().isoformat()}: {platform.machine()}, "
        f"{os.cpu_count()} CPUs, load average {load:.1f} at the start, Python "
        f"{platform.python_version()}; {seconds:.0f} s.",
        "",
        "```",
        summary,
        "```",
        "",
    ]
    path.write_text("\n".join(header) + table + "\n" + (notes or NOTES_MARK + "\n"))


def main() -> int:
    ap = argparse.ArgumentParser(description="plotter benchmark (issue 5)")
    ap.add_argument("--sim-only", action="store_true", help="skip the mock board (no ROS, a few seconds)")
    ap.add_argument("--mock-exponential", action="store_true",
                    help="also draw with $1=1 (exponential ramp) on the mock board (a minute and a half more)")
    ap.add_argument("--record", metavar="FILE.md", help="also write the table and the command to this file")
    args = ap.parse_args()
    t_start = time.monotonic()
    load_before = os.getloadavg()[0]

    def log(msg: str) -> None:
        print(f"[bench {time.monotonic() - t_start:5.1f}s] {msg}", file=sys.stderr, flush=True)

    limits = bound_limits()
    programs = figure_programs() + [spiral_program(), staircase_program()]
    log("simulated board: figures and spiral ($1=0, $1=1, stop at every command)")
    draw = sim_drawings(programs, limits)
    cases = link_cases()
    fast = [c for c in cases if c.link_bound]
    sim_cases = cases + [replace(c, link_cap=False) for c in fast] + \
        [replace(c, status_scaled=False) for c in cases if c.baud == 9600]
    log("simulated board: link rows")
    links = [sim_link(c) for c in sim_cases]
    log("simulated board: status report latency")
    hosts: List[HostRow] = [sim_latency(115200), sim_latency(9600)]
    if not args.sim_only:
        by_name = {r.name: r for r in draw}
        mock_links, mock_hosts = mock_runs(args, programs, cases, limits, by_name, log)
        hosts = mock_hosts + hosts
        links = links + mock_links
    order = {c.label: k for k, c in enumerate(cases)}
    links.sort(key=lambda r: (-r.case.baud, order[r.case.label], not r.case.default, r.board))
    log("hanging plotter: accuracy over the work area")
    hanging = hanging_accuracy()
    lines, ratio_max, util_min, underruns = report(draw, links, hosts, not args.sim_only,
                                                   args.mock_exponential and not args.sim_only)
    lines += hanging_report(hanging)
    deviation, _, per_metre = sweep_summary(hanging)
    figures = (f"figures: time_ratio_max={ratio_max:.3f} link_utilization_min={util_min:.3f} "
               f"underruns={underruns} hanging_deviation_max_mm={deviation:.4f} "
               f"hanging_lines_per_m={per_metre:.1f}")
    text = "\n".join(lines)
    if args.record:
        record(Path(args.record), text, figures, time.monotonic() - t_start, load_before)
        log(f"recorded in {args.record}")
    print(text)
    print(figures, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
