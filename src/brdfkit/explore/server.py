"""The explorer's local web server: the page, its static modules, a WebSocket and uploads.

Security (DESIGN.md §6): the server binds to 127.0.0.1; every URL starts with a random token
(``http://127.0.0.1:PORT/TOKEN/``, as Jupyter's token), checked in constant time on every request
and WebSocket by :class:`Guard`, which also refuses a ``Host`` other than the loopback address
and port (DNS rebinding) and, on WebSockets and uploads, an ``Origin`` other than the page's own
(other web pages). The server reads only the files the session was given and those uploaded;
every message is checked by :mod:`brdfkit.explore.protocol`; the page's replies forbid framing,
caching and referrers (the token stays in this origin).

References
----------
.. [1] Jupyter Server, "Security in the Jupyter Server" (token authentication),
       https://jupyter-server.readthedocs.io/en/latest/operators/security.html
.. [2] OWASP, "Cross-Site WebSocket Hijacking" and "DNS rebinding" cheat sheets.
"""

from __future__ import annotations

import asyncio
import functools
import gc
import logging
import secrets
import socket
import threading
import time
from collections.abc import Awaitable, Callable, MutableMapping
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from brdfkit.errors import BrdfkitError, require_extra
from brdfkit.explore.protocol import (
    MAX_MESSAGE_BYTES,
    Message,
    ProtocolError,
    encode_frame,
    parse_message,
)
from brdfkit.explore.session import MAX_UPLOAD_BYTES, Session, error_reply, fit_spec, guarded
from brdfkit.explore.views import ViewState

if TYPE_CHECKING:
    from starlette.requests import Request
    from starlette.responses import Response
    from starlette.websockets import WebSocket

Scope = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Any]]
Send = Callable[[Any], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

_log = logging.getLogger(__name__)

QUIET_SECONDS = 0.1
"""How long after the last render's reply the progressive views (the environment-lit
spheres, the lit objects) wait before they take the cores again (:class:`_Quiet`)."""

STATIC = Path(str(resources.files("brdfkit.explore") / "static"))
"""The front end's files (package data)."""

SECURITY_HEADERS = {
    "cache-control": "no-store",
    "x-content-type-options": "nosniff",
    "referrer-policy": "no-referrer",
    "x-frame-options": "DENY",
    "content-security-policy": (
        "default-src 'self'; img-src 'self' blob: data:; style-src 'self'; "
        "connect-src 'self'; frame-ancestors 'none'"
    ),
}


class Guard:
    """ASGI middleware: the token, ``Host`` and ``Origin`` checks in front of ``app``."""

    def __init__(self, app: ASGIApp, token: str, port: int) -> None:
        self.app, self.token, self.port = app, token, port
        self.hosts = {f"127.0.0.1:{port}", f"localhost:{port}"}

    def _refusal(self, scope: Scope) -> str | None:
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        if headers.get("host", "") not in self.hosts:
            return "wrong Host"
        segment = scope["path"].lstrip("/").split("/", 1)[0]
        if not secrets.compare_digest(segment.encode(), self.token.encode()):
            return "wrong or missing token"
        origin = headers.get("origin")
        needs_origin = scope["type"] == "websocket" or scope.get("method", "GET") != "GET"
        if needs_origin and origin not in {f"http://{h}" for h in self.hosts}:
            return "wrong or missing Origin"
        return None

    async def __call__(self, scope: Scope, receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        reason = self._refusal(scope)
        if reason is None:
            await self.app(scope, receive, send)
        elif scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008, "reason": reason})
        else:
            body = f"403 Forbidden: {reason}\n".encode()
            await send(
                {
                    "type": "http.response.start",
                    "status": 403,
                    "headers": [(b"content-type", b"text/plain"), (b"cache-control", b"no-store")],
                }
            )
            await send({"type": "http.response.body", "body": body})


def _json(content: Any, status_code: int = 200) -> Response:
    """A JSON response with the page's :data:`SECURITY_HEADERS`."""
    from starlette.responses import JSONResponse

    return JSONResponse(content, status_code, headers=SECURITY_HEADERS)


async def _index(request: Request) -> Response:
    """The page."""
    from starlette.responses import FileResponse

    return FileResponse(STATIC / "index.html", headers=SECURITY_HEADERS)


def _config(session: Session, initial: list[str]) -> Callable[[Request], Awaitable[Response]]:
    """The handler of ``config``: what the page opens with (``initial``), the session's files
    and environment map, the upload limit and the material presets."""

    async def config(request: Request) -> Response:
        return _json(
            {
                "initial": initial,
                "files": session.files,
                "meshes": session.meshes,
                "envmap": session.envmap_name,
                "max_upload": MAX_UPLOAD_BYTES,
                "materials": _material_choices(),  # the picker of static/materials.js
            }
        )

    return config


def _too_large(name: str, size: str) -> Response:
    """The 413 reply to an upload of ``size`` bytes beyond :data:`MAX_UPLOAD_BYTES`."""
    message = (
        f"{name[:60]!r} holds {size} bytes; an upload holds at most "
        f"{MAX_UPLOAD_BYTES >> 20} MiB ({MAX_UPLOAD_BYTES} bytes)"
    )
    return _json({"error": message}, 413)


def _upload(session: Session) -> Callable[[Request], Awaitable[Response]]:
    """The handler of ``upload``: a measured file added to ``session`` (its key in the reply as
    ``name``), a mesh (its key as ``mesh``), or a fit.json read for its spec (no file kept); at
    most :data:`MAX_UPLOAD_BYTES`."""

    async def upload(request: Request) -> Response:
        name = request.query_params.get("name", "")
        length = request.headers.get("content-length", "")
        if length.isdigit() and int(length) > MAX_UPLOAD_BYTES:
            return _too_large(name, length)
        data = bytearray()
        async for chunk in request.stream():
            data += chunk
            if len(data) > MAX_UPLOAD_BYTES:
                return _too_large(name, f"more than {MAX_UPLOAD_BYTES}")
        if name.lower().endswith(".json"):  # a fit.json: its spec, no file kept
            try:
                spec = fit_spec(bytes(data), name[:60])
            except (BrdfkitError, ValueError) as error:
                return _json({"error": str(error)[:500]}, 400)
            return _json({"spec": spec})
        try:
            key = await asyncio.to_thread(session.add_upload, name, bytes(data))
        except (BrdfkitError, ValueError, OSError) as error:
            return _json({"error": str(error)[:500]}, 400)
        return _json({"mesh" if key in session.meshes else "name": key})

    return upload


PROGRESSIVE_ONLY = {
    name: getattr(ViewState(), name) for name in ("envmap", "lit", "mesh", "azimuth", "elevation")
}
"""The view's fields only the progressive views depend on (a render that changes nothing
else is answered from the session's cached views and leaves them the cores)."""


class _Quiet:
    """Whether the directional-light views (the sphere and the plots, a slider's reply) have
    the cores: from a render message's arrival until :data:`QUIET_SECONDS` after the last
    render's reply, during which the progressive views wait, between their passes and
    between the tiles of a pass (a slider being dragged keeps both cores, and the GIL, for
    the sphere views; the progressive views go on once it rests). Set and read on the
    server's event loop, read by the passes' threads."""

    def __init__(self) -> None:
        self.rendering = False
        self.until = 0.0

    def begin(self) -> None:
        """A render message arrived."""
        self.rendering = True

    def end(self, more: bool) -> None:
        """A render was answered; ``more``: another render message is waiting."""
        self.rendering = more
        self.until = time.monotonic() + QUIET_SECONDS

    def left(self) -> float:
        """Seconds the progressive views have yet to wait (at least; 0: go on)."""
        if self.rendering:
            return QUIET_SECONDS
        return max(self.until - time.monotonic(), 0.0)

    def wait(self, cancel: threading.Event) -> None:
        """Block the calling thread until the views are quiet or ``cancel`` is set."""
        while (left := self.left()) > 0 and not cancel.is_set():
            cancel.wait(left)


class _Channel:
    """One page's WebSocket: its messages in latest-wins slots, served by four workers.

    A message waiting in a slot is replaced by a newer one of its kind, so a slider that moves
    faster than the renders skips the stale states. Renders run in one worker; the slow albedo
    curves and physics checks in another, so they never hold up the next image; the
    environment-lit spheres come pass by pass from a third, cancelled only by a render that
    changes what they show (the BRDFs, the map's switch, the resolution);
    the lit objects pass by pass from a fourth, cancelled only by a render that changes what
    they show (the BRDFs, the mesh, the camera), so the light's slider leaves them refining.
    Both progressive views yield to the renders (:class:`_Quiet`): their passes, and the
    tiles of a pass, wait while a render is waiting or under way and for
    :data:`QUIET_SECONDS` after its reply.
    """

    def __init__(self, session: Session, ws: WebSocket) -> None:
        self.session, self.ws = session, ws
        self.pending: dict[str, Message | None] = {"render": None, "albedo": None, "checks": None}
        self.wakes = {k: asyncio.Event() for k in ("fast", "slow", "env", "lit")}
        self.lock = asyncio.Lock()
        self.progressive: dict[str, Message | None] = {"env": None, "lit": None}
        self.cancels = {"env": threading.Event(), "lit": threading.Event()}
        self.env_shown: tuple[Any, ...] | None = None
        self.albedo_asked: tuple[Any, ...] | None = None
        self.views_sent: dict[tuple[str, str], Any] = {}
        self.lit_shown: tuple[Any, ...] | None = None
        self.quiet = _Quiet()
        self.views_shown: tuple[Any, ...] | None = None

    async def serve(self) -> None:
        """Accept the socket and serve it until the page goes away."""
        from starlette.websockets import WebSocketDisconnect

        await self.ws.accept()
        workers = [
            asyncio.create_task(self._work(self.wakes["fast"], ("render",))),
            asyncio.create_task(self._work(self.wakes["slow"], ("checks", "albedo"))),
            asyncio.create_task(self._progressive("env", self.session.environment)),
            asyncio.create_task(self._progressive("lit", self.session.lit)),
        ]
        try:
            await self._listen()
        except WebSocketDisconnect:
            pass
        finally:
            for worker in workers:
                worker.cancel()
            await _stopped(workers)

    async def _reply(self, replies: list[tuple[dict[str, Any], list[Any]]]) -> None:
        async with self.lock:
            for header, arrays in replies:
                await self.ws.send_bytes(encode_frame(header, [a.tobytes() for a in arrays]))

    def _held_left_out(self, reply: tuple[dict[str, Any], list[Any]]) -> tuple[dict, list]:
        """A frame without the views the page holds already: those whose array is the very
        object the last frame sent (the session's cached views, e.g. the θh × θd slice while
        the light moves), named in the header's ``held`` as ``[id, view]`` pairs and left
        out of its arrays. Other replies unchanged."""
        header, arrays = reply
        if header["type"] != "frame":
            return reply
        kept: dict[int, int] = {}
        places = {(i, n): k for i, names in header["views"].items() for n, k in names.items()}
        unchanged = {p for p, k in places.items() if self.views_sent.get(p) is arrays[k]}
        self.views_sent = {p: arrays[k] for p, k in places.items()}
        # an array shared by several views (the disc) is left out only if all of them hold it
        needed = {k for p, k in places.items() if p not in unchanged}
        left_out = {places[p] for p in unchanged} - needed
        held = [list(p) for p in unchanged if places[p] in left_out]
        for index in range(len(arrays)):
            if index not in left_out:
                kept[index] = len(kept)
        views = {
            i: {n: kept[k] for n, k in names.items() if k in kept}
            for i, names in header["views"].items()
        }
        axes = {n: kept[k] for n, k in header["axes"].items()}
        table = [header["arrays"][k] for k in kept]
        return (
            {**header, "views": views, "axes": axes, "arrays": table, "held": held},
            [arrays[k] for k in kept],
        )

    async def _listen(self) -> None:
        """Put each message in its slot and wake its worker, until the page disconnects."""
        while True:
            event = await self.ws.receive()
            if event["type"] == "websocket.disconnect":
                return
            text = event.get("text")
            try:
                if text is None:
                    raise ProtocolError("messages must be JSON text")
                message = parse_message(text)
            except ProtocolError as error:
                await self._reply([error_reply(0, error)])
                continue
            self.pending[message.type] = message
            self.wakes["fast" if message.type == "render" else "slow"].set()
            if message.type == "render":
                view = message.view
                shown = (message.entries, replace(view, **PROGRESSIVE_ONLY))
                if shown != self.views_shown:  # not an orbit or a switch of a progressive view
                    self.views_shown = shown
                    self.quiet.begin()
                shown = (message.entries, view.envmap, view.resolution)
                if shown != self.env_shown:
                    self.env_shown = shown
                    self._restart("env", message)
                shown = (message.entries, view.lit, view.mesh, view.azimuth, view.elevation)
                if shown != self.lit_shown:
                    self.lit_shown = shown
                    self._restart("lit", message)

    def _restart(self, kind: str, message: Message) -> None:
        """Cancel the passes of ``kind`` under way and start those of ``message``."""
        self.cancels[kind].set()
        self.progressive[kind] = message
        self.wakes[kind].set()

    async def _run(self, kind: str, message: Message) -> Any:
        """The reply to ``message`` of ``kind`` (``None`` when a newer one made it stale); an
        error reply for whatever the work raised (:func:`~brdfkit.explore.session.guarded`)."""
        run = {"render": self.session.render, "albedo": self.session.albedo}.get(kind)
        if run is None:
            work = functools.partial(self.session.checks, message)
        else:
            work = functools.partial(run, message, lambda: self.pending[kind] is not None)
        return await asyncio.to_thread(guarded, message.seq, work)

    async def _work(self, wake: asyncio.Event, kinds: tuple[str, ...]) -> None:
        """Serve the slots of ``kinds`` whenever ``wake`` is set; a render queues its albedo
        curves when its BRDFs or resolution differ from those last queued."""
        while True:
            await wake.wait()
            wake.clear()
            for kind in kinds:
                message, self.pending[kind] = self.pending[kind], None
                if message is None:
                    continue
                rendering = kind == "render"
                result = await self._run(kind, message)
                if result is not None:
                    await self._reply([self._held_left_out(result) if rendering else result])
                if rendering and self.quiet.rendering:
                    self.quiet.end(more=self.pending["render"] is not None)
                asked = (message.entries, message.view.resolution)
                if kind == "render" and result is not None and asked != self.albedo_asked:
                    self.albedo_asked = asked  # the light's slider leaves the albedo as it is
                    self.pending["albedo"] = message
                    self.wakes["slow"].set()
                if any(self.pending[k] is not None for k in kinds):
                    wake.set()

    async def _progressive(self, kind: str, passes_of: Callable[..., Any]) -> None:
        """The images of ``kind`` (``env``, ``lit``) pass by pass from ``passes_of``; a newer
        message of that kind cancels the old one. Each pass after the first image, and each
        tile of a pass, waits until the renders are quiet (:class:`_Quiet`)."""
        while True:
            await self.wakes[kind].wait()
            self.wakes[kind].clear()
            message, self.progressive[kind] = self.progressive[kind], None
            if message is None:
                continue
            cancel = self.cancels[kind] = threading.Event()
            passes = passes_of(message, cancel, functools.partial(self.quiet.wait, cancel))
            first = True
            while not cancel.is_set():
                while not first and (left := self.quiet.left()) > 0:
                    await asyncio.sleep(left)
                first = False
                step = functools.partial(next, passes, None)
                result = await asyncio.to_thread(guarded, message.seq, step)
                if result is None or cancel.is_set():
                    break
                await self._reply([result])
                if result[0]["type"] == "error":
                    break  # the passes failed: answered, and this worker serves on


async def _stopped(workers: list[asyncio.Task]) -> None:
    """Wait for the cancelled ``workers``; log the failure of one that died of anything but the
    page going away (its replies then stopped)."""
    from starlette.websockets import WebSocketDisconnect

    for outcome in await asyncio.gather(*workers, return_exceptions=True):
        if isinstance(outcome, Exception) and not isinstance(
            outcome, WebSocketDisconnect | OSError
        ):
            _log.error("an explorer worker failed", exc_info=outcome)


def _channel(session: Session) -> Callable[[WebSocket], Awaitable[None]]:
    """The handler of the WebSocket ``ws`` (:class:`_Channel`)."""

    async def channel(ws: WebSocket) -> None:
        await _Channel(session, ws).serve()

    return channel


def build_app(session: Session, token: str, port: int, initial: list[str]) -> ASGIApp:
    """The guarded Starlette application serving ``session`` under ``/TOKEN/``.

    ``initial`` lists the specs and file names the page opens with.
    """
    require_extra("starlette")
    from starlette.applications import Starlette
    from starlette.routing import Mount, Route, WebSocketRoute
    from starlette.staticfiles import StaticFiles

    routes = [
        Route("/", _index),
        Route("/config", _config(session, initial)),
        Route("/upload", _upload(session), methods=["POST"]),
        WebSocketRoute("/ws", _channel(session)),
        Mount("/static", StaticFiles(directory=STATIC)),
    ]
    return Guard(Starlette(routes=[Mount(f"/{token}", routes=routes)]), token, port)


def _warm_up(session: Session, specs: list[str], files: list[str]) -> None:
    """The session's warm-up (:meth:`Session.warm_up`), then the process's objects so far
    (modules, kernels, the session's tables) collected once and frozen out of the cyclic
    garbage collector (:func:`gc.freeze`): a full collection over them holds the GIL for
    40–300 ms on a 2-core machine, a stall of whatever reply is under way; afterwards the
    collector scans only the objects made since."""
    session.warm_up(specs, files)
    gc.collect()
    gc.freeze()


WARM_UP_TIMEOUT = 300.0
"""Seconds :meth:`ExplorerServer.stop` waits for the warm-up's kernel builds to finish."""


class ExplorerServer:
    """The explorer served on ``127.0.0.1:port`` (0: any free port) in a background thread.

    ``initial``: the specs and file names the page starts with (files must be in ``session``).
    """

    def __init__(self, session: Session, initial: list[str], port: int = 0) -> None:
        self.session, self.token = session, secrets.token_urlsafe(24)
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._socket.bind(("127.0.0.1", port))
        self._socket.listen(64)  # connections wait in the backlog until uvicorn serves
        self.port = self._socket.getsockname()[1]
        self.app = build_app(session, self.token, self.port, initial)
        specs = [item for item in initial if item not in session.files]
        files = [item for item in initial if item in session.files]
        self._warm_up = threading.Thread(target=_warm_up, args=(session, specs, files), daemon=True)
        self._warm_up.start()
        self._server: Any = None
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """The page's address, token included."""
        return f"http://127.0.0.1:{self.port}/{self.token}/"

    def _uvicorn(self) -> Any:
        uvicorn = require_extra("uvicorn")
        config = uvicorn.Config(
            self.app,
            log_level="warning",
            ws_max_size=MAX_MESSAGE_BYTES,
            ws_per_message_deflate=False,  # float arrays barely compress; zlib costs more
            lifespan="off",
        )
        self._server = uvicorn.Server(config)
        return self._server

    def serve_forever(self) -> None:
        """Serve in this thread until interrupted."""
        asyncio.run(self._uvicorn().serve(sockets=[self._socket]))

    def start(self) -> ExplorerServer:
        """Serve in a daemon thread; returns once the server accepts connections."""
        server = self._uvicorn()
        self._thread = threading.Thread(
            target=lambda: asyncio.run(server.serve(sockets=[self._socket])), daemon=True
        )
        self._thread.start()
        while not server.started:
            if not self._thread.is_alive():
                raise RuntimeError("the explorer server did not start")
            threading.Event().wait(0.01)
        return self

    def stop(self) -> None:
        """Stop serving, let the warm-up finish (it uses the session), and remove the session's
        uploads. A stopped server leaves no thread of its own running."""
        if self._server is not None:
            self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._warm_up.join(timeout=WARM_UP_TIMEOUT)
        self._socket.close()
        self.session.close()


@functools.cache
def _material_choices() -> list[list[str]]:
    """``[fit, name, spec]`` of every real-material preset, for the page's material picker."""
    from brdfkit.brdf.presets import catalogue

    return [[r["fit"], r["name"], r["spec"]] for r in catalogue()]


__all__ = ["STATIC", "ExplorerServer", "Guard", "build_app"]
