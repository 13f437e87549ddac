"""Jobs through BoardSession and the firmware core on simulated time, with faults.

Shared by tests/test_reliability_sim.py and scripts/reliability_figures.py:
no ROS, no pty; `SimPort` runs the board at its baud rate on a simulated
clock, so a 1,000-segment job at 1 % byte faults takes seconds, not minutes.
"""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple

from plotter_bridge.link.board_session import BoardSession, Job, SessionConfig
from plotter_bridge.sim.faults import FaultCounts, FaultSpec
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.link.protocol import nearest_seq
from sim_port import SimPort

DT = 0.002


def random_job(segments: int, seed: int = 1, feed: int = 8000) -> Tuple[List[str], Tuple[int, int]]:
    """Lines and arcs in steps that wander around the origin; their end point."""
    rng = random.Random(seed)
    commands, x, y = [], 0, 0
    for k in range(segments):
        if k % 5 == 4:
            r = rng.randint(20, 120)
            # a half circle: centre r to the right, end 2r to the right
            sign = 1 if x < 0 else -1
            commands.append(f"{'C' if k % 2 else 'A'} {2 * r * sign} 0 {r * sign} 0 {feed} 0")
            x += 2 * r * sign
        else:
            dx, dy = rng.randint(-150, 150), rng.randint(-150, 150)
            if (dx, dy) == (0, 0):
                dx = 1
            commands.append(f"L {dx} {dy} {feed} 0")
            x, y = x + dx, y + dy
    return commands, (x, y)


class SimRig:
    """A core, a port into it, and a session on the same simulated clock."""

    def __init__(self, faults: Optional[FaultSpec] = None, config: Optional[SessionConfig] = None,
                 library=None, record_steps: bool = True) -> None:
        self.core = FirmwareCore(library)
        self.port = SimPort(self.core, faults=faults, record_steps=record_steps)
        self.log: List[str] = []
        self.session = BoardSession(self._open, config or SessionConfig(), clock=self.port.clock,
                                    log=self.log.append)

    def _open(self):
        if self.port.unplugged:
            raise OSError(2, "No such file or directory")
        return self.port

    def step(self, dt: float = DT) -> None:
        self.session.pump()
        self.port.advance(dt)

    def run_until(self, cond: Callable[[], bool], limit: float = 600.0, dt: float = DT) -> bool:
        end = self.port.now + limit
        while self.port.now < end:
            self.step(dt)
            if cond():
                return True
        return False

    def connect(self) -> None:
        s = self.session
        assert self.run_until(lambda: s.connection == "connected" and s.link.outstanding == 0, 60.0)

    def start(self, commands: List[str]) -> Job:
        job = self.session.start_job(commands, list(range(1, len(commands) + 1)))
        assert job.result is None, job.result
        return job

    def executed_of(self, job: Job) -> List[int]:
        """The job's commands the board started, as indices, in order (seq log).  The log holds
        16-bit numbers: each is read as the host number nearest the one before it, so a job
        past 2^16 commands is read whole."""
        host, out = job.first - 1, []
        for wire in self.core.seq_log():
            host = nearest_seq(host, wire)
            if 0 <= host - job.first < job.submitted:
                out.append(host - job.first)
        return out

    def close(self) -> None:
        self.core.close()


@dataclass
class Figures:
    faults: str
    segments: int
    injected: FaultCounts
    retransmissions: int
    resend_requests: int
    timeouts: int
    garbled_replies: int
    completed: bool
    exact: bool
    once_in_order: bool
    board_seconds: float
    message: str


STALL_S = 900.0       # simulated s without a command acknowledged: the job is stuck, not slow


def fault_run(spec: FaultSpec, segments: int = 1000, seed: int = 1, library=None) -> Figures:
    """One job through faults, on simulated time, for as long as it goes on: it "did not end" when
    STALL_S pass without a command acknowledged (at 2 % noise a 100k-command job takes some 10 h
    of the board's time, most of it waiting out time-outs)."""
    rig = SimRig(spec, SessionConfig(ack_timeout=0.3), library, record_steps=False)
    try:
        rig.connect()
        commands, end = random_job(segments, seed)
        job = rig.start(commands)
        done, acknowledged = False, -1
        while not done and job.acknowledged > acknowledged:
            acknowledged = job.acknowledged
            done = rig.run_until(lambda: job.result is not None, limit=STALL_S)
        stats = rig.session.link.stats
        injected = rig.port.down.counts.add(rig.port.up.counts)
        return Figures(str(spec), segments, injected, stats.retransmissions, stats.resend_requests,
                       stats.timeouts, stats.garbled_replies,
                       done and job.result.success, rig.core.position == end,
                       rig.executed_of(job) == list(range(segments)), rig.port.now,
                       job.result.message if job.result else
                       f"did not end: no command acknowledged in {STALL_S:g} s after {job.acknowledged}")
    finally:
        rig.close()
