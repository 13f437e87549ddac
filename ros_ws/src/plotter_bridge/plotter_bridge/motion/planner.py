"""Look-ahead speed planning: the exit rate of every motion command.

The board ramps its step rate at a fixed acceleration and carries the rate
from one command into the next, so the host only has to say, per command,
how fast to leave it.  As grbl's planner: each junction gets a speed limit
from the corner deviation rule (a corner may be taken as fast as a circular
arc of deviation `junction_deviation` through it would allow at the given
acceleration); a backward pass makes every command able to brake to what
follows within its length, a forward pass makes every exit reachable from
its entry.  Collinear and gently turning commands flow through; sharp
corners slow down just enough; the pen, dwells and the end stop at rest.

Rates are in steps per second and distances in steps, as on the board.

The board only keeps going while commands arrive faster than it finishes
them; a command that ends with nothing queued behind it is braked to a stop
(an underrun).  `cap_for_link` lowers the cruise rate of commands shorter
in time than the serial link needs to deliver a command, or the board's
8051 to parse and plan it (BoardCpu), so that a dense polyline is drawn at
that pace without stopping at every command.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from collections import deque
from typing import Deque, Iterable, Iterator, List, Optional, Sequence

from .commands import BoardCommand, MIN_RATE
from plotter_bridge.link.protocol import SEQ_MOD, compact_command


@dataclass(frozen=True)
class PlannerLimits:
    acceleration: float        # steps/s^2 the board's ramp may use
    junction_deviation: float  # steps


LINK_SHARE = 0.97    # part of its byte rate a streaming link keeps busy (benchmarks/RESULTS.md)
BOARD_QUEUE = 6      # commands the board holds (firmware QUEUE_SIZE, $I field Q)
SUM_DIGITS = 5       # a checksum below 10000 is the exception (1 line in 6)
RX_BUFFER = 64       # bytes the link keeps unacknowledged: the board's receive ring ($I field B)
REPLY_BYTES = 17     # `ok N<seq> Q<free> *<sum>` and its line end


def wire_bytes(cmd: BoardCommand, rate: int = 0, seq: Optional[int] = None) -> int:
    """Bytes a motion command takes on the wire (protocol.machine_line) at
    cruise `rate` (default: its own), its exit rate (not planned yet)
    counted with as many digits; sent as number `seq`, or with a 5-digit
    number (most of the 16-bit range) when that is not known."""
    r = str(rate or cmd.rate)
    number = len(str(seq % SEQ_MOD)) if seq is not None else 5
    text = compact_command(" ".join([cmd.verb, *map(str, cmd.args), r, r]))
    return 1 + number + len(text) + 1 + SUM_DIGITS + 1       # N<seq><text>*<sum>\n


@dataclass(frozen=True)
class BoardCpu:
    """What a streamed command costs the board's main loop, which parses and
    plans it in what the step interrupt leaves of the CPU
    (`make -C firmware plancost`, firmware/tools/plan_cost.py, the default
    image at 11.0592 MHz).  However fast the link, the board takes a motion
    command no faster than `seconds`: short chords at a high feed are
    bounded by the CPU, not only by the bytes."""
    cycles_per_s: float = 921600.0      # machine cycles a second (11.0592 MHz / 12)
    # A chord: its receive, parse, plan and reply (14323) and its 42 bytes' UART interrupts at their
    # longest path (94 each); an arc likewise (17200, 46 bytes).
    command_cycles: float = 18271.0
    arc_command_cycles: float = 21524.0
    step_cycles: float = 42.3           # the step interrupt's cycles per line step (36.7 % at 8000 steps/s)
    arc_step_cycles: float = 84.6       # ... per arc step (45.9 % at 5000)
    # Of the CPU counted on: a ramp's level changes, a segment load and the link's jitter take the rest.
    share: float = 0.9

    def time(self, steps: float, arc: bool) -> float:
        """The least time the board takes for a motion command of `steps`
        when commands like it come back to back: the CPU does the next one's
        main-loop work and this one's step interrupts in it."""
        cycles = (self.arc_command_cycles + self.arc_step_cycles * steps if arc
                  else self.command_cycles + self.step_cycles * steps)
        return cycles / (self.cycles_per_s * self.share)

    def seconds(self, cmd: BoardCommand) -> float:
        return self.time(cmd.steps, cmd.verb in ("A", "C"))


BOARD_CPU = BoardCpu()


def cap_for_link(commands: Sequence[BoardCommand], link_bytes_per_s: float,
                 share: float = LINK_SHARE, window: int = BOARD_QUEUE,
                 first_seq: Optional[int] = None, cpu: Optional[BoardCpu] = BOARD_CPU) -> List[BoardCommand]:
    """Lower (in place) the cruise rate of motion commands shorter in time
    than the link needs to deliver them, so that the board takes about as
    long to draw them as `share` of the link's byte rate takes to send
    them; returns the list.  The board then finishes commands no faster
    than they arrive instead of running dry and braking to a stop at the
    end of each.  `first_seq`: the sequence number the first command goes
    out with, if known (its digits count).

    Along a run of such commands the cap is the mean rate of the `window`
    commands up to each (the board's queue evens out the rest): neighbouring
    chords of a curve differ by a step or two, and capping each to its own
    length would make their rates alternate by 10 % or more, which the
    board's ramp cannot follow and the planner's exits would flatten to the
    lowest.  Only earlier commands count, because a command the board runs
    faster than the link delivers it must be paid for by time the queue has
    already gained.  A lower rate may take fewer digits on the wire, so the
    bytes are counted again at the capped rates.

    `cpu`: the board's own time per command (BoardCpu), the floor under
    the link's: a command takes at least that long to be parsed and
    planned, at any baud rate (None: a board that plans in no time)."""
    return list(iter_cap_for_link(commands, link_bytes_per_s, share, window, first_seq, cpu))


def iter_cap_for_link(commands: Iterable[BoardCommand], link_bytes_per_s: float,
                      share: float = LINK_SHARE, window: int = BOARD_QUEUE,
                      first_seq: Optional[int] = None, cpu: Optional[BoardCpu] = BOARD_CPU) -> Iterator[BoardCommand]:
    """cap_for_link one command at a time: a command's cap depends only on it and the commands
    before it, so each goes on as soon as it is capped."""
    if link_bytes_per_s <= 0:
        yield from commands
        return
    bytes_per_s = link_bytes_per_s * share

    def need(cmd: BoardCommand, rate: int, number: Optional[int]) -> float:
        """Seconds the link and the board need for a command at `rate` (0: its own).  With the board's
        CPU: also what the link's window allows, as many lines as fill the receive ring each held from
        its first byte sent until its ok is in (its bytes, its parsing, the ok's bytes)."""
        n = wire_bytes(cmd, rate, number)
        if cpu is None:
            return n / bytes_per_s
        parse = cpu.seconds(cmd)
        held = ((n + REPLY_BYTES) / link_bytes_per_s + parse) * n / RX_BUFFER
        return max(n / bytes_per_s, parse, held / share)

    # The run's last `window` commands: steps and seconds at their own rates, then at the first caps;
    # each cap is the mean rate of those (twice, as a lower rate may take fewer digits on the wire).
    steps: Deque[int] = deque(maxlen=window)
    first: Deque[float] = deque(maxlen=window)
    second: Deque[float] = deque(maxlen=window)
    for k, cmd in enumerate(commands):
        number = None if first_seq is None else first_seq + k
        if not (cmd.is_motion and cmd.steps > 0 and cmd.steps / cmd.rate < need(cmd, 0, number)):
            steps.clear(), first.clear(), second.clear()
            yield cmd
            continue
        steps.append(cmd.steps)
        first.append(need(cmd, cmd.rate, number))
        rate = max(MIN_RATE, min(cmd.rate, int(sum(steps) / sum(first))))
        second.append(need(cmd, rate, number))
        cmd.rate = max(MIN_RATE, min(cmd.rate, int(sum(steps) / sum(second))))
        yield cmd


def link_baud(parameter: int, bridge_baud: int) -> int:
    """The baud rate cap_for_link plans for: `parameter` if positive, none
    if 0, the serial bridge's if negative."""
    return parameter if parameter >= 0 else max(0, bridge_baud)


def junction_rate(a: BoardCommand, b: BoardCommand, limits: PlannerLimits) -> float:
    """Highest rate at which the path may turn from command a into command b."""
    ux, uy = a.dir_out
    vx, vy = b.dir_in
    cos_theta = -(ux * vx + uy * vy)       # theta: angle between the reversed in and the out direction
    if cos_theta > 0.999999:
        return 0.0                         # a full reversal
    if cos_theta < -0.999999:
        return math.inf                    # straight on
    sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
    return math.sqrt(limits.acceleration * limits.junction_deviation * sin_half / (1.0 - sin_half))


PLAN_HORIZON = 50000   # commands of one chain held at most before some go on (see iter_plan)


def plan(commands: Sequence[BoardCommand], limits: PlannerLimits) -> List[BoardCommand]:
    """Set exit_rate on every motion command (in place) and return the list."""
    return list(iter_plan(commands, limits))


def iter_plan(commands: Iterable[BoardCommand], limits: PlannerLimits,
              horizon: int = PLAN_HORIZON) -> Iterator[BoardCommand]:
    """plan one command at a time, holding no more of a chain of motion commands than decides the
    exits of those that go on.

    The backward pass brakes each command for what follows.  Run over the commands held, as if the
    chain ended after them, a command whose exit its own limits (its rate, its neighbour's, the
    junction) bound rather than the braking for the rest is exact: a longer rest could only let it
    go faster than those limits.  It and all before it go on (the forward pass is causal); the rest
    wait for more.  A chain that brakes all the way through `horizon` commands lets its first half
    go as if it stopped there: never faster than the whole plan, only slower."""
    a2 = 2.0 * limits.acceleration
    chain: List[BoardCommand] = []
    entry = 0
    tried = 0

    def settle(final: bool) -> Iterator[BoardCommand]:
        nonlocal entry, tried
        n = len(chain)
        # Whole steps/s throughout: the board is sent integers, and the checks
        # below must hold for exactly what it is sent.
        exits = [0] * n
        cut = n - 1 if final else -1
        for i in range(n - 2, -1, -1):           # backward: brake in time for what follows
            nxt = chain[i + 1]
            own = min(junction_rate(chain[i], nxt, limits), chain[i].rate, nxt.rate)
            brake = math.sqrt(exits[i + 1] ** 2 + a2 * nxt.steps)
            exits[i] = int(min(own, brake))
            if cut < 0 and own <= brake:
                cut = i
        if cut < 0 and n >= horizon:
            cut = n // 2
        for i in range(cut + 1):                 # forward: only what acceleration can reach
            cmd = chain[i]
            exit_rate = min(exits[i], int(math.sqrt(entry ** 2 + a2 * cmd.steps)))
            cmd.exit_rate = exit_rate if exit_rate >= MIN_RATE else 0
            entry = cmd.exit_rate
            yield cmd
        del chain[:cut + 1]
        if final:
            entry = 0
        tried = len(chain)

    for cmd in commands:
        if cmd.is_motion:
            chain.append(cmd)
            if len(chain) >= 2 * tried + 64:
                yield from settle(False)
        else:
            yield from settle(True)               # pen changes and dwells start and end at rest
            yield cmd
    yield from settle(True)
