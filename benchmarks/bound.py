"""The time-optimal drawing time of a program, for the board's own limits.

Written independently of the host planner (plotter_bridge.motion.planner): the
benchmark compares what the board achieves with this bound, so it must not
share the planner's code or its mistakes.

The model is the board's rate space: distances in steps (point-by-point
interpolation takes one axis per step, so a segment of dx, dy is |dx| + |dy|
steps long, an arc the total variation of x plus y) and rates in steps/s.
Within that space:

- every move has its own cruise rate (the G-code feed converted per move);
- the rate changes at no more than `acceleration` steps/s^2 (the board's
  trapezoid ramp);
- the board starts and stops at `start_rate` without a ramp (level 0 of its
  ramp table), so no rate below it is ever needed;
- where two moves meet, the rate may not exceed the corner rule of grbl's
  junction deviation: a circular arc of deviation `junction_deviation`
  steps, tangent to both moves, taken at `acceleration`.  With phi the angle
  the direction of travel turns through, v^2 = a * d * c / (1 - c) with
  c = cos(phi / 2): no limit straight on, zero for a full reversal;
- pen changes and dwells stand still for their time, and the rate is at
  rest on both sides of them.

Under these constraints the fastest profile is the classic one: the highest
junction rates that every move can still brake from (a backward pass) and
accelerate to (a forward pass), then per move the fastest
accelerate-cruise-brake (trapezoid or triangle) between them.  The time is
computed in closed form, in floating point, without the board's level
quantisation: a lower bound on what any planner can get out of this board.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Sequence, Tuple, Union

Vec = Tuple[float, float]


@dataclass(frozen=True)
class Limits:
    acceleration: float          # steps/s^2
    junction_deviation: float    # steps
    start_rate: float            # steps/s reached or left instantly at rest


@dataclass(frozen=True)
class Move:
    steps: int                   # length in the board's steps
    rate: float                  # cruise rate, steps/s
    dir_in: Vec                  # unit direction of travel at the start
    dir_out: Vec                 # ... and at the end


@dataclass(frozen=True)
class Wait:
    seconds: float               # pen change or dwell: at rest this long


Item = Union[Move, Wait]


def corner_rate(u: Vec, v: Vec, limits: Limits) -> float:
    """Highest rate for turning from direction u into direction v."""
    dot = max(-1.0, min(1.0, u[0] * v[0] + u[1] * v[1]))
    c = math.sqrt((1.0 + dot) / 2.0)          # cos(phi / 2), phi the turn angle
    if c >= 1.0 - 1e-12:
        return math.inf
    return math.sqrt(limits.acceleration * limits.junction_deviation * c / (1.0 - c))


def junction_rates(moves: Sequence[Move], limits: Limits) -> List[float]:
    """Rates at the n + 1 boundaries of n moves driven without a stop
    (index 0: the start, n: the end, both at rest)."""
    n = len(moves)
    a2 = 2.0 * limits.acceleration
    rest = [min(limits.start_rate, m.rate) for m in moves]
    v = [0.0] * (n + 1)
    v[0] = rest[0] if n else 0.0
    v[n] = rest[-1] if n else 0.0
    for k in range(1, n):
        prev, nxt = moves[k - 1], moves[k]
        cap = min(corner_rate(prev.dir_out, nxt.dir_in, limits), prev.rate, nxt.rate)
        v[k] = max(cap, min(rest[k - 1], rest[k]))
    for k in range(n - 1, 0, -1):             # brake in time for everything after
        v[k] = min(v[k], math.sqrt(v[k + 1] ** 2 + a2 * moves[k].steps))
    for k in range(1, n):                     # reach it from everything before
        v[k] = min(v[k], math.sqrt(v[k - 1] ** 2 + a2 * moves[k - 1].steps))
    return v


def move_time(steps: float, entry: float, exit_: float, cruise: float, accel: float) -> float:
    """Fastest time over `steps` from rate `entry` to `exit_` with top rate
    `cruise` at acceleration `accel` (entry and exit compatible with it)."""
    if steps <= 0:
        return 0.0
    peak2 = (2.0 * accel * steps + entry ** 2 + exit_ ** 2) / 2.0
    if peak2 >= cruise ** 2:
        ramps = (2.0 * cruise ** 2 - entry ** 2 - exit_ ** 2) / (2.0 * accel)
        return (2.0 * cruise - entry - exit_) / accel + (steps - ramps) / cruise
    peak = math.sqrt(peak2)
    return (2.0 * peak - entry - exit_) / accel


def chain_time(moves: Sequence[Move], limits: Limits) -> float:
    """Optimal time of moves driven one after the other without stopping."""
    v = junction_rates(moves, limits)
    return sum(move_time(m.steps, v[k], v[k + 1], m.rate, limits.acceleration)
               for k, m in enumerate(moves))


def stop_chain_time(moves: Sequence[Move], limits: Limits) -> float:
    """Optimal time of the same moves with a stop at the end of every one."""
    return sum(chain_time([m], limits) for m in moves)


def program_time(items: Sequence[Item], limits: Limits, stop_every_move: bool = False) -> float:
    """Optimal time from the first move's start to the last move's end:
    chains of moves between waits, and the waits between the moves."""
    first = next((k for k, it in enumerate(items) if isinstance(it, Move)), None)
    if first is None:
        return 0.0
    last = max(k for k, it in enumerate(items) if isinstance(it, Move))
    total, chain = 0.0, []
    timer = stop_chain_time if stop_every_move else chain_time
    for it in items[first:last + 1]:
        if isinstance(it, Move):
            chain.append(it)
        else:
            total += timer(chain, limits) + it.seconds
            chain = []
    return total + timer(chain, limits)
