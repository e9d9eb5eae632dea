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
import contextlib
import functools
import secrets
import socket
import threading
from collections.abc import Awaitable, Callable, MutableMapping
from importlib import resources
from pathlib import Path
from typing import Any

from brdfkit.errors import BrdfkitError
from brdfkit.explore.protocol import (
    MAX_MESSAGE_BYTES,
    Message,
    ProtocolError,
    encode_frame,
    parse_message,
)
from brdfkit.explore.session import MAX_UPLOAD_BYTES, Session, error_reply, fit_spec

Scope = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Any]]
Send = Callable[[Any], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

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


def build_app(session: Session, token: str, port: int, initial: list[str]) -> ASGIApp:
    """The guarded Starlette application serving ``session`` under ``/TOKEN/``.

    ``initial`` lists the specs and file names the page opens with.
    """
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import FileResponse, JSONResponse, Response
    from starlette.routing import Mount, Route, WebSocketRoute
    from starlette.staticfiles import StaticFiles
    from starlette.websockets import WebSocket, WebSocketDisconnect

    async def index(request: Request) -> Response:
        return FileResponse(STATIC / "index.html", headers=SECURITY_HEADERS)

    async def config(request: Request) -> Response:
        return JSONResponse(
            {
                "initial": initial,
                "files": session.files,
                "envmap": session.envmap_name,
                "max_upload": MAX_UPLOAD_BYTES,
                "materials": _material_choices(),  # the picker of static/materials.js
            },
            headers=SECURITY_HEADERS,
        )

    def too_large(name: str, size: str) -> Response:
        message = (
            f"{name[:60]!r} holds {size} bytes; an upload holds at most "
            f"{MAX_UPLOAD_BYTES >> 20} MiB ({MAX_UPLOAD_BYTES} bytes)"
        )
        return JSONResponse({"error": message}, 413, headers=SECURITY_HEADERS)

    async def upload(request: Request) -> Response:
        name = request.query_params.get("name", "")
        length = request.headers.get("content-length", "")
        if length.isdigit() and int(length) > MAX_UPLOAD_BYTES:
            return too_large(name, length)
        data = bytearray()
        async for chunk in request.stream():
            data += chunk
            if len(data) > MAX_UPLOAD_BYTES:
                return too_large(name, f"more than {MAX_UPLOAD_BYTES}")
        if name.lower().endswith(".json"):  # a fit.json: its spec, no file kept
            try:
                spec = fit_spec(bytes(data), name[:60])
            except (BrdfkitError, ValueError) as error:
                return JSONResponse({"error": str(error)[:500]}, 400, headers=SECURITY_HEADERS)
            return JSONResponse({"spec": spec}, headers=SECURITY_HEADERS)
        try:
            key = await asyncio.to_thread(session.add_upload, name, bytes(data))
        except (BrdfkitError, ValueError, OSError) as error:
            return JSONResponse({"error": str(error)[:500]}, 400, headers=SECURITY_HEADERS)
        return JSONResponse({"name": key}, headers=SECURITY_HEADERS)

    async def channel(ws: WebSocket) -> None:
        await ws.accept()
        # Latest-wins slots: a message waiting in a slot is replaced by a newer one of its kind,
        # so a slider that moves faster than the renders skips the stale states. Renders run in
        # one worker; the slow albedo curves and physics checks in another, so they never hold
        # up the next image.
        pending: dict[str, Message | None] = {"render": None, "albedo": None, "checks": None}
        wakes = {"fast": asyncio.Event(), "slow": asyncio.Event()}
        lock = asyncio.Lock()

        async def reply(replies: list[tuple[dict[str, Any], list[Any]]]) -> None:
            async with lock:
                for header, arrays in replies:
                    await ws.send_bytes(encode_frame(header, [a.tobytes() for a in arrays]))

        async def work(wake: asyncio.Event, kinds: tuple[str, ...]) -> None:
            while True:
                await wake.wait()
                wake.clear()
                for kind in kinds:
                    message, pending[kind] = pending[kind], None
                    if message is None:
                        continue
                    run = {"render": session.render, "albedo": session.albedo}.get(kind)
                    try:
                        if run is None:
                            result = await asyncio.to_thread(session.checks, message)
                        else:
                            stale = lambda k=kind: pending[k] is not None  # noqa: E731
                            result = await asyncio.to_thread(run, message, stale)
                    except (BrdfkitError, ValueError) as error:
                        result = error_reply(message.seq, error)
                    if result is not None:
                        await reply([result])
                    if kind == "render" and result is not None:
                        pending["albedo"] = message
                        wakes["slow"].set()
                    if any(pending[k] is not None for k in kinds):
                        wake.set()

        env: dict[str, Any] = {"message": None, "cancel": threading.Event()}
        wakes["env"] = asyncio.Event()

        async def environment() -> None:
            # The environment-lit spheres, pass by pass; a newer render cancels the old one.
            while True:
                await wakes["env"].wait()
                wakes["env"].clear()
                message, env["message"] = env["message"], None
                if message is None:
                    continue
                cancel = env["cancel"] = threading.Event()
                passes = session.environment(message, cancel)
                while not cancel.is_set():
                    result = await asyncio.to_thread(next, passes, None)
                    if result is None or cancel.is_set():
                        break
                    await reply([result])

        workers = [
            asyncio.create_task(work(wakes["fast"], ("render",))),
            asyncio.create_task(work(wakes["slow"], ("checks", "albedo"))),
            asyncio.create_task(environment()),
        ]
        try:
            while True:
                event = await ws.receive()
                if event["type"] == "websocket.disconnect":
                    break
                text = event.get("text")
                try:
                    if text is None:
                        raise ProtocolError("messages must be JSON text")
                    message = parse_message(text)
                except ProtocolError as error:
                    await reply([error_reply(0, error)])
                    continue
                pending[message.type] = message
                wakes["fast" if message.type == "render" else "slow"].set()
                if message.type == "render":
                    env["cancel"].set()
                    env["message"] = message
                    wakes["env"].set()
        except WebSocketDisconnect:
            pass
        finally:
            for worker in workers:
                worker.cancel()
            for worker in workers:
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await worker

    routes = [
        Mount(
            f"/{token}",
            routes=[
                Route("/", index),
                Route("/config", config),
                Route("/upload", upload, methods=["POST"]),
                WebSocketRoute("/ws", channel),
                Mount("/static", StaticFiles(directory=STATIC)),
            ],
        )
    ]
    app = Starlette(routes=routes)
    return Guard(app, token, port)


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
        self._warm_up = threading.Thread(target=session.warm_up, args=(specs,), daemon=True)
        self._warm_up.start()
        self._server: Any = None
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        """The page's address, token included."""
        return f"http://127.0.0.1:{self.port}/{self.token}/"

    def _uvicorn(self) -> Any:
        import uvicorn

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
