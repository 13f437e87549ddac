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
in time than the serial link needs to deliver a command, so that a dense
polyline is drawn at the link's pace without stopping at every command.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Sequence

from .commands import BoardCommand, MIN_RATE
from .protocol import compact_command


@dataclass(frozen=True)
class PlannerLimits:
    acceleration: float        # steps/s^2 the board's ramp may use
    junction_deviation: float  # steps


WIRE_OVERHEAD = 12   # bytes around a command on the wire: "N1234" and "*12345\n" (protocol.machine_line)
LINK_SHARE = 0.93    # part of its byte rate a streaming link keeps busy (benchmarks/RESULTS.md)


def wire_bytes(cmd: BoardCommand) -> int:
    """Bytes a motion command takes on the wire, its exit rate (not planned
    yet) counted with as many digits as its cruise rate."""
    r = str(cmd.rate)
    return len(compact_command(" ".join([cmd.verb, *map(str, cmd.args), r, r]))) + WIRE_OVERHEAD


def cap_for_link(commands: Sequence[BoardCommand], link_bytes_per_s: float,
                 share: float = LINK_SHARE) -> List[BoardCommand]:
    """Lower (in place) the cruise rate of every motion command so that it
    lasts at least as long as the link needs to deliver a command like it
    when `share` of the link's byte rate carries commands; returns the list.
    The board then finishes commands no faster than they arrive instead of
    running dry and braking to a stop at the end of each."""
    if link_bytes_per_s <= 0:
        return list(commands)
    for cmd in commands:
        if cmd.is_motion and cmd.steps > 0:
            seconds = wire_bytes(cmd) / (link_bytes_per_s * share)
            cmd.rate = max(MIN_RATE, min(cmd.rate, int(cmd.steps / seconds)))
    return list(commands)


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


def plan(commands: Sequence[BoardCommand], limits: PlannerLimits) -> List[BoardCommand]:
    """Set exit_rate on every motion command (in place) and return the list."""
    a2 = 2.0 * limits.acceleration
    chain: List[BoardCommand] = []

    def flush() -> None:
        n = len(chain)
        # Whole steps/s throughout: the board is sent integers, and the checks
        # below must hold for exactly what it is sent.
        exits = [0] * n
        for i in range(n - 2, -1, -1):           # backward: brake in time for what follows
            nxt = chain[i + 1]
            exits[i] = int(min(junction_rate(chain[i], nxt, limits), chain[i].rate, nxt.rate,
                               math.sqrt(exits[i + 1] ** 2 + a2 * nxt.steps)))
        entry = 0
        for i, cmd in enumerate(chain):          # forward: only what acceleration can reach
            exits[i] = min(exits[i], int(math.sqrt(entry ** 2 + a2 * cmd.steps)))
            cmd.exit_rate = exits[i] if exits[i] >= MIN_RATE else 0
            entry = cmd.exit_rate
        chain.clear()

    for cmd in commands:
        if cmd.is_motion:
            chain.append(cmd)
        else:
            flush()                               # pen changes and dwells start and end at rest
    flush()
    return list(commands)
