"""The serial bridge's side of one board, without ROS.

BoardSession owns the port and the BoardLink, and decides what happens when
things go wrong:

- The port cannot be opened, or vanishes: the state is DISCONNECTED, the
  job is kept, and the port is opened again (same path) with growing
  back-off: up to `backoff_max` apart while a job waits for the port, up to
  `backoff_idle` apart when none does.  Each failed attempt goes to
  `log_error` with its reason and the next attempt's delay.  When it answers,
  the link holds every line until a status report shows where the board is.
  If the board still counts where it did, the job goes on from the board's
  `N`: what it had queued ran once, what it lost is sent again.  If the port
  stays away longer than `reconnect_timeout`, the job is aborted.
- The port opens but no status report comes (a board switched off, another
  device on the port, firmware at another baud rate): after
  `answer_timeout` this goes to `log_error` and `last_error`, saying whether
  any bytes came at all, and again at growing intervals while it lasts.
- The board was reset (its start-up banner, or two status reports in a row
  whose numbering the link cannot explain): the position is unknown until the origin is set
  again, and a running job is aborted, since a relative move cut short
  cannot be finished from an unknown place.
- Emergency stop, hold, resume and reset are real-time bytes (the last
  three a pair of the same byte, after a line end) that noise may destroy,
  or a half-received line may swallow: each is sent again until a status
  report shows it took effect.
- A job, once started, belongs to the session: it holds every command, so
  it runs to its end whatever its client does (stalls, loses the network,
  dies).  Only cancel(), an e-stop or reset, a board alarm or reset, or the
  port away longer than `reconnect_timeout` end it early.
- A pen change in a job (`M6 k`, protocol.py) goes to the board as a 1 ms
  dwell, and nothing after it is sent: once the board has done everything
  up to it and stands idle, the job waits (`Job.pen_change`) with the board
  held (`!!`: a panel shows "Paused", and nothing moves), until
  continue_job() (the bridge's resume) or the board's own pause / resume
  key, which the session sees as the hold ending.  Cancel, e-stop and reset
  end it there as anywhere else; the counts go on across it as if it were
  one command, so a journal resume finds its place.

The caller runs `pump()` in a loop on one thread; everything else may be
called from other threads.  Waits happen outside the lock.
"""
from __future__ import annotations

import re
import threading
import time
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple

from .board_link import BoardLink, Command, Port
from .command_store import CommandStore
from .protocol import (PEN_CHANGE_STANDIN, RT_ESTOP, RT_HOLD, RT_RESET, RT_RESUME, SEQ_MOD, Err, Status,
                       pen_change_number)

QUEUE_SIZE = 6
FEED_AHEAD = 32          # a job's commands in the link not yet sent: enough for any burst of credit
DISCONNECTED, CONNECTING, CONNECTED = "disconnected", "connecting", "connected"


@dataclass
class SessionConfig:
    ack_timeout: float = 0.5          # seconds before unacknowledged lines are sent again
    status_interval: float = 0.04     # '?' polling period
    baud: int = 0                     # the line's baud rate: polling is held to a share of it (board_link.py)
    reconnect_timeout: float = 30.0   # a job waits this long for a vanished port
    backoff_min: float = 0.1          # first wait before opening the port again
    backoff_max: float = 2.0          # longest wait while a job waits for the port
    backoff_idle: float = 10.0        # longest wait when no job does
    rt_retry: float = 0.15            # send an unconfirmed real-time byte again after this
    rt_timeout: float = 3.0           # give up confirming it
    answer_timeout: float = 5.0       # an open port without a status report this long: say so


@dataclass
class JobResult:
    success: bool
    message: str
    executed: int       # commands the board started
    completed: int      # commands the board finished


@dataclass
class Job:
    """A job's commands stay in `source` (the lists given to start_job, kept, not copied) and
    go to the link a few at a time (FEED_AHEAD unsent at most), numbered first, first + 1...:
    the bridge's memory and the time to the first step do not grow with a Command per line."""
    source: Tuple[List[str], List[int]] = ([], [])  # the whole job: texts, and each one's program line
    error: Optional[str] = None         # set: the job failed, the board is being stopped
    interrupted: bool = False           # it ended inside a command (stop, reset)
    acknowledged: int = 0
    started: int = 0                    # from the last status that could be trusted
    status_at_last_ack: int = 0
    disconnected_at: Optional[float] = None
    result: Optional[JobResult] = None
    expected_end: Optional[tuple] = None  # where the pen must be once every command ran
    summing: Optional[threading.Thread] = None  # works out expected_end beside a big job
    pen_change: Optional[int] = None    # the job waits at this pen change (M6 k) for continue_job()
    change_held: bool = False           # ... and the board has been seen held for it
    first: int = 0                      # the link's number of command 0
    submitted: int = 0                  # commands handed to the link
    part_end: int = 0                   # the current part: commands up to and including its pen change

    @property
    def total(self) -> int:
        return len(self.source[0])

    @property
    def last(self) -> int:
        return self.first + self.submitted - 1

    def owns(self, seq: int) -> bool:
        """The link's number `seq` is one of this job's commands."""
        return self.submitted > 0 and self.first <= seq <= self.last

    def line_of(self, index: int) -> int:
        if not self.submitted:
            return 0
        return int(self.source[1][min(max(index, 0), self.submitted - 1)] or 0)


@dataclass
class _Realtime:
    wire: bytes                       # ESC, or the pair of !, ~ or Ctrl-X
    check: Callable[[Status], bool]
    sent_at: float
    deadline: float
    done: bool = False
    failed: bool = False


def displacement(commands: List[str]) -> Optional[tuple]:
    """Sum of the moves (dx, dy) of board commands, in steps; None when a
    line follow (F) is among them, which ends where the line takes the pen."""
    x = y = 0
    for text in commands:
        parts = text.split()       # (a pen change, M6 k, moves nothing)
        if parts and parts[0] == "F":
            return None
        if parts and parts[0] in ("L", "C", "A") and len(parts) >= 3:
            x, y = x + int(parts[1]), y + int(parts[2])
    return x, y


SUMMED_AT_ONCE = 20000    # commands whose moves start_job sums itself; a bigger job's are summed beside it
# A pen change as pen_change_number reads it, in a CommandStore's text (a bridge's job's: ASCII,
# spaces its only blanks).
_PEN_CHANGE_LINE = re.compile(r"^M6 +[0-9]+ *$", re.MULTILINE)


def _expect_end(job: Job, at: Tuple[int, int]) -> Optional[threading.Thread]:
    """Set job.expected_end from `at` and the job's moves: at once for a small job; for a big one on a
    thread, returned, so that its first line does not wait a second for a million commands' sum."""
    def work() -> None:
        moves = displacement(job.source[0])
        if moves is not None:
            job.expected_end = (at[0] + moves[0], at[1] + moves[1])
    if len(job.source[0]) <= SUMMED_AT_ONCE:
        work()
        return None
    thread = threading.Thread(target=work, name="job end", daemon=True)
    thread.start()
    return thread


def started_count(first: int, count: int, last_started: int) -> int:
    """How many of `count` commands numbered from `first` the board has started, `last_started`
    being the host number of its status's S (the last one started).  In host numbers, which do
    not wrap: a report from before the job (S below `first`) counts none, whatever the job's
    length."""
    return min(max(last_started - first + 1, 0), count)


class BoardSession:
    def __init__(self, open_port: Callable[[], Port], config: SessionConfig = SessionConfig(),
                 clock: Callable[[], float] = time.monotonic,
                 on_status: Optional[Callable[[Status], None]] = None,
                 on_change: Optional[Callable[[], None]] = None,
                 log: Callable[[str], None] = lambda text: None,
                 log_error: Callable[[str], None] = lambda text: None) -> None:
        self._open_port = open_port
        self.config = config
        self.clock = clock
        self.on_status = on_status
        self.on_change = on_change          # connection state or error changed
        self.log = log
        self.log_error = log_error
        self.open_failures = 0              # failed attempts since the port was last open
        self.lock = threading.RLock()
        self._cond = threading.Condition(self.lock)
        self.port: Optional[Port] = None
        self.link: Optional[BoardLink] = None
        self.connection = DISCONNECTED
        self.position_known = True          # the power-on origin, until a reset is seen
        self.last_error = ""
        self.firmware = ""
        self.job: Optional[Job] = None
        self.status_count = 0
        self._synced = False
        self._resync = False
        self._rt: Optional[_Realtime] = None
        self._backoff = config.backoff_min
        self._next_open = 0.0
        self._origin_cmd: Optional[Command] = None
        self._origin_result: Optional[str] = None
        self.board_resets = 0
        self._silent_since = 0.0            # when the port opened (CONNECTING)
        self._silence_next = 0.0            # when to say again that the board does not answer
        self._silence_error = ""
        self._bytes_at_open = 0
        self._suspect_seq: Optional[int] = None   # a status's N the link could not explain, once

    # --- the pump (I/O thread) ------------------------------------------------------
    def pump(self) -> None:
        with self.lock:
            now = self.clock()
            if self.port is None:
                self._expire_disconnected_job(now)
                if now < self._next_open:
                    return
                self._connect(now)
                if self.port is None:
                    return
            try:
                self._feed()
                self.link.poll()
                self._retry_realtime(self.clock())
            except Exception as exc:  # serial.SerialException, OSError: the port is gone
                self._lost(exc)
                return
            if self.connection == CONNECTING:
                self._check_silence(self.clock())

    def quiet_for(self, most: float) -> float:
        """Seconds the pump may wait for the port, at most `most`."""
        with self.lock:
            if self.port is None or self.link is None:
                return most
            return min(most, self.link.quiet_for(self.clock()))

    def _connect(self, now: float) -> None:
        try:
            port = self._open_port()
        except Exception as exc:
            self._open_failed(now, exc)
            return
        self.open_failures = 0
        self.port = port
        self.connection = CONNECTING
        self._silent_since = now
        self._silence_next = now + self.config.answer_timeout
        if self.link is None:
            self.link = BoardLink(port, ack_timeout=self.config.ack_timeout,
                                  status_interval=self.config.status_interval,
                                  baud=self.config.baud, clock=self.clock,
                                  on_status=self._on_status, on_error=self._on_error,
                                  on_banner=self._on_banner, on_message=self._on_message,
                                  on_ack=self._on_ack, on_mismatch=self._on_mismatch)
            self.link.request_status()
        else:
            self.link.attach(port)
        self._bytes_at_open = self.link.stats.bytes_received
        self.log("port open, waiting for the board's status")
        self._changed()

    def _check_silence(self, now: float) -> None:
        """Say that the open port brings no status report, and what came instead."""
        if now < self._silence_next:
            return
        waited = now - self._silent_since
        self._silence_next = now + min(max(2.0 * waited, self.config.answer_timeout), 60.0)
        got = self.link.stats.bytes_received - self._bytes_at_open
        baud = f" at {self.config.baud} baud" if self.config.baud else ""
        if got == 0:
            text = (f"no answer from the board in {waited:.0f} s: nothing came back on the port{baud}; "
                    f"is the board powered and connected to this port?")
        else:
            text = (f"no status report from the board in {waited:.0f} s: {got} bytes came back on the port{baud}, "
                    f"none of them a line the firmware sends; is the firmware built for this baud rate "
                    f"(the default image talks at 9600, one built with BAUD=115200 at 115200)?")
        self._silence_error = text
        self._set_error(text)
        self.log_error(text)

    def _open_failed(self, now: float, exc: Exception) -> None:
        job = self.job
        waiting = job is not None and job.result is None
        wait = self._backoff
        self._next_open = now + wait
        self._backoff = min(self._backoff * 2, self.config.backoff_max if waiting else self.config.backoff_idle)
        self.open_failures += 1
        self._set_error(str(exc))
        self.log_error(f"{exc} (attempt {self.open_failures}; trying again in {wait:.1f} s)")

    def _lost(self, exc: Exception) -> None:
        self.log(f"serial link lost: {exc}")
        if self.port is not None:
            try:
                self.port.close()
            except Exception:
                pass
        self.port = None
        self.connection = DISCONNECTED
        self._backoff = self.config.backoff_min
        self._next_open = self.clock() + self._backoff
        if self._rt is not None and not self._rt.done:
            self._rt.failed = True
            self._rt = None
        job = self.job
        if job is not None and job.result is None and job.disconnected_at is None:
            job.disconnected_at = self.clock()
        self._set_error(f"disconnected: {exc}")
        self._cond.notify_all()

    def _expire_disconnected_job(self, now: float) -> None:
        job = self.job
        if job is None or job.result is not None or job.disconnected_at is None:
            return
        if now - job.disconnected_at > self.config.reconnect_timeout:
            started = job.started
            self._finish(job, False, f"port lost for more than {self.config.reconnect_timeout:g} s: "
                         f"job aborted after line {job.line_of(started - 2)}; the board may have "
                         f"finished up to {min(started + QUEUE_SIZE, job.submitted)} commands",
                         started, max(started - 1, 0))
            self.link.discard()
            self._resync = True

    # --- link callbacks (lock held) ----------------------------------------------
    def _on_mismatch(self, st: Status) -> None:
        if not self._synced:
            self._sync(st)          # first contact: take the board's numbering
            return
        # A board reset whose banner was lost, or a damaged report whose checksum still matched
        # (one damaged reply in 65536 does: at 2 % byte noise a few in a 100k-command job, each
        # aborting it with the position lost).  Believed when the next report says the same.
        if self._suspect_seq != st.next_seq:
            self._suspect_seq = st.next_seq
            self.link.request_status()
            return
        self._suspect_seq = None
        self._board_reset(f"board reset (it expects line {st.next_seq}, the bridge had sent "
                          f"up to {self.link.last_sent % SEQ_MOD})")
        self._sync(st)

    def _sync(self, st: Optional[Status], expected: int = 0, free: int = QUEUE_SIZE) -> None:
        if st is not None:
            expected, free = st.next_seq, st.queue_free
        self.link.sync(expected, free)
        self.link.submit("")        # an empty numbered line: after it, N = 0 means a reset
        self._synced = True
        self._resync = False

    def _on_status(self, st: Status) -> None:
        self.status_count += 1
        self._suspect_seq = None
        if not self._synced:
            self._sync(st)
        if self.connection != CONNECTED:
            self.connection = CONNECTED
            if self._silence_error and self.last_error == self._silence_error:
                self._set_error("")
            self._silence_error = ""
            job = self.job
            if job is not None and job.result is None and job.disconnected_at is not None:
                job.disconnected_at = None
                nxt = self.link.expected(st)
                self.log(f"port back: the board expects command {nxt - job.first + 1} of the job; "
                         f"going on from there")
                self._set_error(f"reconnected; job resumed at line {job.line_of(nxt - job.first)}")
            self._changed()
        rt = self._rt
        if rt is not None and not rt.done and rt.check(st):
            rt.done = True
            self._rt = None
        if self._resync and self._rt is None and (self.job is None or self.job.result is not None):
            self._sync(st)
        job = self.job
        if job is not None and job.submitted and job.result is None:
            job.started = max(job.started, started_count(job.first, job.submitted,
                                                         self.link.host_seq(st.seq)))
            if st.state == "Alarm" and job.error is None:
                self._fail(job, f"board alarm (code {st.alarm})", stop=False)
            if job.pen_change is not None and job.error is None:
                self._watch_pen_change(job, st)
            self._check_job_end(job, st)
        if self.on_status:
            self.on_status(st)
        self._cond.notify_all()

    def _on_ack(self, cmd: Command) -> None:
        job = self.job
        if job is not None and job.result is None and job.owns(cmd.seq):
            job.acknowledged += 1
            job.status_at_last_ack = self.status_count
        if cmd is self._origin_cmd:
            self.position_known = True
            self._origin_result = ""
            self._set_error("")
            self._cond.notify_all()

    def _on_error(self, cmd: Command, err: Err) -> None:
        text = f"board refused '{cmd.text}': E{err.code} {err.text}"
        if cmd is self._origin_cmd:
            self._origin_result = text
            self._cond.notify_all()
            return
        self._set_error(text)
        job = self.job
        if job is not None and job.result is None and job.owns(cmd.seq):
            self._fail(job, f"{text} (line {cmd.tag})", stop=True)

    def _on_banner(self, text: str) -> None:
        self.firmware = text
        if self._synced:
            self._board_reset("board reset (start-up banner)")
        self._sync(None, 0, QUEUE_SIZE)

    def _on_message(self, text: str) -> None:
        if text.startswith("[alarm"):
            self._set_error(text.strip("[]"))
            job = self.job
            if job is not None and job.result is None and job.error is None:
                self._fail(job, f"board alarm: {text.strip('[]')}", stop=False)

    def _board_reset(self, why: str) -> None:
        self.board_resets += 1
        self.position_known = False
        self.log(f"{why}: position unknown until the origin is set")
        self._set_error(f"{why}: position unknown until set_origin")
        self._rt = None
        job = self.job
        if job is not None and job.result is None:
            started = job.started
            self._finish(job, False, f"{why} during the job, after line {job.line_of(started - 2)}: "
                         f"job aborted, the position is unknown; set the origin and start again",
                         started, max(started - 1, 0))
        self.link.discard()

    def wait_connected(self, timeout: float) -> bool:
        """Until the board has answered with a status report (CONNECTED), at
        most `timeout` seconds; whether it has."""
        with self._cond:
            return self._cond.wait_for(lambda: self.connection == CONNECTED, timeout)

    # --- jobs ---------------------------------------------------------------------
    def start_job(self, commands: List[str], lines: List[int], need_origin: bool = True) -> Job:
        """Queue a job; its `result` is set when it ends (see wait_job).  The homing cycle's
        moves (need_origin False) run where the position is not known yet."""
        with self.lock:
            if self.job is not None and self.job.result is None:
                raise RuntimeError("another job is running")
            why = None
            st = self.link.status if self.link else None
            if self.connection != CONNECTED or st is None:
                why = "board not connected"
            elif need_origin and not self.position_known:
                why = "position unknown after a board reset: set the origin first"
            elif st.state == "Alarm":
                why = "board in alarm: reset it first"
            elif self._rt is not None:
                why = "board busy with a stop or reset"
            if why:
                job = Job()
                job.result = JobResult(False, why, 0, 0)
                return job
            if len(lines) != len(commands):
                raise ValueError(f"{len(commands)} commands but {len(lines)} line numbers")
            if self._resync:
                self._sync(st)
            job = Job(source=(commands, lines), first=self.link.next_host_seq)
            job.part_end = self._part_end(job, 0)
            self._feed_job(job)
            if st.state == "Idle" and st.queue_free == QUEUE_SIZE:
                job.summing = _expect_end(job, (st.x, st.y))
            self.job = job
            return job

    @staticmethod
    def _part_end(job: Job, k: int) -> int:
        """The end of the part that begins at command k: just after its next pen change."""
        texts = job.source[0]
        if isinstance(texts, CommandStore):
            found = texts.find(_PEN_CHANGE_LINE, k)
            return len(texts) if found is None else found + 1
        while k < len(texts):
            k += 1
            if texts[k - 1].startswith("M6") and pen_change_number(texts[k - 1]) is not None:
                break
        return k

    def _feed(self) -> None:
        job = self.job
        if job is not None and job.result is None and job.error is None and job.submitted < job.part_end:
            self._feed_job(job)

    def _feed_job(self, job: Job) -> None:
        """Hand the link the job's next commands of the current part, up to FEED_AHEAD unsent."""
        texts, lines = job.source
        link = self.link
        room = FEED_AHEAD - link.unsent
        while room > 0 and job.submitted < job.part_end:
            k = job.submitted
            text = texts[k]
            if text.startswith("M6") and pen_change_number(text) is not None:
                text = PEN_CHANGE_STANDIN
            link.submit(text, tag=lines[k])
            job.submitted += 1
            room -= 1

    def continue_job(self) -> Tuple[bool, str]:
        """The operator has put in the next pen: the job waiting at a pen change goes on."""
        with self.lock:
            job = self.job
            if job is None or job.result is not None or job.pen_change is None:
                return False, "no job waits for a pen change"
            self._request_rt(RT_RESUME, _not_held)        # the hold of the pen change (lines queue meanwhile)
            return True, self._go_on(job, "the new pen is in")

    def _go_on(self, job: Job, why: str) -> str:
        change = job.pen_change
        job.pen_change, job.change_held = None, False
        job.status_at_last_ack = self.status_count     # done again only after a status that follows
        job.part_end = self._part_end(job, job.submitted)
        self._feed_job(job)
        self.log(f"pen change {change + 1}: {why}, the job goes on")
        self._changed()
        return f"pen change {change + 1} done: the job goes on"

    def _watch_pen_change(self, job: Job, st: Status) -> None:
        """At a pen change: the board's hold taken, then left with its own pause / resume key."""
        if st.state == "Hold":
            job.change_held = True
        elif job.change_held and st.state == "Idle" and self._rt is None:
            self._go_on(job, "resumed on the board's panel")

    def wait_job(self, job: Job, timeout: float) -> Optional[JobResult]:
        with self._cond:
            self._cond.wait_for(lambda: job.result is not None, timeout)
            return job.result

    def progress(self, job: Job) -> tuple:
        """(acknowledged, started, line of the command executing)."""
        with self.lock:
            return job.acknowledged, job.started, job.line_of(job.started - 1)

    def _fail(self, job: Job, why: str, stop: bool) -> None:
        """The job cannot go on: discard what is unsent, stop the board (hold,
        then reset, keeping the position) unless it already stopped."""
        if job.error is not None:
            return
        job.error = why
        job.interrupted = True
        self._set_error(why)
        self.link.discard()
        self._resync = True
        if stop:
            self._request_rt(RT_HOLD, _held_still())

    def _check_job_end(self, job: Job, st: Status) -> None:
        link = self.link
        at_rest = st.state in ("Idle", "Alarm") and st.queue_free == QUEUE_SIZE
        if job.error is not None:
            if st.state == "Hold" and self._rt is None:
                self._request_rt(RT_RESET, _reset_done)      # held still: now flush the queue
                return
            if at_rest and self._rt is None:
                self._finish(job, False, job.error, job.started, max(job.started - 1, 0))
            return
        if (link.outstanding == 0 and self.status_count > job.status_at_last_ack
                and st.state == "Idle" and st.queue_free == QUEUE_SIZE):
            if job.submitted < job.part_end:
                return                      # the pump feeds the rest of the part
            if job.submitted < job.total:
                if job.pen_change is None:
                    job.pen_change = pen_change_number(job.source[0][job.submitted - 1])
                    self._request_rt(RT_HOLD, _held)
                    self.log(f"pen change {job.pen_change + 1}: the job waits, pen up and the board held, for "
                             f"the next pen (resume, or the board's pause / resume key, goes on)")
                    self._changed()
                return
            if job.summing is not None:
                job.summing.join()
            if job.expected_end is not None and (st.x, st.y) != job.expected_end:
                # Every line was acknowledged, yet the pen is elsewhere: a line damaged on
                # the way passed the checksum and ran as something else.
                self._finish(job, False, f"the board ended at X{st.x} Y{st.y}, not at X{job.expected_end[0]} "
                             f"Y{job.expected_end[1]}: a damaged line passed its checksum",
                             job.total, job.total)
                return
            self._finish(job, True, "done", job.total, job.total)

    def _finish(self, job: Job, success: bool, message: str, executed: int, completed: int) -> None:
        job.result = JobResult(success, message, executed, completed)
        if not success:
            self.log(f"job ended: {message}")
            self._resync = True
        self._cond.notify_all()

    def cancel(self, job: Job, timeout: float = 10.0) -> Optional[JobResult]:
        """Stop a job where it is (hold, then reset: the position is kept)."""
        with self.lock:
            if job.result is None:
                self._fail(job, "canceled", stop=True)
        return self.wait_job(job, timeout)

    # --- real-time commands ----------------------------------------------------------
    def _request_rt(self, wire: bytes, check: Callable[[Status], bool]) -> _Realtime:
        now = self.clock()
        rt = _Realtime(wire, check, now, now + self.config.rt_timeout)
        self._rt = rt
        self._send_rt(rt)
        return rt

    def _send_rt(self, rt: _Realtime) -> None:
        # ESC acts anywhere; the pairs only between lines, so end any line first.
        self.link.port.write(rt.wire if rt.wire == RT_ESTOP else b"\n" + rt.wire)
        rt.sent_at = self.clock()
        self.link.request_status()

    def _retry_realtime(self, now: float) -> None:
        rt = self._rt
        if rt is None:
            return
        if now > rt.deadline:
            rt.failed = True
            self._rt = None
            self._set_error(f"the board did not confirm real-time command {rt.wire!r}")
            return
        if now - rt.sent_at > self.config.rt_retry:
            self._send_rt(rt)

    def realtime(self, what: str, timeout: Optional[float] = None) -> tuple:
        """estop, hold, resume or reset, confirmed by a status report:
        (success, message)."""
        wire, check = {"estop": (RT_ESTOP, _in_alarm), "hold": (RT_HOLD, _held),
                       "resume": (RT_RESUME, _not_held), "reset": (RT_RESET, _reset_done)}[what]
        with self.lock:
            if self.port is None or self.link is None:
                return False, "board not connected"
            job = self.job
            if what == "resume" and job is not None and job.result is None and job.pen_change is not None:
                return self.continue_job()           # at a pen change, resume is "the next pen is in"
            if what in ("estop", "reset"):
                if job is not None and job.result is None:
                    job.error = job.error or ("emergency stop" if what == "estop" else "reset")
                    job.interrupted = True
                    self._set_error(job.error)
                self.link.discard()
                self._resync = True
            if what == "reset":
                self._set_error("")
            rt = self._request_rt(wire, check)
        with self._cond:
            self._cond.wait_for(lambda: rt.done or rt.failed or self._rt is not rt,
                                self.config.rt_timeout if timeout is None else timeout)
        if rt.done:
            return True, {"estop": "emergency stop", "hold": "feed hold", "resume": "resumed",
                          "reset": "reset"}[what]
        return False, f"{what} sent but not confirmed by the board"

    def set_origin(self, timeout: float = 3.0) -> tuple:
        """Make the current position the origin (a numbered `H`): (success, message)."""
        with self.lock:
            if self.connection != CONNECTED:
                return False, "board not connected"
            if self.job is not None and self.job.result is None:
                return False, "a job is running"
            if self._resync and self.link.status is not None:
                self._sync(self.link.status)
            self._origin_result = None
            self._origin_cmd = self.link.submit("H")
        with self._cond:
            self._cond.wait_for(lambda: self._origin_result is not None, timeout)
            result = self._origin_result
            if result == "":
                # A job started next plans its end from the last status: wait for one at the new origin.
                reports = self.status_count
                self._cond.wait_for(lambda: self.status_count > reports and self.link.status is not None
                                    and (self.link.status.x, self.link.status.y) == (0, 0), timeout)
        if result is None:
            return False, "the board did not answer"
        return (True, "origin set") if result == "" else (False, result)

    # --- misc --------------------------------------------------------------------
    def _set_error(self, text: str) -> None:
        if text != self.last_error:
            self.last_error = text
            self._changed()

    def _changed(self) -> None:
        if self.on_change:
            self.on_change()

    def close(self) -> None:
        with self.lock:
            if self.port is not None:
                try:
                    self.port.close()
                except Exception:
                    pass
            self.port = None


def _in_alarm(st: Status) -> bool:
    return st.state == "Alarm"


def _held(st: Status) -> bool:
    return st.state in ("Hold", "Alarm")


def _not_held(st: Status) -> bool:
    return st.state != "Hold"


def _reset_done(st: Status) -> bool:
    return st.state == "Idle" and st.queue_free == QUEUE_SIZE


def _held_still() -> Callable[[Status], bool]:
    """Hold confirmed once two reports in a row show the pen not moving."""
    last: List[Status] = []

    def check(st: Status) -> bool:
        if st.state not in ("Hold", "Idle", "Alarm"):
            last.clear()
            return False
        still = bool(last) and (last[-1].x, last[-1].y) == (st.x, st.y)
        last[:] = [st]
        return still
    return check
