"""What the serial bridge tells RViz and the diagnostics tools.

The bridge hands every status report of the board to ``BridgeTelemetry``
(and says when the serial link is lost) from its I/O thread, which only
keeps them; two timers of the bridge's node publish, in its namespace:

- ``path`` (nav_msgs/Path, once a second while it changes): every position
  the board reported, the pen's trajectory so far (the older half thinned
  beyond MAX_PATH_POSES);
- ``planned_path`` (nav_msgs/Path, transient local): the moves of the job
  being streamed, from its board commands, in the same pen coordinates as
  ``path``;
- ``pen`` (visualization_msgs/Marker, 4 times a second): the pen, red when
  down, grey when up;
- ``ink`` (visualization_msgs/Marker, line list, with ``path``): the pen-down
  part of the trajectory, what is on the paper;
- ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, once a second, as
  diagnostic_updater does): the link (connection, bytes, errors,
  retransmissions) and the board (state, queue fill, step rate, firmware),
  each OK, WARN or ERROR as REP-107 describes.

Paths and markers are in metres (REP-103) in the bridge's frame (``plotter``),
so RViz shows the 200 mm work area at its true size; ``position`` stays in mm.
The board counts motor steps; on a machine whose motors are not its axes
(the hanging plotter) every position goes through the machine's forward
kinematics first (``to_pen``: motor steps to the pen's mm times steps_per_mm),
the reported ones and the planned ones alike.
The pure functions below hold the logic; the class only turns it into messages.

The bridge's serial thread shares the Python interpreter with these
publishers, and building and converting a long path holds it: 5,000 poses
took some 70 ms, enough to leave a fast board without its next line.  So
the serial thread only records the reports; the trace timer makes each
report into its pose and point once, keeps them for the next message, and
sends the long messages once a second, at most MAX_PATH_POSES poses (about
5 ms).
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Iterable, List, Optional, Sequence, Tuple

MM = 0.001                      # metres per mm
MAX_PATH_POSES = 1500           # older poses are thinned out beyond this
PUBLISH_PERIOD = 0.25           # s between pen messages and new planned paths
TRACE_PERIOD = 1.0              # s between path and ink messages (when they changed)
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
    x, y = float(start[0]), float(start[1])
    out = [PathPoint(x, y, pen_down)]
    for text in commands:
        parts = text.replace(",", " ").split()
        if not parts:
            continue
        verb, args = parts[0], [int(a) for a in parts[1:]]
        if verb == "P" and args:
            pen_down = args[0] == 1
        elif verb == "L" and len(args) >= 2:
            x, y = x + args[0], y + args[1]
            out.append(PathPoint(x, y, pen_down))
        elif verb in ("C", "A") and len(args) >= 4:
            pts = _arc(x, y, args[0], args[1], args[2], args[3], verb == "C")
            out += [PathPoint(px, py, pen_down) for px, py in pts]
            x, y = x + args[0], y + args[1]
    return out


ToPen = Callable[[Tuple[float, float]], Tuple[float, float]]


def planned_pen_points(commands: Iterable[str], start: Tuple[int, int], pen_down: bool,
                       end: Optional[Tuple[int, int]], to_pen: ToPen) -> List[PathPoint]:
    """planned_points from the motor position `start`, shifted to end at the
    motor position `end` when the job knows it, then carried into pen
    coordinates: board commands move the motors, so their sums are motor steps."""
    pts = planned_points(commands, start, pen_down)
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


def ink_segments(samples: Sequence[Sample]) -> List[Tuple[Sample, Sample]]:
    """Consecutive reports with the pen down at both: what is on the paper."""
    return [(samples[k], samples[k + 1]) for k in ink_indices(samples)]


def ink_indices(samples: Sequence[Sample]) -> List[int]:
    """k for each ink segment samples[k] - samples[k + 1]."""
    return [k for k, (a, b) in enumerate(zip(samples, samples[1:]))
            if a.pen_down and b.pen_down and (a.x, a.y) != (b.x, b.y)]


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
    return Diagnosis("board", OK, {"Idle": "idle", "Run": "running", "Hold": "feed hold"}.get(s.board_state,
                                                                                            s.board_state), values)


# --- the ROS side ---------------------------------------------------------------------------------

class BridgeTelemetry:
    """Publishers of the serial bridge for RViz and /diagnostics; fed from its I/O thread."""

    def __init__(self, node, steps_per_mm: float, frame_id: str, port: str,
                 clock: Callable[[], float] = time.monotonic, to_pen: Optional[ToPen] = None) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from nav_msgs.msg import Path
        from visualization_msgs.msg import Marker
        from .qos import latched
        self.node = node
        self.steps_per_mm = steps_per_mm
        self.frame_id = frame_id
        self.clock = clock
        self.to_pen = to_pen
        self.pub_path = node.create_publisher(Path, "path", latched())
        self.pub_planned = node.create_publisher(Path, "planned_path", latched())
        self.pub_pen = node.create_publisher(Marker, "pen", 10)
        self.pub_ink = node.create_publisher(Marker, "ink", latched())
        self.pub_diag = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._lock = threading.Lock()
        self._diag_lock = threading.Lock()
        self._samples: List[Sample] = []
        self._built: dict = {}                      # Sample -> its (PoseStamped, Point): trace timer only
        self._changed = False
        self._planned: Optional[tuple] = None
        self._job = None
        self._snap = BridgeSnapshot(port=port)
        self._last_status_t: Optional[float] = None
        self._reported = BridgeSnapshot()          # counters at the previous diagnostics message
        self._prefix = node.get_fully_qualified_name().lstrip("/")
        self._timers = (node.create_timer(1.0, self.publish_diagnostics),
                        node.create_timer(PUBLISH_PERIOD, self.publish_motion),
                        node.create_timer(TRACE_PERIOD, self.publish_trace))

    # --- hooks called by the bridge (its I/O thread) ---------------------------------
    def on_status(self, st, stats, firmware: str = "", last_error: str = "", job=None) -> None:
        """A status report in motor steps (the bridge's I/O thread): only
        bookkeeping, the timers publish."""
        now = self.clock()
        x, y = self.to_pen((st.x, st.y)) if self.to_pen else (st.x, st.y)
        sample = Sample(now, x, y, bool(st.pen_down))
        with self._lock:
            prev = self._samples[-1] if self._samples else None
            rate = step_rate(prev, sample) if prev else 0.0
            self._snap = replace(self._snap, connected=True, ever_connected=True, lost_reason="",
                                 board_state=st.state, alarm=st.alarm, queue_free=st.queue_free,
                                 underruns=st.underruns, step_rate=rate,
                                 peak_step_rate=max(self._snap.peak_step_rate, rate),
                                 firmware=firmware, last_error=last_error,
                                 counters=LinkCounters.of(stats))
            self._last_status_t = now
            if prev is None or (prev.x, prev.y, prev.pen_down) != (sample.x, sample.y, sample.pen_down):
                self._samples.append(sample)
                if len(self._samples) > MAX_PATH_POSES:
                    self._samples = thin(self._samples)
                self._changed = True
            if job is not None and job is not self._job and getattr(job, "commands", None):
                self._job = job
                self._planned = ([c.text for c in job.commands], (st.x, st.y), bool(st.pen_down),
                                 getattr(job, "expected_end", None))

    def publish_motion(self) -> None:
        """Timer: the pen, the planned path of a new job."""
        with self._lock:
            last = self._samples[-1] if self._samples else None
            planned, self._planned = self._planned, None
        if planned is not None:
            self._publish_planned(*planned)
        if last is not None:
            self._publish_pen(last)

    def publish_trace(self) -> None:
        """Timer: the path and the ink, when the pen moved."""
        with self._lock:
            if not self._changed:
                return
            samples = list(self._samples)
            self._changed = False
        header = self._header()
        built = {s: self._built.get(s) or (self._pose(header, s.x, s.y), self._point(s)) for s in samples}
        self._built = built                         # thinned-out samples drop out here
        self._publish_trace(header, samples, [built[s][0] for s in samples], [built[s][1] for s in samples])

    def on_link_lost(self, reason: str) -> None:
        with self._lock:
            was = self._snap.connected
            self._snap = replace(self._snap, connected=False, lost_reason=reason, board_state="")
        if was:
            self.publish_diagnostics()

    # --- messages ----------------------------------------------------------------------
    def _header(self):
        from std_msgs.msg import Header
        return Header(stamp=self.node.get_clock().now().to_msg(), frame_id=self.frame_id)

    def _pose(self, header, x: float, y: float):
        from geometry_msgs.msg import PoseStamped
        p = PoseStamped(header=header)
        p.pose.position.x = x / self.steps_per_mm * MM
        p.pose.position.y = y / self.steps_per_mm * MM
        p.pose.orientation.w = 1.0
        return p

    def _point(self, s: Sample):
        from geometry_msgs.msg import Point
        k = self.steps_per_mm / MM
        return Point(x=s.x / k, y=s.y / k)

    def _publish_trace(self, header, samples: Sequence[Sample], poses: list, points: list) -> None:
        from nav_msgs.msg import Path
        from visualization_msgs.msg import Marker
        self.pub_path.publish(Path(header=header, poses=poses))
        ink = Marker(header=header, ns="ink", id=0, type=Marker.LINE_LIST, action=Marker.ADD)
        ink.pose.orientation.w = 1.0
        ink.scale.x = 0.0005
        ink.color.r = ink.color.g = ink.color.b = 0.05
        ink.color.a = 1.0
        ink.points = [points[k + i] for k in ink_indices(samples) for i in (0, 1)]
        self.pub_ink.publish(ink)

    def _publish_pen(self, s: Sample) -> None:
        from visualization_msgs.msg import Marker
        m = Marker(header=self._header(), ns="pen", id=0, type=Marker.CYLINDER, action=Marker.ADD)
        m.pose.position.x = s.x / self.steps_per_mm * MM
        m.pose.position.y = s.y / self.steps_per_mm * MM
        m.pose.position.z = 0.005 if s.pen_down else 0.015
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = 0.003
        m.scale.z = 0.01
        m.color.a = 1.0
        m.color.r, m.color.g, m.color.b = (0.9, 0.1, 0.1) if s.pen_down else (0.6, 0.6, 0.6)
        self.pub_pen.publish(m)

    def _publish_planned(self, commands: List[str], here: Tuple[int, int], pen_down: bool,
                         end: Optional[Tuple[int, int]]) -> None:
        from nav_msgs.msg import Path
        header = self._header()
        pts = planned_pen_points(commands, here, pen_down, end, self.to_pen or (lambda m: m))
        self.pub_planned.publish(Path(header=header, poses=[self._pose(header, p.x, p.y) for p in pts]))

    def snapshot(self) -> BridgeSnapshot:
        with self._lock:
            age = math.inf if self._last_status_t is None else self.clock() - self._last_status_t
            return replace(self._snap, seconds_since_status=age)

    def publish_diagnostics(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
        with self._diag_lock:
            snap = self.snapshot()
            prev = self._reported
            snap = replace(snap, errors_in_last_period=max(0, snap.counters.errors - prev.counters.errors),
                           underruns_in_last_period=max(0, snap.underruns - prev.underruns))
            self._reported = snap
        msg = DiagnosticArray(header=self._header())
        for d in (diagnose_link(snap), diagnose_board(snap)):
            msg.status.append(DiagnosticStatus(
                level=d.level, name=f"{self._prefix}: {d.name}", message=d.message, hardware_id=snap.port,
                values=[KeyValue(key=k, value=v) for k, v in d.values]))
        self.pub_diag.publish(msg)
