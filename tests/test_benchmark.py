"""The benchmark's own parts: the independent time-optimal bound, the
simulated board with both UART directions at the baud rate, and the
planner's link cap that the benchmark motivated."""
import math
import sys
from pathlib import Path

import pytest

from firmware_build import host_library
from plotter_bridge.motion.commands import BoardCommand
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.motion.planner import cap_for_link, link_baud, wire_bytes
from plotter_bridge.link.protocol import machine_line

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from bound import Limits, Move, Wait, chain_time, corner_rate, junction_rates, move_time, program_time  # noqa: E402
from simboard import SimBoard, settle  # noqa: E402

LIM = Limits(acceleration=100000.0, junction_deviation=4.0, start_rate=250.0)
EAST, NORTH, WEST, SOUTH = (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)


def numeric_time(steps, entry, exit_, cruise, accel, dt=1e-6):
    """Fastest profile by brute force: accelerate while braking to exit_ is
    still possible, else brake; never above cruise."""
    x, v, t = 0.0, entry, 0.0
    while x < steps:
        brake = (v * v - exit_ * exit_) / (2 * accel)
        if steps - x <= brake:
            v = max(exit_, v - accel * dt)
        else:
            v = min(cruise, v + accel * dt)
        x += v * dt
        t += dt
    return t


@pytest.mark.parametrize("steps,entry,exit_,cruise", [
    (4000, 250, 250, 8000),       # trapezoid
    (300, 250, 250, 8000),        # triangle
    (500, 3000, 1000, 4000),      # entry and exit in motion
    (2000, 4000, 4000, 4000),     # cruise only
])
def test_move_time_is_the_fastest_profile(steps, entry, exit_, cruise):
    assert move_time(steps, entry, exit_, cruise, 1e5) == pytest.approx(
        numeric_time(steps, entry, exit_, cruise, 1e5), rel=2e-3)


def test_corner_rule():
    assert corner_rate(EAST, EAST, LIM) == math.inf
    assert corner_rate(EAST, WEST, LIM) == 0.0
    c = math.cos(math.pi / 4)                         # a right angle turns by 90 degrees
    assert corner_rate(EAST, NORTH, LIM) == pytest.approx(math.sqrt(1e5 * 4 * c / (1 - c)))


def test_junctions_respect_corners_braking_and_the_start_rate():
    moves = [Move(800, 6000, EAST, EAST), Move(800, 6000, NORTH, NORTH), Move(50, 6000, SOUTH, SOUTH)]
    v = junction_rates(moves, LIM)
    assert v[0] == v[-1] == 250.0
    assert v[1] == pytest.approx(corner_rate(EAST, NORTH, LIM))
    assert v[2] == 250.0                               # a reversal: at the start rate
    for k, m in enumerate(moves):                     # every move can link its two ends
        assert abs(v[k + 1] ** 2 - v[k] ** 2) <= 2 * LIM.acceleration * m.steps + 1e-6


def test_waits_split_chains_and_add_their_time():
    a, b = Move(4000, 8000, EAST, EAST), Move(4000, 8000, EAST, EAST)
    together = program_time([a, b], LIM)
    apart = program_time([Wait(0.5), a, Wait(0.15), b, Wait(0.5)], LIM)
    assert together == pytest.approx(chain_time([a, b], LIM))
    assert apart == pytest.approx(2 * chain_time([a], LIM) + 0.15)
    assert together < apart - 0.15


@pytest.fixture
def core():
    c = FirmwareCore(host_library())
    yield c
    c.close()


def test_sim_board_sends_replies_at_the_baud_rate(core):
    board = SimBoard(core, baud=9600)
    settle(board, 0.1)
    board.port.read(4096)                             # the banner
    line = machine_line(0, "L 80 0 2000 0")
    board.port.write(line)
    got, t_reply = b"", None
    while b"\n" not in got:
        settle(board, 0.001)
        got += board.port.read(4096)
        t_reply = board.now if b"\n" in got else None
    # the line arrives byte by byte, then the reply leaves byte by byte: 1.04 ms each at 9600
    expected = (len(line) + len(got)) * 10 / 9600 + 0.1
    assert t_reply == pytest.approx(expected, abs=0.0025)
    assert got.startswith(b"ok N0 Q")


def test_link_cap_makes_commands_last_their_time_on_the_wire():
    cmds = [BoardCommand("L", (8, 0), 1, 8, 8000, dir_in=EAST, dir_out=EAST) for _ in range(5)]
    cmds.append(BoardCommand("L", (4000, 0), 1, 4000, 8000, dir_in=EAST, dir_out=EAST))
    cap_for_link(cmds, 11520.0, share=0.9, first_seq=1234, cpu=None)
    for k, c in enumerate(cmds):
        assert c.steps / c.rate >= wire_bytes(c, seq=1234 + k) / (11520.0 * 0.9) - 1e-9
    assert cmds[0].rate < 8000 and cmds[-1].rate == 8000     # long commands keep their feed
    c = cmds[0]
    c.exit_rate = c.rate
    sent = machine_line(1234, c.text)
    assert wire_bytes(c, seq=1234) == len(sent) + 5 - len(sent.split(b"*")[1].strip())
    assert wire_bytes(c) == wire_bytes(c, seq=12345)          # number unknown: five digits


def test_link_cap_gives_neighbouring_chords_one_rate():
    """Chords of a curve one step longer or shorter than their neighbours get
    the rate of the stretch they end, not one each: the board's ramp could not
    follow rates alternating by a tenth, and the planner would flatten them to
    the lowest.  Over any stretch the board takes as long as the link."""
    steps = [10, 11] * 30
    cmds = [BoardCommand("L", (s, 0), 1, s, 10000, dir_in=EAST, dir_out=EAST) for s in steps]
    cap_for_link(cmds, 11520.0, share=0.95, first_seq=100, cpu=None)
    rates = [c.rate for c in cmds[6:]]
    assert max(rates) - min(rates) <= 0.01 * max(rates)
    board = sum(c.steps / c.rate for c in cmds[6:])
    link = sum(wire_bytes(c, seq=106 + k) for k, c in enumerate(cmds[6:])) / (11520.0 * 0.95)
    assert board == pytest.approx(link, rel=0.02)


def test_streamer_plans_for_the_bridges_baud_unless_told():
    assert link_baud(-1, 9600) == 9600          # gcode_streamer's default: serial_bridge's baud
    assert link_baud(0, 9600) == 0              # off
    assert link_baud(115200, 9600) == 115200
    assert link_baud(-1, 0) == 0                # a bridge that does not say


def test_board_cpu_bounds_short_chords_whatever_the_baud():
    """A chord takes the board's main loop BoardCpu.command_cycles, in the
    share of the CPU its steps leave: at 115200 baud that, not the link,
    bounds 1 mm chords; at 9600 the link is the tighter bound."""
    from plotter_bridge.motion.planner import BOARD_CPU
    cpu = BOARD_CPU
    for baud, cpu_binds in ((115200, True), (9600, False)):
        cmds = [BoardCommand("L", (80, 0), 1, 80, 8000, dir_in=EAST, dir_out=EAST) for _ in range(30)]
        cap_for_link(cmds, baud / 10.0, first_seq=100)
        r = cmds[-1].rate
        closed_form = 80 * cpu.cycles_per_s * cpu.share / (cpu.command_cycles + cpu.step_cycles * 80)
        if cpu_binds:
            assert r == pytest.approx(closed_form, rel=0.03)
        else:
            assert r < 0.97 * closed_form
        assert 80 / r >= cpu.seconds(cmds[-1]) * 0.99
    long = [BoardCommand("L", (8000, 0), 1, 8000, 8000, dir_in=EAST, dir_out=EAST) for _ in range(3)]
    cap_for_link(long, 11520.0)
    assert all(c.rate == 8000 for c in long)         # long commands keep their feed


@pytest.mark.parametrize("baud, board_cpu", [(115200, True), (9600, True), (115200, False)])
def test_a_board_that_charges_the_chips_cpu_runs_dry_unless_planned_for(baud, board_cpu):
    """On the simulated board charging each line the chip's main-loop cycles
    (SimBoard line_cycles, step_cycles), 1 mm chords at F6000 keep the queue
    fed when the streamer plans for the CPU (at 9600 baud, for the window of
    lines the receive ring holds while each is parsed and answered), and at
    115200 brake at chord after chord when it plans for the link alone."""
    from plotter_bridge.motion.compiler import StreamerConfig, compile_program
    from plotter_bridge.motion.planner import BOARD_CPU
    from simrun import SimSession
    gcode = "G21 G90\nG0 X70 Y50\nM3\n" + "".join(
        f"G1 X{50 + 20 * math.cos(k / 20):.3f} Y{50 + 20 * math.sin(k / 20):.3f} F6000\n" for k in range(1, 120))
    config = StreamerConfig(link_baud=baud, fit_arcs=False, board_cpu=board_cpu)
    session = SimSession(baud=baud, line_cycles=round(BOARD_CPU.command_cycles),
                         step_cycles=BOARD_CPU.step_cycles)
    try:
        result = session.stream(compile_program(gcode, config, (0, 0)))
    finally:
        session.close()
    if board_cpu:
        assert result.underruns <= 2
    else:
        assert result.underruns > 30
