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
  part of the trajectory, what is on the paper, every report of it from the
  bridge's start, kept within INK_POINTS points as the eye sees them
  (gcode/thinning.py: a day-long drawing alike from its first line);
- ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, once a second, as
  diagnostic_updater does): the link (connection, bytes, errors,
  retransmissions) and the board (state, queue fill, step rate, firmware),
  each OK, WARN or ERROR as REP-107 describes.

Paths and markers are in metres (REP-103) in the bridge's frame (``plotter``),
as ``position`` is, so RViz shows the 200 mm work area at its true size.
The board counts motor steps; on a machine whose motors are not its axes
(the hanging plotter) every position goes through the machine's forward
kinematics first (``to_pen``: motor steps to the pen's mm times steps_per_mm),
the reported ones and the planned ones alike.
The pure functions of link/telemetry.py hold the logic; the class here only turns it
into messages.

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
from dataclasses import replace
from typing import Callable, List, Optional, Sequence, Tuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import Path
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from plotter_bridge.link.telemetry import (MAX_PATH_POSES, BridgeSnapshot, LinkCounters, Sample, ToPen,
                                           diagnose_board, diagnose_link, planned_pen_points,
                                           step_rate, thin)

from plotter_bridge.gcode.thinning import Thinning

from .qos import latched

MM = 0.001                      # metres per mm
PUBLISH_PERIOD = 0.25           # s between pen messages and new planned paths
TRACE_PERIOD = 1.0              # s between path and ink messages (when they changed)
INK_POINTS = 6000               # points of the ink at most (a line list of twice as many)


class BridgeTelemetry:
    """Publishers of the serial bridge for RViz and /diagnostics; fed from its I/O thread."""

    def __init__(self, node, steps_per_mm: float, frame_id: str, port: str,
                 clock: Callable[[], float] = time.monotonic, to_pen: Optional[ToPen] = None) -> None:
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
        self._new_ink: List[Tuple[Sample, Sample]] = []     # pen-down moves since the last ink message
        self._ink = Thinning(INK_POINTS)                    # trace timer only
        self._ink_lines = self._ink.group()
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
                if prev is not None and prev.pen_down and sample.pen_down:
                    self._new_ink.append((prev, sample))
                self._samples.append(sample)
                if len(self._samples) > MAX_PATH_POSES:
                    self._samples = thin(self._samples)
                self._changed = True
            if job is not None and job is not self._job and getattr(job, "part_end", 0):
                self._job = job
                self._planned = (job.source[0][:job.part_end], (st.x, st.y), bool(st.pen_down),
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
            new_ink, self._new_ink = self._new_ink, []
        for a, b in new_ink:
            self._ink.add(self._ink_lines, [(a.x, a.y), (b.x, b.y)], join=True)
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
        return Header(stamp=self.node.get_clock().now().to_msg(), frame_id=self.frame_id)

    def _pose(self, header, x: float, y: float):
        p = PoseStamped(header=header)
        p.pose.position.x = x / self.steps_per_mm * MM
        p.pose.position.y = y / self.steps_per_mm * MM
        p.pose.orientation.w = 1.0
        return p

    def _point(self, s: Sample):
        k = self.steps_per_mm / MM
        return Point(x=s.x / k, y=s.y / k)

    def _publish_trace(self, header, samples: Sequence[Sample], poses: list, points: list) -> None:
        self.pub_path.publish(Path(header=header, poses=poses))
        ink = Marker(header=header, ns="ink", id=0, type=Marker.LINE_LIST, action=Marker.ADD)
        ink.pose.orientation.w = 1.0
        ink.scale.x = 0.0005
        ink.color.r = ink.color.g = ink.color.b = 0.05
        ink.color.a = 1.0
        k = self.steps_per_mm / MM
        ink.points = [Point(x=x / k, y=y / k) for line in self._ink_lines
                      for a, b in zip(line, line[1:]) for x, y in (a, b)]
        self.pub_ink.publish(ink)

    def _publish_pen(self, s: Sample) -> None:
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
        header = self._header()
        pts = planned_pen_points(commands, here, pen_down, end, self.to_pen or (lambda m: m))
        self.pub_planned.publish(Path(header=header, poses=[self._pose(header, p.x, p.y) for p in pts]))

    def snapshot(self) -> BridgeSnapshot:
        with self._lock:
            age = math.inf if self._last_status_t is None else self.clock() - self._last_status_t
            return replace(self._snap, seconds_since_status=age)

    def publish_diagnostics(self) -> None:
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
