"""What the serial bridge reports besides the position, without ROS: the
planned path of a job from its board commands, the pen's trace (samples,
step rate, thinning) and the diagnosis of the link
and the board (OK, WARN, ERROR as REP-107 describes).

nodes/telemetry.py turns these into messages; everything here is in the
board's units (steps, or on a machine whose motors are not its axes the
pen's mm times steps_per_mm) and testable without ROS.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, Iterator, List, Optional, Sequence, Tuple

MAX_PATH_POSES = 1500           # older poses are thinned out beyond this
MAX_PLANNED_POSES = 20000       # poses of a planned path at most (decimate)
STALE_AFTER = 1.0               # s without a status report: WARN
ARC_STEP = 0.1                  # rad between points of an arc in the planned path

OK, WARN, ERROR, STALE = b"\x00", b"\x01", b"\x02", b"\x03"   # diagnostic_msgs/DiagnosticStatus levels


# --- the planned path from board commands -------------------------------------------------

@dataclass(frozen=True)
class PathPoint:
    x: float           # steps
    y: float
    pen_down: bool


def _arc(x: float, y: float, dx: int, dy: int, i: int, j: int, cw: bool) -> List[Tuple[float, float]]:
    cx, cy = x + i, y + j
    r = math.hypot(i, j)
    a0 = math.atan2(-j, -i)
    a1 = math.atan2(y + dy - cy, x + dx - cx)
    sweep = ((a0 - a1) if cw else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
    n = max(2, int(math.ceil(sweep / ARC_STEP)))
    sign = -1.0 if cw else 1.0
    pts = [(cx + r * math.cos(a0 + sign * sweep * k / n), cy + r * math.sin(a0 + sign * sweep * k / n))
           for k in range(1, n)]
    return pts + [(x + dx, y + dy)]


def planned_points(commands: Iterable[str], start: Tuple[int, int], pen_down: bool = False) -> List[PathPoint]:
    """Where a job's board commands (PROTOCOL.md: L, C, A, P, D) take the pen, in steps."""
    return list(iter_planned_points(commands, start, pen_down))


def iter_planned_points(commands: Iterable[str], start: Tuple[int, int],
                        pen_down: bool = False) -> Iterator[PathPoint]:
    x, y = float(start[0]), float(start[1])
    yield PathPoint(x, y, pen_down)
    for text in commands:
        parts = text.replace(",", " ").split()
        if not parts:
            continue
        verb, args = parts[0], [int(a) for a in parts[1:]]
        if verb == "P" and args:
            pen_down = args[0] == 1
        elif verb == "L" and len(args) >= 2:
            x, y = x + args[0], y + args[1]
            yield PathPoint(x, y, pen_down)
        elif verb in ("C", "A") and len(args) >= 4:
            for px, py in _arc(x, y, args[0], args[1], args[2], args[3], verb == "C"):
                yield PathPoint(px, py, pen_down)
            x, y = x + args[0], y + args[1]


ToPen = Callable[[Tuple[float, float]], Tuple[float, float]]


def decimate(points: Callable[[], Iterable[PathPoint]], limit: int = MAX_PLANNED_POSES) -> List[PathPoint]:
    """At most `limit` of the points (`points()` gives them, each time afresh), as the eye sees them.

    All of them if they are few enough.  Else first what cannot be seen: a point nearer than a
    2000th of the drawing's extent (a pixel of a large view) to the last one kept goes, unless the
    pen goes up or down there or it is the last.  If that is still too many (a dense drawing: a
    stippling, a random walk), every k-th of those is kept, with the pen's changes and the last."""
    count, lo_x, lo_y, hi_x, hi_y = 0, math.inf, math.inf, -math.inf, -math.inf
    for p in points():
        count += 1
        lo_x, lo_y, hi_x, hi_y = min(lo_x, p.x), min(lo_y, p.y), max(hi_x, p.x), max(hi_y, p.y)
    if count <= limit:
        return list(points())
    near = math.hypot(hi_x - lo_x, hi_y - lo_y) / 2000.0
    kept: List[PathPoint] = []
    last: Optional[PathPoint] = None
    for k, p in enumerate(points()):
        if last is None or p.pen_down != last.pen_down or k == count - 1 \
                or abs(p.x - last.x) + abs(p.y - last.y) >= near:
            kept.append(p)
            last = p
    if len(kept) <= limit:
        return kept

    def change(k: int) -> bool:          # the pen goes down or up here, or at the next point
        return (k > 0 and kept[k].pen_down != kept[k - 1].pen_down) or \
            (k + 1 < len(kept) and kept[k + 1].pen_down != kept[k].pen_down)
    changes = sum(1 for k in range(len(kept)) if change(k))
    stride = -(-len(kept) // max(limit - changes - 1, limit // 4))
    out = [p for k, p in enumerate(kept) if k % stride == 0 or k == len(kept) - 1 or change(k)]
    return out if len(out) <= limit else out[:limit - 1] + [kept[-1]]     # more strokes than poses


def planned_pen_points(commands: Sequence[str], start: Tuple[int, int], pen_down: bool,
                       end: Optional[Tuple[int, int]], to_pen: ToPen,
                       limit: int = MAX_PLANNED_POSES) -> List[PathPoint]:
    """planned_points from the motor position `start`, shifted to end at the
    motor position `end` when the job knows it, then carried into pen
    coordinates: board commands move the motors, so their sums are motor steps.
    At most `limit` of them (decimate)."""
    pts = decimate(lambda: iter_planned_points(commands, start, pen_down), limit)
    if end is not None:        # start where the job ends less its moves
        dx, dy = end[0] - pts[-1].x, end[1] - pts[-1].y
        pts = [replace(p, x=p.x + dx, y=p.y + dy) for p in pts]
    out = []
    for p in pts:
        x, y = to_pen((p.x, p.y))
        out.append(replace(p, x=x, y=y))
    return out


# --- step rate and the pen's trace ----------------------------------------------------------

@dataclass(frozen=True)
class Sample:
    t: float           # monotonic seconds
    x: float           # pen coordinates: steps of a cartesian machine, pen mm * steps_per_mm
    y: float
    pen_down: bool


def step_rate(a: Sample, b: Sample) -> float:
    """Steps per second between two reports (point-by-point: |dx| + |dy| pulses)."""
    dt = b.t - a.t
    return (abs(b.x - a.x) + abs(b.y - a.y)) / dt if dt > 0 else 0.0


def thin(samples: List[Sample], limit: int = MAX_PATH_POSES) -> List[Sample]:
    """At most `limit` samples: every second one of the older half goes."""
    if len(samples) <= limit:
        return samples
    half = len(samples) // 2
    return samples[:half:2] + samples[half:]


# --- diagnostics -------------------------------------------------------------------------------

@dataclass(frozen=True)
class LinkCounters:
    bytes_sent: int = 0
    bytes_received: int = 0
    lines_sent: int = 0
    retransmissions: int = 0
    resend_requests: int = 0
    timeouts: int = 0
    garbled_replies: int = 0

    @staticmethod
    def of(stats) -> "LinkCounters":
        """From board_link.LinkStats (or anything with the same fields)."""
        return LinkCounters(**{k: int(getattr(stats, k, 0)) for k in LinkCounters.__dataclass_fields__})

    @property
    def errors(self) -> int:
        return self.resend_requests + self.timeouts + self.garbled_replies


@dataclass(frozen=True)
class BridgeSnapshot:
    """What the diagnostics are made from, at one moment."""
    port: str = ""
    connected: bool = False
    ever_connected: bool = False
    lost_reason: str = ""
    seconds_since_status: float = math.inf
    board_state: str = ""            # Idle, Run, Hold, Alarm
    alarm: int = 0
    queue_free: int = 0
    queue_size: int = 6
    underruns: int = 0
    step_rate: float = 0.0           # steps/s, latest
    peak_step_rate: float = 0.0
    firmware: str = ""
    last_error: str = ""
    counters: LinkCounters = field(default_factory=LinkCounters)
    errors_in_last_period: int = 0    # link errors since the previous diagnostics message
    underruns_in_last_period: int = 0


@dataclass(frozen=True)
class Diagnosis:
    name: str
    level: bytes
    message: str
    values: Tuple[Tuple[str, str], ...]


def diagnose_link(s: BridgeSnapshot) -> Diagnosis:
    """The serial link: ERROR when the port is gone, WARN when it is noisy or silent."""
    c = s.counters
    values = (("port", s.port), ("connected", str(s.connected)),
              ("bytes sent", str(c.bytes_sent)), ("bytes received", str(c.bytes_received)),
              ("lines sent", str(c.lines_sent)), ("retransmissions", str(c.retransmissions)),
              ("resend requests", str(c.resend_requests)), ("ack timeouts", str(c.timeouts)),
              ("garbled replies", str(c.garbled_replies)),
              ("link errors in the last period", str(s.errors_in_last_period)),
              ("seconds since the last status", f"{s.seconds_since_status:.2f}"
               if math.isfinite(s.seconds_since_status) else "never"))
    if not s.connected:
        why = s.lost_reason or ("port not open yet" if not s.ever_connected else "disconnected")
        return Diagnosis("link", ERROR, f"no serial link: {why}", values)
    if s.seconds_since_status > STALE_AFTER:
        return Diagnosis("link", WARN, f"no status from the board for {s.seconds_since_status:.1f} s", values)
    if s.errors_in_last_period:
        return Diagnosis("link", WARN, f"{s.errors_in_last_period} link errors (lines resent)", values)
    return Diagnosis("link", OK, "connected", values)


def diagnose_board(s: BridgeSnapshot) -> Diagnosis:
    """The board: ERROR in alarm, WARN when its queue ran dry or it was reset under a job."""
    used = s.queue_size - s.queue_free
    values = (("state", s.board_state or "unknown"), ("firmware", s.firmware or "unknown (no banner since connecting)"),
              ("queue free", str(s.queue_free)), ("queue size", str(s.queue_size)),
              ("queue fill %", f"{100.0 * used / s.queue_size:.0f}" if s.queue_size else "0"),
              ("step rate (steps/s)", f"{s.step_rate:.0f}"), ("peak step rate (steps/s)", f"{s.peak_step_rate:.0f}"),
              ("underruns", str(s.underruns)), ("alarm", str(s.alarm)), ("last error", s.last_error))
    if not s.connected or not s.board_state:
        return Diagnosis("board", STALE if s.connected else ERROR, "no status from the board", values)
    if s.board_state == "Alarm":
        return Diagnosis("board", ERROR, f"alarm {s.alarm}: reset the board"
                         + (f" ({s.last_error})" if s.last_error else ""), values)
    if s.underruns_in_last_period:
        return Diagnosis("board", WARN, f"queue ran dry {s.underruns_in_last_period} times (host too slow)", values)
    if s.last_error:
        return Diagnosis("board", WARN, s.last_error, values)
    words = {"Idle": "idle", "Run": "running", "Hold": "feed hold"}
    return Diagnosis("board", OK, words.get(s.board_state, s.board_state), values)
