"""The compiler as a stream: each stage (arc fitting, the link cap, the planner) holds only the
window that decides what it gives next, and gives exactly what it would give holding the whole
program.  Each is checked against the plain whole-program form of its rule, written out here, on
random chains longer than its window; and compile_texts against compile_job on whole programs."""
from __future__ import annotations

import math
import random
import sys
from pathlib import Path
from typing import Iterable, Iterator, List

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)

from plotter_bridge.gcode.arcfit import FitConfig, _fit_chain, iter_fit_arcs  # noqa: E402
from plotter_bridge.gcode.types import GCodeError, Move  # noqa: E402
from plotter_bridge.gcode.limits import WorkArea  # noqa: E402
from plotter_bridge.motion.commands import BoardCommand, MIN_RATE  # noqa: E402
from plotter_bridge.motion.compiler import StreamerConfig, compile_job, compile_stream, compile_texts  # noqa: E402
from plotter_bridge.motion.planner import (BOARD_QUEUE, PlannerLimits, iter_cap_for_link, iter_plan,  # noqa: E402
                                           junction_rate, wire_bytes)

LIMITS = PlannerLimits(acceleration=80000.0, junction_deviation=4.0)


class Counted:
    """An iterator that counts what was taken from it."""

    def __init__(self, items: Iterable) -> None:
        self._it, self.taken = iter(items), 0

    def __iter__(self) -> Iterator:
        return self

    def __next__(self):
        item = next(self._it)
        self.taken += 1
        return item


def _line(dx: int, dy: int, rate: int) -> BoardCommand:
    r = math.hypot(dx, dy)
    u = (dx / r, dy / r)
    return BoardCommand("L", (dx, dy), 1, abs(dx) + abs(dy), rate, dir_in=u, dir_out=u)


def _walk(rng: random.Random, n: int, short: bool = False) -> List[BoardCommand]:
    """Commands of a random walk: mostly gentle turns, some sharp, now and then a pen command."""
    out, heading = [], 0.0
    for _ in range(n):
        if rng.random() < 0.002:
            out.append(BoardCommand("P", (rng.randint(0, 1),), 1))
            continue
        heading += rng.gauss(0.0, 0.15) if rng.random() < 0.9 else rng.uniform(-3.0, 3.0)
        length = rng.uniform(2, 12) if short else rng.uniform(20, 400)
        dx, dy = round(length * math.cos(heading)), round(length * math.sin(heading))
        if dx == 0 and dy == 0:
            dx = 1
        out.append(_line(dx, dy, rng.choice((800, 3000, 8000, 12000))))
    return out


def _copy(cmds: List[BoardCommand]) -> List[BoardCommand]:
    return [BoardCommand(c.verb, c.args, c.line, c.steps, c.rate, c.exit_rate, c.dir_in, c.dir_out, c.note)
            for c in cmds]


def whole_plan(commands: List[BoardCommand], limits: PlannerLimits) -> List[int]:
    """The planner's rule over whole chains (backward, then forward): the exits."""
    a2 = 2.0 * limits.acceleration
    out: List[int] = []
    chain: List[BoardCommand] = []

    def flush() -> None:
        n = len(chain)
        exits = [0] * n
        for i in range(n - 2, -1, -1):
            nxt = chain[i + 1]
            exits[i] = int(min(junction_rate(chain[i], nxt, limits), chain[i].rate, nxt.rate,
                               math.sqrt(exits[i + 1] ** 2 + a2 * nxt.steps)))
        entry = 0
        for i, cmd in enumerate(chain):
            e = min(exits[i], int(math.sqrt(entry ** 2 + a2 * cmd.steps)))
            entry = e if e >= MIN_RATE else 0
            out.append(entry)
        chain.clear()

    for cmd in commands:
        if cmd.is_motion:
            chain.append(cmd)
        else:
            flush()
            out.append(0)
    flush()
    return out


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("short", [False, True])
def test_the_planner_as_a_stream_gives_the_whole_chains_exits(seed, short):
    cmds = _walk(random.Random(seed), 3000, short)
    expected = whole_plan(cmds, LIMITS)
    got = [c.exit_rate if c.is_motion else 0 for c in iter_plan(_copy(cmds), LIMITS)]
    assert got == expected


def test_the_planner_holds_a_window_not_the_chain():
    """A straight line of 100k one-step commands (one chain): the planner is never more than a few
    hundred commands ahead of what it has given."""
    cmds = (_line(1, 0, 4000) for _ in range(100_000))
    source = Counted(cmds)
    ahead = 0
    for given, _ in enumerate(iter_plan(source, LIMITS), start=1):
        ahead = max(ahead, source.taken - given)
    assert given == 100_000 and ahead < 600, ahead


def test_a_chain_braking_past_the_horizon_is_never_faster_than_the_whole_plan():
    # a long slow crawl into a stop: every exit is bound by the braking for what follows
    cmds = [_line(10, 0, 12000) for _ in range(4000)]
    slow = PlannerLimits(acceleration=2000.0, junction_deviation=4.0)
    expected = whole_plan(cmds, slow)
    got = [c.exit_rate for c in iter_plan(_copy(cmds), slow, horizon=500)]
    assert all(g <= e for g, e in zip(got, expected)) and got[-1] == 0
    assert got != expected          # the horizon did cut in here


def whole_cap(commands: List[BoardCommand], bytes_per_s: float, share: float, window: int,
              first_seq: int) -> List[int]:
    """The link cap's rule over whole runs of short commands: the rates."""
    rates = [c.rate for c in commands]
    run: List[int] = []

    def need(k: int, rate: int) -> float:
        return wire_bytes(commands[k], rate, first_seq + k) / (bytes_per_s * share)

    def flush() -> None:
        rs = [commands[k].rate for k in run]
        for _ in range(2):
            seconds = [need(k, r) for k, r in zip(run, rs)]
            caps = []
            for p in range(len(run)):
                a = max(0, p - window + 1)
                caps.append(sum(commands[k].steps for k in run[a:p + 1]) / sum(seconds[a:p + 1]))
            rs = [max(MIN_RATE, min(commands[k].rate, int(cap))) for k, cap in zip(run, caps)]
        for k, r in zip(run, rs):
            rates[k] = r
        run.clear()

    for k, cmd in enumerate(commands):
        if cmd.is_motion and cmd.steps > 0 and cmd.steps / cmd.rate < need(k, 0):
            run.append(k)
        else:
            flush()
    flush()
    return rates


@pytest.mark.parametrize("seed", range(4))
def test_the_link_cap_as_a_stream_gives_the_whole_runs_rates(seed):
    cmds = _walk(random.Random(seed), 2000, short=True)
    expected = whole_cap(cmds, 960.0, 0.9, BOARD_QUEUE, 65530)
    got = [c.rate for c in iter_cap_for_link(_copy(cmds), 960.0, share=0.9, first_seq=65530, cpu=None)]
    assert got == expected
    assert got != [c.rate for c in cmds]        # the cap did lower some


def _spiral_chords(n: int, feed: float = 1500.0) -> List[Move]:
    """One joined drawn chain: a slowly widening spiral, with a wiggle now and then."""
    pts, rng = [], random.Random(n)
    for k in range(n + 1):
        a = k * 0.05
        r = 20.0 + 0.002 * k + (0.3 * rng.random() if k % 97 < 5 else 0.0)
        pts.append((100.0 + r * math.cos(a), 100.0 + r * math.sin(a)))
    return [Move(k + 1, "line", a[0], a[1], b[0], b[1], feed, "down") for k, (a, b) in enumerate(zip(pts, pts[1:]))]


@pytest.mark.parametrize("max_moves", [400, 37])
def test_arc_fitting_as_a_stream_gives_the_whole_chains_pieces(max_moves):
    chain = _spiral_chords(6000)
    config = FitConfig(max_moves=max_moves)
    expected = _fit_chain(chain, config)[0]
    source = Counted(chain)
    got, ahead = [], 0
    for item in iter_fit_arcs(source, config):
        got.append(item)
        ahead = max(ahead, source.taken - len(got))
    assert got == expected
    assert any(m.kind == "arc" for m in got) and any(m.kind == "line" for m in got)
    assert ahead < 10 * (max_moves + 1) + len(chain) - len(got)   # a window, never the whole chain


def _program(rng: random.Random, n: int) -> str:
    lines = ["(walk)", "G21 G90", "G0 X100 Y100", "M3", "F3000"]
    x, y = 100.0, 100.0
    for k in range(n):
        if k % 500 == 499:
            x, y = round(rng.uniform(20, 180), 3), round(rng.uniform(20, 180), 3)
            lines += ["M5", f"G0 X{x:.3f} Y{y:.3f}", "M3"]
            continue
        if k % 700 == 300:
            lines.append(f"G2 X{x + 4:.3f} Y{y:.3f} I2 J0")
            x += 4
            continue
        a = rng.uniform(0, 2 * math.pi)
        x = round(min(180.0, max(10.0, x + 1.5 * math.cos(a))), 3)
        y = round(min(190.0, max(10.0, y + 1.5 * math.sin(a))), 3)
        lines.append(f"G1 X{x:.3f} Y{y:.3f}")
    return "\n".join(lines) + "\nM5\nM2\n"


@pytest.mark.parametrize("config", [StreamerConfig(), StreamerConfig(link_baud=9600, link_seq=65000),
                                    StreamerConfig(fit_arcs=False, lookahead=False)],
                         ids=["default", "link", "plain"])
def test_compile_texts_is_compile_jobs_commands(config):
    text = _program(random.Random(1), 5000)
    _, commands = compile_job(text, config)
    job = compile_texts(text, config)
    assert job.texts == [c.text for c in commands]
    assert list(job.lines) == [c.line for c in commands]


def test_a_refused_program_is_refused_whole_by_the_stream_too():
    text = _program(random.Random(2), 3000).replace("G1 X", "G1 Q1 X", 1)
    lines = text.split("\n")
    lines.insert(2000, "G1 X500 Y0")                       # outside the work area
    text = "\n".join(lines)
    with pytest.raises(GCodeError) as whole:
        compile_job(text, StreamerConfig())
    with pytest.raises(GCodeError) as stream:
        for _ in compile_stream(text, StreamerConfig()):
            pass
    assert str(stream.value) == str(whole.value)
    assert "line 2001" in str(stream.value) and "'Q'" in str(stream.value)


def test_a_park_outside_the_area_is_refused_by_the_stream_too():
    text = "G21 G90 F1000\nG0 X50 Y50\nM3\nG1 X60\nM5\nT1 M6\nG0 X70\nM3\nG1 X80\nM5\n"
    config = StreamerConfig(area=WorkArea(10, 190, 10, 190), park=(0.0, 0.0))
    with pytest.raises(GCodeError, match="park position") as whole:
        compile_job(text, config)
    with pytest.raises(GCodeError, match="park position") as stream:
        compile_texts(text, config)
    assert str(stream.value) == str(whole.value)
