"""The look-ahead planner: junction speeds, reachable and brakeable exits,
and the time it saves on the real firmware core (simulated board time)."""
import math

import pytest

from firmware_build import host_library
from plotter_bridge.motion.commands import BoardCommand
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.link.board_link import BoardLink
from plotter_bridge.motion.planner import PlannerLimits, junction_rate, plan
from plotter_bridge.motion.compiler import StreamerConfig, compile_program
from sim_port import SimPort

LIMITS = PlannerLimits(acceleration=80000.0, junction_deviation=4.0)


def line(dx, dy, rate=4000):
    r = math.hypot(dx, dy)
    u = (dx / r, dy / r)
    return BoardCommand("L", (dx, dy), 1, abs(dx) + abs(dy), rate, dir_in=u, dir_out=u)


def test_collinear_segments_flow_through_at_full_rate():
    cmds = plan([line(400, 0) for _ in range(10)], LIMITS)
    assert [c.exit_rate for c in cmds[1:-2]] == [4000] * 7
    assert cmds[-1].exit_rate == 0


def test_right_angle_slows_just_to_the_corner_rule():
    cmds = plan([line(4000, 0), line(0, 4000)], LIMITS)
    s = math.sqrt(0.5)                   # sin(45 deg)
    assert cmds[0].exit_rate == int(math.sqrt(LIMITS.acceleration * LIMITS.junction_deviation * s / (1 - s)))


def test_reversal_stops_and_pen_changes_stop():
    cmds = plan([line(400, 0), line(-400, 0), line(400, 0), BoardCommand("P", (1,), 2), line(400, 0)], LIMITS)
    assert cmds[0].exit_rate == 0
    assert cmds[2].exit_rate == 0 and cmds[4].exit_rate == 0
    assert junction_rate(line(1, 0), line(1, 0), LIMITS) == math.inf


def test_every_exit_reachable_and_brakeable():
    cmds = compile_program(open_spiral(400), StreamerConfig())
    motion = [c for c in cmds if c.is_motion]
    a2 = 2 * 0.8 * 100000
    entry = 0
    for k, c in enumerate(motion):
        assert c.exit_rate <= c.rate
        assert c.exit_rate ** 2 <= entry ** 2 + a2 * c.steps + 1
        if k + 1 < len(motion):
            assert c.exit_rate ** 2 <= motion[k + 1].exit_rate ** 2 + a2 * motion[k + 1].steps + 1
        entry = c.exit_rate


def open_spiral(n):
    lines = ["G21 G90", "G0 X100 Y100", "M3"]
    for k in range(1, n):
        a, r = k * 0.08, 2 + k * 0.1
        lines.append(f"G1 X{100 + r * math.cos(a):.3f} Y{100 + r * math.sin(a):.3f} F6000")
    return "\n".join(lines + ["M5", "M2"]) + "\n"


def board_time(commands):
    core = FirmwareCore(host_library())
    port = SimPort(core)
    link = BoardLink(port, clock=port.clock)
    while link.status is None:
        link.poll()
        port.advance(0.002)
    link.sync(link.status.next_seq, link.status.queue_free)
    for c in commands:
        link.submit(c.text)
    while link.outstanding or core.running or core.queue_free != 6:
        link.poll()
        port.advance(0.002)
    moves = port.steps
    core.close()
    return moves[-1][0] - moves[0][0], moves[-1][1:]


def test_lookahead_draws_the_same_path_in_far_less_board_time():
    text = open_spiral(300)
    planned = compile_program(text, StreamerConfig())
    stopping = compile_program(text, StreamerConfig(lookahead=False))
    t_plan, end_plan = board_time(planned)
    t_stop, end_stop = board_time(stopping)
    assert end_plan == end_stop
    assert t_plan < 0.5 * t_stop, (t_plan, t_stop)


def test_board_leaves_each_command_no_faster_than_planned():
    """The firmware's ramp must not climb to a level it cannot brake down from:
    a short line planned to leave at 850 steps/s takes the corner at most one
    ramp level (200 steps/s) faster."""
    from plotter_bridge.sim.firmware_core import CYCLES_PER_S
    core = FirmwareCore(host_library())
    assert core.plan_line(160, 0, 8000, 850) == 0
    assert core.plan_line(0, 160, 8000, 0) == 0
    steps = core.run_steps()
    core.close()
    rates = [CYCLES_PER_S / s.cycles for s in steps]
    assert max(rates[158:162]) <= 850 + 200 + 1
    assert rates[-1] <= 250 + 200 + 1
