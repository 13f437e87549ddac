"""Streaming commands to the board without waiting for each reply.

BoardLink keeps a window of numbered commands in flight, limited by the
board's receive buffer (bytes not yet acknowledged) and its free queue slots
(the `Q` of the latest reply, less what was sent after it).  Damaged or lost
lines are sent again from the number the board expects ("go back N"): on an
`rs`, or when the oldest line stays unacknowledged past a time-out.  The
board executes each number once, so repeats are harmless.

Every status report is checked against what the link knows: the board's
next expected number must lie between the last acknowledged line and the
last line sent.  A board that forgot its numbering (it was reset, perhaps
while the port was away and its banner lost) fails that check and is
reported through `on_mismatch` instead of having lines acknowledged or sent
to it.  After the port comes back, `attach()` holds every line until a
status report shows where the board is, then goes on from its `N`.

Lines are sent as soon as the board's receive ring has room for them: the
bytes of every line sent and not yet acknowledged count against its 64
bytes, as grbl's character-counting streaming does, so two or three lines
are on their way while the board answers the one before.

The board frees a queue slot silently when a command ends.  While its queue
is full and no line is on its way (whose ok would carry the news), the link
sends a probe: an empty line numbered 30000 below the last acknowledged one.
The board answers a number it has already executed with `ok N<that> Q<free>`
and runs nothing (PROTOCOL.md, go back N), after every line sent before it:
20 bytes back instead of a 48-byte status report, which also holds the
8051's main loop while it fills the 16-byte transmit ring.  A lost probe or
answer only costs time: another goes after `ack_timeout`.

Status reports share the board-to-host direction with the acknowledgements.
A report of about 48 bytes delays the acknowledgement behind it, and with
only two lines fitting in the ring the link then idles: at 115200 baud each
report costs the link about 4 ms of sending.  With `baud` given, polling is
held, whatever `status_interval` asks, to a share of that direction's bytes:
`status_share` (STATUS_SHARE, 5 %: about 12 reports a second at 115200 baud,
1 at 9600) while lines wait to be sent and lines are on their way or the
board has room for more, and `wait_share` (WAIT_SHARE, 30 %: 6 a second at
9600) while its queue is full and nothing is on its way, or there is nothing
to send, when acknowledgements are few.  Probes are held to `wait_share` as
well: up to 170 a second at 115200 baud, 14 at 9600.

The caller drives it: `poll()` reads what arrived, reacts, and sends what the
window allows.  It owns no thread and knows nothing of ROS.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from itertools import islice
from typing import Callable, Deque, Optional, Protocol

from .protocol import (RT_STATUS, SEQ_MOD, Banner, Err, Message, Ok, Resend, Status, nearest_seq,
                       machine_line, parse_reply)


class Port(Protocol):
    def write(self, data: bytes) -> int: ...
    def read(self, n: int) -> bytes: ...


@dataclass
class Command:
    seq: int                 # host sequence number, unbounded; the wire carries seq % 65536
    text: str                # e.g. "L 120 -40 2000 0"
    tag: object = None       # caller's bookkeeping (source line)
    data: bytes = b""
    sent_at: Optional[float] = None


@dataclass
class _Probe:
    wire: int                # its number on the wire, long executed
    covers: int              # host seq of the last line sent before it
    sent_at: float
    data: bytes


@dataclass
class LinkStats:
    lines_sent: int = 0
    retransmissions: int = 0
    resend_requests: int = 0
    timeouts: int = 0
    bytes_sent: int = 0
    bytes_received: int = 0
    garbled_replies: int = 0
    reconnects: int = 0
    mismatches: int = 0
    probes: int = 0


STATUS_SHARE = 0.05      # of the reply direction's bytes, for status polls while lines wait to go
WAIT_SHARE = 0.30        # ... while the board's queue is full or nothing waits
STATUS_BYTES = 50        # a status report on the wire, until one is seen
PROBE_BACK = 30000       # a probe's number lies this far below the last acknowledged line
PROBE_REPLY_BYTES = 20   # "ok N12345 Q0 *12345\r\n"


def status_period(interval: float, baud: int, share: float, report_bytes: int) -> float:
    """Seconds between status polls: `interval`, or longer if the reports
    would take more than `share` of the link's bytes (baud 0: unknown)."""
    if baud <= 0 or share <= 0:
        return interval
    return max(interval, report_bytes * 10.0 / (baud * share))


@dataclass
class BoardLink:
    port: Port
    rx_buffer: int = 64              # the board's receive ring (PROTOCOL: $I field B)
    ack_timeout: float = 0.5         # seconds before the window is sent again
    status_interval: float = 0.05    # '?' polling period while the link is up
    baud: int = 0                    # the line's baud rate, to hold polling to a share of it; 0: unknown
    status_share: float = STATUS_SHARE
    wait_share: float = WAIT_SHARE
    clock: Callable[[], float] = time.monotonic
    on_status: Optional[Callable[[Status], None]] = None
    on_ack: Optional[Callable[[Command], None]] = None
    on_error: Optional[Callable[[Command, Err], None]] = None
    on_banner: Optional[Callable[[str], None]] = None
    on_message: Optional[Callable[[str], None]] = None
    on_mismatch: Optional[Callable[[Status], None]] = None
    stats: LinkStats = field(default_factory=LinkStats)

    def __post_init__(self) -> None:
        self._next_seq = 0
        self._window: Deque[Command] = deque()   # unacknowledged, oldest first
        self._send_pos = 0                        # index in _window of the next to send
        self._credit_q = 0                        # free slots known from the last report
        self._credit_from = 0                     # first host seq that report did not cover
        self._inbuf = b""
        self._last_status_req = -1e9
        self._status_due = 0.0
        self._status_pending = False
        self._status_bytes = STATUS_BYTES
        self._probe: Optional[_Probe] = None
        self._last_probe = -1e9
        self.status: Optional[Status] = None
        self.acked = -1                           # highest host seq acknowledged
        self.last_sent = -1                       # highest host seq put on the wire
        self.paused = False                       # after attach(): wait for a status first

    # --- numbering ---------------------------------------------------------
    def sync(self, expected_wire_seq: int, queue_free: int) -> None:
        """Continue numbering where the board expects (after a banner: 0)."""
        base = self._next_seq - (self._next_seq % SEQ_MOD) + expected_wire_seq
        if base < self._next_seq:
            base += SEQ_MOD
        self._next_seq = base
        self.acked = base - 1
        self.last_sent = base - 1
        self.paused = False
        self._window.clear()
        self._send_pos = 0
        self._probe = None
        self._credit_q = queue_free
        self._credit_from = base

    def host_seq(self, wire: int) -> int:
        """The host number closest to the window for a 16-bit wire number."""
        return nearest_seq(self._window[0].seq if self._window else self._next_seq, wire)

    # --- queueing ----------------------------------------------------------
    def submit(self, text: str, tag: object = None) -> Command:
        cmd = Command(self._next_seq, text, tag, machine_line(self._next_seq, text))
        self._next_seq += 1
        self._window.append(cmd)
        return cmd

    @property
    def next_seq(self) -> int:
        """The wire number (0..65535) the next submitted command gets."""
        return self._next_seq % SEQ_MOD

    @property
    def next_host_seq(self) -> int:
        """The host number the next submitted command gets."""
        return self._next_seq

    @property
    def unsent(self) -> int:
        """Commands submitted but not yet put on the wire."""
        return len(self._window) - self._send_pos

    @property
    def outstanding(self) -> int:
        """Commands submitted but not acknowledged."""
        return len(self._window)

    def discard(self) -> None:
        """Forget everything not yet acknowledged (after an abort).  The numbers never sent are
        free again: the board's next number stays within half the 16-bit range of the host's,
        however many commands the aborted job had queued here."""
        self._window.clear()
        self._send_pos = 0
        self._next_seq = self.last_sent + 1

    def attach(self, port: Port) -> None:
        """Go on over a new port (the old one vanished): nothing is sent until
        a status report shows that the board still counts where it did."""
        self.port = port
        self.stats.reconnects += 1
        self._inbuf = b""
        self._send_pos = 0
        self._probe = None
        self.paused = True
        self.port.write(b"\n")          # ends whatever part-line the board holds
        self.request_status()

    def consistent(self, st: Status) -> bool:
        """The board's next expected number is one the link can explain:
        after everything acknowledged, at most one past the last line sent."""
        nxt = self.host_seq(st.next_seq)
        return self.acked + 1 <= nxt <= self.last_sent + 1

    def expected(self, st: Status) -> int:
        """The host number of the board's next expected line."""
        return self.host_seq(st.next_seq)

    def realtime(self, byte: bytes) -> None:
        self.port.write(byte)
        self.stats.bytes_sent += len(byte)

    def request_status(self) -> None:
        self.realtime(RT_STATUS)
        self._last_status_req = self.clock()
        self._status_pending = True

    # --- the pump ----------------------------------------------------------
    def poll(self) -> None:
        data = self.port.read(4096)
        if data:
            self.stats.bytes_received += len(data)
            self._inbuf += data
            *lines, self._inbuf = self._inbuf.split(b"\n")
            for raw in lines:
                self._handle(raw.decode("ascii", "replace").strip("\r"), len(raw) + 1)
            if len(self._inbuf) > 512:      # a line that never ends: noise
                self._inbuf = b""
        now = self.clock()
        self._check_timeout(now)
        self._transmit(now)
        waiting = self._send_pos < len(self._window)
        in_flight = self._send_pos > 0           # their oks will bring the board's free slots
        starved = waiting and self._credit() <= 0
        if starved and not in_flight:
            self._send_probe(now)
        if waiting and (in_flight or not starved):
            interval = status_period(self.status_interval, self.baud, self.status_share, self._status_bytes)
        else:
            interval = status_period(self.status_interval, self.baud, self.wait_share, self._status_bytes)
        wait = interval if not self._status_pending else max(interval, 0.3)
        if now - self._last_status_req >= wait:
            self.request_status()
        self._status_due = self._last_status_req + wait

    def quiet_for(self, now: float) -> float:
        """Seconds until the pump has something to do that no byte from the
        board brings: the next status request, or at once while a submitted
        command could go out (acknowledgements and status reports, which
        free the board's room, arrive on the port)."""
        if self._send_pos < len(self._window) and not self.paused and self._credit() > 0:
            return 0.0
        return max(0.0, self._status_due - now)

    def _credit(self) -> int:
        """Queue slots the board still has for lines not yet sent."""
        sent_after = sum(1 for c in islice(self._window, self._send_pos) if c.seq >= self._credit_from)
        return self._credit_q - sent_after

    def _in_flight_bytes(self) -> int:
        probe = len(self._probe.data) if self._probe else 0
        return probe + sum(len(c.data) for c in islice(self._window, self._send_pos))

    def _send_probe(self, now: float) -> None:
        """Ask for the board's free queue slots with a line it has executed."""
        if self.paused:
            return
        if self._probe is not None:
            if now - self._probe.sent_at <= self.ack_timeout:
                return
            self._probe = None                 # lost on the way, or its answer was
        floor = self.status_interval / 4 if self.baud <= 0 else 0.0
        spacing = status_period(floor, self.baud, self.wait_share, PROBE_REPLY_BYTES)
        if now - self._last_probe < spacing:
            return
        wire = (self.acked - PROBE_BACK) % SEQ_MOD
        probe = _Probe(wire, self.last_sent, now, machine_line(wire, ""))
        if len(probe.data) > self.rx_buffer - self._in_flight_bytes():
            return
        self.port.write(probe.data)
        self.stats.bytes_sent += len(probe.data)
        self.stats.probes += 1
        self._probe, self._last_probe = probe, now

    def _transmit(self, now: float) -> None:
        if self.paused:
            return
        budget = self.rx_buffer - self._in_flight_bytes()
        credit = self._credit()
        while self._send_pos < len(self._window) and credit > 0:
            cmd = self._window[self._send_pos]
            if len(cmd.data) > budget:
                break
            if cmd.sent_at is not None:
                self.stats.retransmissions += 1
            self.port.write(cmd.data)
            self.stats.bytes_sent += len(cmd.data)
            self.stats.lines_sent += 1
            self.last_sent = max(self.last_sent, cmd.seq)
            cmd.sent_at = now
            budget -= len(cmd.data)
            credit -= 1
            self._send_pos += 1

    def _check_timeout(self, now: float) -> None:
        if self._send_pos == 0 or self.paused:
            return
        oldest = self._window[0]
        if oldest.sent_at is not None and now - oldest.sent_at > self.ack_timeout:
            self.stats.timeouts += 1
            self._send_pos = 0                 # send the whole window again
            self.request_status()

    def _was_sent(self, seq: int) -> bool:
        """Host seq at or below the last line put on the wire."""
        return seq <= self.last_sent

    def _acknowledge_through(self, seq: int) -> None:
        while self._window and self._window[0].seq <= seq:
            cmd = self._window.popleft()
            self._send_pos = max(0, self._send_pos - 1)
            self.acked = max(self.acked, cmd.seq)
            if self.on_ack:
                self.on_ack(cmd)

    def _handle(self, line: str, size: int) -> None:
        reply = parse_reply(line)
        if reply is None:
            if line:
                self.stats.garbled_replies += 1
            return
        if isinstance(reply, Ok):
            if reply.seq is None:
                return
            probe = self._probe
            if probe is not None and reply.seq == probe.wire:
                # Q after every line sent before the probe
                if probe.covers + 1 >= self._credit_from:
                    self._credit_q, self._credit_from = reply.queue_free, probe.covers + 1
                self._probe = None
                return
            seq = self.host_seq(reply.seq)
            if not self._was_sent(seq):
                self.stats.garbled_replies += 1     # acknowledges what was never sent
                return
            self._acknowledge_through(seq)
            if seq + 1 >= self._credit_from:
                self._credit_q, self._credit_from = reply.queue_free, seq + 1
        elif isinstance(reply, Resend):
            self.stats.resend_requests += 1
            expected = self.host_seq(reply.expected)
            if expected > self.last_sent + 1:
                self.stats.garbled_replies += 1     # asks for what was never sent
                return
            self._acknowledge_through(expected - 1)
            self._send_pos = 0
        elif isinstance(reply, Err):
            if reply.seq is None:
                return
            seq = self.host_seq(reply.seq)
            self._acknowledge_through(seq - 1)
            if self._window and self._window[0].seq == seq:
                cmd = self._window.popleft()
                self._send_pos = max(0, self._send_pos - 1)
                self.acked = max(self.acked, seq)
                if self.on_error:
                    self.on_error(cmd, reply)
        elif isinstance(reply, Status):
            self._status_pending = False
            self._status_bytes = size
            if not self.consistent(reply):
                self.stats.mismatches += 1
                if self.on_mismatch:
                    self.on_mismatch(reply)     # the caller decides: sync() or give up
                if not self.consistent(reply):
                    return
            self.status = reply
            self.paused = False
            nxt = self.host_seq(reply.next_seq)
            self._acknowledge_through(nxt - 1)
            if nxt >= self._credit_from:
                self._credit_q, self._credit_from = reply.queue_free, nxt
            if self.on_status:
                self.on_status(reply)
        elif isinstance(reply, Banner):
            if self.on_banner:
                self.on_banner(reply.text)
        elif isinstance(reply, Message):
            if self.on_message:
                self.on_message(reply.text)
