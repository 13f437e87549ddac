"""web_ui: a web page for the plotter, served by a node of its own.

    ros2 run plotter_web web_ui --ros-args --params-file plotter.yaml        # http://127.0.0.1:8080
    ros2 run plotter_web web_ui --ros-args -p host:=0.0.0.0 -p token:=<12+ characters>

It is a client of whatever plotter runs in its namespace (default
/plotter): it shows `state`, `ink` and `planned_path` live, sends jobs as
`run_program` goals (files, jog moves), `draw` goals (shapes) and, for a
board with line sensors (FOLLOW=1), `follow_line` goals, and calls
the bridge's services (hold, resume, estop, reset, set_origin, home).  A
file is shown planned before it runs: each pen in its colour, the pen-up
travel, the lengths and the board's time.  At a pen change the page says
which pen comes next; Resume goes on.  The recent jobs of the streamer's
journal (`journal_dir`, the same directory) are listed, and one that
stopped part-way is resumed from where it stopped (a `run_program` goal
with `resume`).  When several plotters run in the domain (a serial bridge
in each namespace), the page lists them and drives the one picked.  One job
from the page at a time: a new one while it runs, or while the board is
busy, disconnected or in alarm, is refused with the reason and nothing
moves.  The server (app.py) runs on a thread of its own; it is bound to
127.0.0.1 unless `host` says otherwise, and binding anywhere else needs a
`token`, which every request must then carry.
"""
from __future__ import annotations

import asyncio
import ipaddress
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from std_srvs.srv import Trigger

from plotter_bridge.gcode.limits import WorkArea
from plotter_bridge.link.journal import Journal, default_journal_dir
from plotter_bridge.link.protocol import DEFAULT_BAUD
from plotter_bridge.nodes.action_client import ActionClient
from plotter_bridge.nodes.main import DEFAULT_NAMESPACE, run_node
from plotter_bridge.nodes.params import WORK_AREA, NodeParameters, ParamSpec, check_work_area
from plotter_bridge.nodes.qos import latched

from .app import Refused, WebApp, serve, stop, token_ok
from .jobs import Checked, check_program, check_upload, jog_program, journal_jobs

SERVER_WAIT_S = 5.0      # s a request waits for an action server it has not seen yet
STATE_PERIOD = 0.1       # s: the page gets the board's state at most this often
SERVICES = {"hold": "hold", "resume": "resume", "estop": "estop", "reset": "reset", "set_origin": "set_origin",
            "home": "home"}
SERVICE_WAIT_S = {"home": 600.0}     # s a button's service may take: the homing cycle runs over the table

SPECS = (
    ParamSpec("host", "127.0.0.1", "address the page is served on; anything but this machine's loopback "
                                   "needs a token", read_only=True),
    ParamSpec("port", 8080, "TCP port of the page", low=1, high=65535, read_only=True),
    ParamSpec("token", "", "secret every request must carry (?token= on the page's address); needed to "
                           "bind beyond loopback; at least 12 characters", read_only=True),
    ParamSpec("svg_width", 120.0, "width an uploaded SVG drawing is scaled to", "mm", low=1.0, high=10000.0),
    ParamSpec("default_feed", 1500.0, "drawing feed of uploaded SVG drawings", "mm/min", low=0.0, above=True,
              high=1e5),
    ParamSpec("journal_dir", "", "the streamer's job journal, for the page's list of jobs ('' = "
                                 "$ROS_HOME/plotter_journal, the streamer's default)", read_only=True),
    *WORK_AREA,
)
JOBS_LISTED = 10         # the newest jobs of the journal the page lists
PLOTTERS_PERIOD = 2.0    # s between looks for the plotters (serial bridges) of the domain


def check_web(values) -> Optional[str]:
    host, token = str(values["host"]), str(values["token"])
    try:
        loopback = ipaddress.ip_address(host).is_loopback
    except ValueError:
        loopback = host == "localhost"
    if token and not token_ok(token):
        return "token = '...': must be at least 12 printable characters without spaces"
    if not loopback and not token:
        return (f"host = {host!r}: must be this machine's loopback (127.0.0.1) unless a token is given "
                f"(-p token:=<secret>): the page drives the machine")
    return check_work_area(values)


@dataclass
class _Plotter:
    """One plotter the page has driven: its entities and the newest of what it said."""
    ns: str
    subs: list = field(default_factory=list)
    run_client: object = None
    draw_client: object = None
    follow_client: object = None
    triggers: dict = field(default_factory=dict)
    state: object = None
    last_name: str = ""
    ink: List[float] = field(default_factory=list)
    planned: List[float] = field(default_factory=list)


class WebUi(Node):
    def __init__(self, *, namespace: str = DEFAULT_NAMESPACE, **kwargs) -> None:
        super().__init__("web_ui", namespace=namespace, **kwargs)
        from plotter_interfaces.action import DrawShape, FollowLine, RunProgram
        from plotter_interfaces.msg import BoardState
        self.params = NodeParameters(self, SPECS, cross=check_web)
        self._RunProgram, self._DrawShape, self._FollowLine = RunProgram, DrawShape, FollowLine
        self._disconnected, self._idle = BoardState.DISCONNECTED, BoardState.IDLE
        group = ReentrantCallbackGroup()
        self._state_sent = 0.0
        self._job: Optional[dict] = None          # the page's job: name, status, progress...
        self._handle = None
        self._lock = threading.Lock()
        self._group = group
        # Every plotter the page has driven keeps its subscriptions and clients until the node
        # ends: entities destroyed from the web thread race the executor's wait set.
        self._known: Dict[str, _Plotter] = {}
        self._cur = self._connect(self.get_namespace())
        self._plotters: List[str] = []
        self.create_timer(PLOTTERS_PERIOD, self._look_for_plotters, callback_group=group)
        self._journal = Journal(str(self.params["journal_dir"]) or default_journal_dir())
        token = str(self.params["token"])
        self.web = WebApp(self, token, log=None)
        host, port = str(self.params["host"]), int(self.params["port"])
        started, errors = threading.Event(), []
        self._server = threading.Thread(target=serve, args=(self.web, host, port, started, errors),
                                        name="web", daemon=True)
        self._server.start()
        started.wait(10.0)
        if errors:
            raise ValueError(f"port = {port}: cannot serve on {host}:{port}: {errors[0].strerror or errors[0]}")
        where = f"http://{host}:{port}/" + ("?token=..." if token else "")
        print(f"plotter page on {where}", flush=True)
        self.get_logger().info(f"plotter page on {where} for the plotter in {self.get_namespace()}")

    # --- which plotter ------------------------------------------------------------------------
    def _connect(self, namespace: str) -> "_Plotter":
        """The plotter in `namespace`: its topics, actions and services (absolute names)."""
        from nav_msgs.msg import Path
        from plotter_interfaces.msg import BoardState
        from visualization_msgs.msg import Marker
        ns, group = namespace.rstrip("/"), self._group
        key = ns or "/"
        known = self._known.get(key)
        if known is not None:
            return known
        p = _Plotter(key)
        p.subs = [
            self.create_subscription(BoardState, f"{ns}/state", lambda m: self._on_state(p, m), latched(),
                                     callback_group=group),
            self.create_subscription(Marker, f"{ns}/ink", lambda m: self._on_ink(p, m), latched(),
                                     callback_group=group),
            self.create_subscription(Path, f"{ns}/planned_path", lambda m: self._on_planned(p, m), latched(),
                                     callback_group=group)]
        p.run_client = ActionClient(self, self._RunProgram, f"{ns}/run_program", callback_group=group)
        p.draw_client = ActionClient(self, self._DrawShape, f"{ns}/draw", callback_group=group)
        p.follow_client = ActionClient(self, self._FollowLine, f"{ns}/follow_line", callback_group=group)
        p.triggers = {name: self.create_client(Trigger, f"{ns}/{srv}", callback_group=group)
                      for name, srv in SERVICES.items()}
        self._known[key] = p
        return p

    @property
    def _target(self) -> str:
        return self._cur.ns

    @property
    def _state(self):
        return self._cur.state

    def plotters(self) -> List[str]:
        """The namespaces in which a serial bridge runs: the plotters of this ROS domain."""
        found = {ns for name, ns in self.get_node_names_and_namespaces() if name == "serial_bridge"}
        return sorted(found | {self._target})

    def _look_for_plotters(self) -> None:
        found = self.plotters()
        if found != self._plotters:
            self._plotters = found
            self.web.publish(self._plotters_event())

    def _plotters_event(self) -> dict:
        return {"type": "plotters", "namespaces": self._plotters or [self._target], "current": self._target}

    async def pick(self, namespace: str) -> str:
        """Drive another plotter of the domain; not while a job of the page's runs."""
        if namespace == self._target:
            return f"already on {namespace}"
        if namespace not in self.plotters():
            raise Refused(f"no plotter (serial_bridge) in {namespace!r}: the domain has "
                          f"{', '.join(self.plotters())}", 400)
        job = self._job
        if job is not None and job["status"] in ("sending", "running"):
            raise Refused(f"busy: {job['name']!r} is running on {self._target}: wait for it or cancel it")
        with self._lock:
            self._cur = self._connect(namespace)
            self._job, self._handle = None, None
        for event in self.snapshot():
            self.web.publish(event)
        return f"now driving the plotter in {namespace}"

    # --- what the plotter tells -------------------------------------------------------------
    def area(self) -> WorkArea:
        p = self.params
        return WorkArea(float(p["x_min"]), float(p["x_max"]), float(p["y_min"]), float(p["y_max"]))

    def _state_event(self) -> dict:
        s = self._state
        if s is None:
            return {"type": "state", "state": "UNKNOWN", "connected": False,
                    "last_error": "no state from serial_bridge yet"}
        return {"type": "state", "state": s.state_name, "connected": s.state != self._disconnected,
                "x_mm": s.x_mm, "y_mm": s.y_mm, "pen_down": s.pen_down, "position_known": s.position_known,
                "queue_free": s.queue_free, "queue_size": s.queue_size, "last_error": s.last_error,
                "firmware": s.firmware_version,
                # A board with line sensors (FOLLOW=1): those on black, bit i = sensor i; its follow's state.
                "sensors": s.sensors if s.has_sensors else None,
                "follow_state": s.follow_state_name if s.has_sensors else None,
                # At a pen change: the pen the job waits for.
                "next_pen": s.next_pen, "next_pen_colour": s.next_pen_colour}

    def _on_state(self, plotter: "_Plotter", msg) -> None:
        plotter.state = msg
        changed, plotter.last_name = plotter.last_name != msg.state_name, msg.state_name
        if plotter is not self._cur:
            return
        now = time.monotonic()
        if changed or now - self._state_sent >= STATE_PERIOD:
            self._state_sent = now
            self.web.publish(self._state_event())

    def _on_ink(self, plotter: "_Plotter", msg) -> None:
        # A line list in metres; the page draws in millimetres.
        plotter.ink = [round(v * 1000.0, 3) for p in msg.points for v in (p.x, p.y)]
        if plotter is self._cur:
            self.web.publish({"type": "ink", "points": plotter.ink})

    def _on_planned(self, plotter: "_Plotter", msg) -> None:
        plotter.planned = [round(v * 1000.0, 3) for p in msg.poses
                           for v in (p.pose.position.x, p.pose.position.y)]
        if plotter is self._cur:
            self.web.publish({"type": "planned", "points": plotter.planned})

    def snapshot(self) -> list:
        a = self.area()
        events = [{"type": "config", "area": [a.x_min, a.x_max, a.y_min, a.y_max], "namespace": self._target,
                   "jog_steps": [0.1, 1.0, 10.0]}, self._plotters_event(),
                  self._state_event(), {"type": "ink", "points": self._cur.ink},
                  {"type": "planned", "points": self._cur.planned}]
        if self._job is not None:
            events.append({"type": "job", **self._job})
        events.append(self.jobs_event())
        return events

    def jobs_event(self) -> dict:
        """The newest jobs of the journal, each with whether it can be resumed."""
        return {"type": "jobs", "jobs": journal_jobs(self._journal, JOBS_LISTED)}

    def _pen(self) -> tuple:
        s = self._state
        return (s.x_mm, s.y_mm) if s is not None else (0.0, 0.0)

    # --- what the page asks ------------------------------------------------------------------
    def check(self, filename: str, data: bytes, width: Optional[float], layers: str = "",
              optimize: bool = False) -> Checked:
        s = self._state
        return check_upload(filename, data, self.area(), self._pen(),
                            width if width is not None else float(self.params["svg_width"]),
                            float(self.params["default_feed"]),
                            int(s.link_baud) if s is not None and s.link_baud else DEFAULT_BAUD,
                            layers, optimize)

    def _ready_for_a_job(self) -> None:
        s = self._state
        if s is None or s.state == self._disconnected:
            why = s.last_error if s is not None and s.last_error else "no state from serial_bridge"
            raise Refused(f"the board is not connected ({why}): nothing was sent")
        job = self._job
        if job is not None and job["status"] in ("sending", "running"):
            raise Refused(f"busy: {job['name']!r} is running ({job['progress'] * 100:.0f}%): wait for it or "
                          f"cancel it")
        if s.state_name == "ALARM":
            raise Refused("the board is in alarm: press reset first")
        if s.state != self._idle or s.queue_free != s.queue_size:
            raise Refused(f"busy: the board is {s.state_name.lower()} with a job from elsewhere")

    async def run(self, job: Checked) -> str:
        self._ready_for_a_job()
        return await self._send(self._cur.run_client, self._RunProgram.Goal(program=job.program, name=job.name),
                                job.name, "run_program", "gcode_streamer")

    async def resume(self, job_id: str) -> str:
        """Finish a journalled job from where it stopped (the streamer's resume)."""
        listed = {j["id"]: j for j in journal_jobs(self._journal, JOBS_LISTED)}
        job = listed.get(job_id)
        if job is None:
            raise Refused(f"job {job_id[:8]} is not among the page's recent jobs", 400)
        if not job["resumable"]:
            raise Refused(f"{job['name']}: cannot be resumed ({job['state']}"
                          f"{': ' + job['note'] if job['note'] else ''})")
        self._ready_for_a_job()
        name = f"{job['name']} (resumed)"
        return await self._send(self._cur.run_client, self._RunProgram.Goal(name=name, resume=job_id),
                                name, "run_program", "gcode_streamer")

    async def jog(self, dx: float, dy: float) -> str:
        try:
            program = jog_program(dx, dy)
        except ValueError as exc:
            raise Refused(str(exc), 400) from None
        self._ready_for_a_job()
        checked = check_program(program, "jog", self.area(), self._pen())
        if not checked.ok:
            raise Refused(f"jog: {checked.errors[0]['message']}", 400)
        return await self._send(self._cur.run_client, self._RunProgram.Goal(program=program, name="jog"),
                                "jog", "run_program", "gcode_streamer")

    async def draw(self, fields: dict) -> str:
        from plotter_interfaces.msg import ShapeGoal
        goal = ShapeGoal()
        try:
            goal.shape = str(fields.get("shape", ""))
            for name in ("x", "y", "size", "feed", "x2", "y2", "start_angle", "end_angle"):
                setattr(goal, name, float(fields.get(name, 0.0) or 0.0))
            goal.clockwise, goal.reverse = bool(fields.get("clockwise")), bool(fields.get("reverse"))
        except (TypeError, ValueError, AssertionError) as exc:
            raise Refused(f"shape: {exc}", 400) from None
        self._ready_for_a_job()
        name = (goal.shape or "shape") + (" reversed" if goal.reverse else "")
        return await self._send(self._cur.draw_client, self._DrawShape.Goal(shape=goal), name, "draw", "shape_server")

    async def follow(self, fields: dict) -> str:
        """A follow_line goal; gcode_streamer refuses a bad one with every reason."""
        s = self._state
        if s is not None and s.state != self._disconnected and not s.has_sensors:
            raise Refused("the board reports no line sensors: line following needs the firmware built with "
                          "FOLLOW=1")
        self._ready_for_a_job()
        goal = self._FollowLine.Goal(from_here=fields["from_here"], gate_mm=0.0,
                                     **{k: v for k, v in fields.items() if k != "from_here"})
        return await self._send(self._cur.follow_client, goal, "follow", "follow_line", "gcode_streamer",
                                self._on_follow_feedback)

    async def button(self, name: str) -> str:
        if name == "cancel":
            handle = self._handle
            if handle is None:
                raise Refused("nothing of this page's is running")
            await _wrap(handle.cancel_goal_async())
            return "cancel requested"
        client = self._cur.triggers[name]
        if not client.service_is_ready():
            raise Refused(f"{self._target}/{SERVICES[name]} does not answer: is serial_bridge running?")
        response = await asyncio.wait_for(_wrap(client.call_async(Trigger.Request())),
                                          SERVICE_WAIT_S.get(name, 10.0))
        if not response.success:
            raise Refused(f"{name}: {response.message}")
        return f"{name}: {response.message}"

    async def _send(self, client: ActionClient, goal, name: str, action: str, node: str,
                    on_feedback=None) -> str:
        on_feedback = on_feedback or self._on_feedback
        self._set_job(name=name, status="sending", progress=0.0, seconds_left=0.0, line=0, message="")
        for _ in range(int(SERVER_WAIT_S / 0.1)):     # just started: discovery may still be on its way
            if client.server_is_ready():
                break
            await asyncio.sleep(0.1)
        else:
            why = f"{self._target}/{action} does not answer: is {node} running?"
            self._set_job(status="aborted", message=why)
            raise Refused(why)
        try:
            handle = await asyncio.wait_for(_wrap(client.send_goal_async(
                goal, feedback_callback=lambda fb: on_feedback(fb.feedback))), 10.0)
        except asyncio.TimeoutError:
            self._set_job(status="aborted", message=f"{node} did not answer")
            raise Refused(f"{node} did not answer the goal") from None
        if not handle.accepted:
            self._set_job(status="aborted", message=f"{node} rejected the job (its queue is full)")
            raise Refused(f"{node} rejected the job (its queue is full)")
        self._handle = handle
        self._set_job(status="running")
        handle.get_result_async().add_done_callback(lambda f: self._on_result(handle, f.result()))
        return f"{name}: started"

    def _on_feedback(self, fb) -> None:
        self._set_job(progress=float(fb.progress), seconds_left=float(fb.seconds_left),
                      line=int(fb.current_line), jobs_ahead=int(fb.jobs_ahead))

    def _on_follow_feedback(self, fb) -> None:
        self._set_job(steps=int(fb.steps), length_mm=round(float(fb.length_mm), 1), jobs_ahead=int(fb.jobs_ahead))

    def _on_result(self, handle, wrapped) -> None:
        from action_msgs.msg import GoalStatus
        status = {GoalStatus.STATUS_SUCCEEDED: "succeeded", GoalStatus.STATUS_CANCELED: "canceled"}.get(
            wrapped.status, "aborted")
        message = wrapped.result.message
        if self._handle is handle:
            self._handle = None
        followed = {}
        if hasattr(wrapped.result, "length_mm"):          # a follow: what it followed
            followed = {"steps": int(wrapped.result.steps), "length_mm": round(float(wrapped.result.length_mm), 1)}
        self._set_job(status=status, message=message, progress=1.0 if status == "succeeded" else None,
                      seconds_left=0.0, **followed)
        self.web.publish(self.jobs_event())
        if status != "succeeded":
            self.web.publish({"type": "message", "level": "error" if status == "aborted" else "info",
                              "text": f"{self._job['name']}: {status}: {message}"})

    def _set_job(self, **fields) -> None:
        with self._lock:
            job = dict(self._job or {})
            if fields.get("status") == "sending":
                job = {"jobs_ahead": 0}
            job.update({k: v for k, v in fields.items() if v is not None})
            self._job = job
        self.web.publish({"type": "job", **job})

    def destroy_node(self) -> None:
        stop(self.web)
        self._server.join(timeout=5.0)
        super().destroy_node()


async def _wrap(future):
    """An rclpy future, awaited on the server's asyncio loop."""
    loop = asyncio.get_running_loop()
    done = loop.create_future()

    def settle(f) -> None:
        def set_it() -> None:
            if done.done():
                return
            exc = f.exception()
            done.set_exception(exc) if exc else done.set_result(f.result())
        loop.call_soon_threadsafe(set_it)
    future.add_done_callback(settle)
    return await done


def main(args=None) -> int:
    return run_node(WebUi, "web_ui", args)


if __name__ == "__main__":
    sys.exit(main())
