"""The web page's HTTP side (aiohttp): static files, a WebSocket of events,
and a small JSON API; what each call does is the Backend's (the ROS node).

    GET  /                 the page (static/index.html)
    GET  /static/<file>    its script and style, served from the package
    GET  /ws               events: the work area, the board's state, the ink
                           and the planned path, the job's progress, messages
    POST /api/check        an uploaded G-code or SVG file (multipart `file`;
                           for an SVG optional `width` mm, `layers` "3,1" and
                           `optimize` 1): read, checked, kept under an id
    POST /api/run          {"id"}: run a checked job
    POST /api/draw         {"shape", "x", "y", "size", ...}: a ShapeGoal
    POST /api/jog          {"dx", "dy"} mm, pen up, while idle
    POST /api/button/<b>   hold, resume, cancel, estop, reset, set_origin, home

Refusals answer 409 (busy, not connected) or 400 (bad input) with
{"error": text}; the page shows the text and nothing moves.

Access: with a token (needed to bind beyond this machine), every request
must carry it: `?token=` on the page's address (the page then keeps it in a
cookie for its own requests), the cookie, or `Authorization: Bearer`.
Every POST must carry the header `X-Plotter: 1`, which a page of another
site cannot send without a CORS preflight this server never grants, and a
WebSocket must come from this server's own page (its Origin).
"""
from __future__ import annotations

import asyncio
import hmac
import json
import logging
import math
import threading
import uuid
from collections import OrderedDict
from pathlib import Path
from typing import Optional, Protocol, Set

from aiohttp import WSMsgType, web

from .jobs import MAX_UPLOAD, Checked

STATIC = Path(__file__).resolve().parent / "static"
COOKIE = "plotter_token"
CHECKED_KEPT = 16                     # checked jobs the page can still run
CHECKED_BYTES = MAX_UPLOAD            # ... and their programs' text in all, the newest always kept
BUTTONS = ("hold", "resume", "cancel", "estop", "reset", "set_origin", "home")


# The follow box's numbers (FollowLine's goal, in mm, mm/s and degrees).
FOLLOW_FIELDS = ("start_x_mm", "start_y_mm", "heading_deg", "feed_mm_s", "lost_mm", "distance_mm")


class Refused(Exception):
    """A request the plotter cannot do now (409) or at all (400); the text says why."""

    def __init__(self, text: str, status: int = 409) -> None:
        super().__init__(text)
        self.status = status


class Backend(Protocol):
    def snapshot(self) -> list: ...                      # events that bring a new page up to date
    def check(self, filename: str, data: bytes, width: Optional[float], layers: str,
              optimize: bool) -> Checked:
        ...

    async def run(self, job: Checked) -> str: ...
    async def draw(self, fields: dict) -> str: ...
    async def jog(self, dx: float, dy: float) -> str: ...
    async def button(self, name: str) -> str: ...
    async def follow(self, fields: dict) -> str: ...
    async def resume(self, job_id: str) -> str: ...
    async def pick(self, namespace: str) -> str: ...


class WebApp:
    def __init__(self, backend: Backend, token: str = "", log: Optional[logging.Logger] = None) -> None:
        self.backend = backend
        self.token = token
        self.log = log or logging.getLogger("plotter_web")
        self._sockets: Set[web.WebSocketResponse] = set()
        self._checked: "OrderedDict[str, Checked]" = OrderedDict()
        self.loop: Optional[asyncio.AbstractEventLoop] = None
        self.app = web.Application(middlewares=[self._guard], client_max_size=MAX_UPLOAD + 1024 * 1024)
        self.app.add_routes([
            web.get("/", self._index),
            web.get("/static/{name}", self._static),
            web.get("/ws", self._ws),
            web.post("/api/check", self._check),
            web.post("/api/run", self._run),
            web.post("/api/draw", self._draw),
            web.post("/api/jog", self._jog),
            web.post("/api/button/{name}", self._button),
            web.post("/api/follow", self._follow),
            web.post("/api/resume", self._resume),
            web.post("/api/plotter", self._plotter),
        ])

    # --- access ------------------------------------------------------------------------
    def _has_token(self, request: web.Request) -> bool:
        if not self.token:
            return True
        given = request.query.get("token") or request.cookies.get(COOKIE) or ""
        auth = request.headers.get("Authorization", "")
        if auth.startswith("Bearer "):
            given = given or auth[7:]
        return hmac.compare_digest(given.encode(), self.token.encode())

    @web.middleware
    async def _guard(self, request: web.Request, handler):
        if not self._has_token(request):
            return web.json_response({"error": "this plotter needs its token: open the address with ?token=..."},
                                     status=401)
        if request.method == "POST" and request.headers.get("X-Plotter") != "1":
            return web.json_response({"error": "requests come from the plotter's own page"}, status=403)
        try:
            return await handler(request)
        except Refused as exc:
            return web.json_response({"error": str(exc)}, status=exc.status)

    # --- the page ----------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.StreamResponse:
        response = web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})
        if self.token and request.query.get("token"):
            response.set_cookie(COOKIE, self.token, httponly=True, samesite="Strict")
        return response

    async def _static(self, request: web.Request) -> web.StreamResponse:
        name = request.match_info["name"]
        path = STATIC / name
        if "/" in name or name.startswith(".") or not path.is_file():
            raise web.HTTPNotFound()
        return web.FileResponse(path, headers={"Cache-Control": "no-store"})

    async def _ws(self, request: web.Request) -> web.StreamResponse:
        origin = request.headers.get("Origin")
        if origin and origin.split("://", 1)[-1] != request.host:
            return web.json_response({"error": "WebSocket from another site"}, status=403)
        ws = web.WebSocketResponse(heartbeat=20.0)
        await ws.prepare(request)
        for event in self.backend.snapshot():
            await ws.send_str(json.dumps(event))
        self._sockets.add(ws)
        try:
            async for msg in ws:
                if msg.type == WSMsgType.ERROR:
                    break
        finally:
            self._sockets.discard(ws)
        return ws

    # --- events from the node (any thread) -------------------------------------------------
    def publish(self, event: dict) -> None:
        loop = self.loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(self._broadcast, json.dumps(event))

    def _broadcast(self, text: str) -> None:
        for ws in list(self._sockets):
            if not ws.closed:
                asyncio.ensure_future(ws.send_str(text))

    # --- the API -----------------------------------------------------------------------
    async def _json(self, request: web.Request) -> dict:
        try:
            body = await request.json()
        except (ValueError, UnicodeDecodeError):
            raise Refused("the request is not JSON", 400) from None
        if not isinstance(body, dict):
            raise Refused("the request is not a JSON object", 400)
        return body

    async def _check(self, request: web.Request) -> web.Response:
        if not request.content_type.startswith("multipart/"):
            raise Refused("send the file as multipart/form-data", 400)
        try:
            form = await request.post()
        except web.HTTPRequestEntityTooLarge:
            raise Refused(f"file too large: {request.content_length} bytes (limit {MAX_UPLOAD})", 413) from None
        upload = form.get("file")
        if upload is None or not hasattr(upload, "file"):
            raise Refused("no file in the request", 400)
        width = _number(form.get("width") or None, "width", allow_none=True)
        if width is not None and not 1.0 <= width <= 10000.0:
            raise Refused(f"width {width:g} mm: must be 1..10000", 400)
        layers = str(form.get("layers") or "")
        if len(layers) > 200:
            raise Refused(f"layers {layers[:40]!r}...: too long", 400)
        optimize = str(form.get("optimize") or "") in ("1", "true", "on")
        data = upload.file.read()
        job = await asyncio.get_running_loop().run_in_executor(
            None, self.backend.check, upload.filename or "upload", data, width, layers, optimize)
        key = uuid.uuid4().hex
        self._checked[key] = job
        while len(self._checked) > 1 and (len(self._checked) > CHECKED_KEPT or sum(
                len(kept.program) for kept in self._checked.values()) > CHECKED_BYTES):
            self._checked.popitem(last=False)
        return web.json_response({"id": key, **job.as_json()})

    async def _run(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        job = self._checked.get(str(body.get("id", "")))
        if job is None:
            raise Refused("no such checked job: check the file again", 400)
        if not job.ok:
            raise Refused(f"{job.name} has errors: line {job.errors[0]['line']}: {job.errors[0]['message']}", 400)
        return web.json_response({"message": await self.backend.run(job)})

    async def _resume(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        job_id = str(body.get("id", ""))
        if not job_id:
            raise Refused("no job id to resume", 400)
        return web.json_response({"message": await self.backend.resume(job_id)})

    async def _plotter(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        namespace = str(body.get("namespace", ""))
        if not namespace.startswith("/"):
            raise Refused(f"namespace {namespace!r}: give an absolute namespace, e.g. /plotter", 400)
        return web.json_response({"message": await self.backend.pick(namespace)})

    async def _draw(self, request: web.Request) -> web.Response:
        return web.json_response({"message": await self.backend.draw(await self._json(request))})

    async def _jog(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        dx, dy = _number(body.get("dx", 0), "dx"), _number(body.get("dy", 0), "dy")
        return web.json_response({"message": await self.backend.jog(dx, dy)})

    async def _follow(self, request: web.Request) -> web.Response:
        body = await self._json(request)
        fields = {name: _number(body.get(name, 0) or 0, name) for name in FOLLOW_FIELDS}
        fields["from_here"] = bool(body.get("from_here"))
        return web.json_response({"message": await self.backend.follow(fields)})

    async def _button(self, request: web.Request) -> web.Response:
        name = request.match_info["name"]
        if name not in BUTTONS:
            raise Refused(f"no button {name!r}: one of {', '.join(BUTTONS)}", 400)
        return web.json_response({"message": await self.backend.button(name)})


def _number(value, name: str, allow_none: bool = False) -> Optional[float]:
    if value is None and allow_none:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise Refused(f"{name}: not a number: {str(value)[:40]!r}", 400) from None
    if not math.isfinite(v):
        raise Refused(f"{name}: not a finite number", 400)
    return v


def serve(app: WebApp, host: str, port: int, started: threading.Event, errors: list) -> None:
    """Run the server on this thread's own event loop until stop(); a port
    that cannot be bound goes to `errors`.  `started` is set either way."""
    loop = asyncio.new_event_loop()
    asyncio.set_event_loop(loop)
    runner = web.AppRunner(app.app, access_log=None)
    try:
        loop.run_until_complete(runner.setup())
        loop.run_until_complete(web.TCPSite(runner, host, port).start())
    except OSError as exc:
        errors.append(exc)
        loop.run_until_complete(runner.cleanup())
        loop.close()
        started.set()
        return
    app.loop = loop
    started.set()
    try:
        loop.run_forever()
    finally:
        loop.run_until_complete(runner.cleanup())
        loop.close()


def stop(app: WebApp) -> None:
    if app.loop is not None and not app.loop.is_closed():
        app.loop.call_soon_threadsafe(app.loop.stop)


def token_ok(token: str) -> bool:
    return len(token) >= 12 and token.isprintable() and " " not in token
